// Input files (scenes, meshes, bump-map images) are read only when they are regular files of a bounded size: a
// FIFO, a device (/dev/zero), a socket or a folder is refused before a byte is read, and so is a file over its
// bound (docs/scene-format.md, "Files").
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>

namespace crumple {

struct InputFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The largest scene file read (64 MiB).
constexpr std::uintmax_t kMaxSceneFileBytes = std::uintmax_t(64) << 20;
// The largest bump-map image read (256 MiB; its decoded map is at most 4096 x 4096).
constexpr std::uintmax_t kMaxImageFileBytes = std::uintmax_t(256) << 20;
// The largest mesh file read (1 GiB, engine/mesh_io_detail.h's kMaxFileBytes).
constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t(1) << 30;

// "1 GiB", "64 MiB": a bound as messages and the docs write it.
std::string byteSize(std::uintmax_t bytes);

// Why `path` is not read as `what` ("scene file", "mesh file", "image file"): "no such file", "is a folder, not a
// scene file", "is a FIFO (named pipe), not a regular file", "is larger than 64 MiB (...)"; "" when it is a
// regular file (links followed) of at most maxBytes. Looks at the file's type and size only (stat).
std::string inputFileProblem(const std::string& path, std::uintmax_t maxBytes, const char* what);

// The whole of `path`, read only after the checks of inputFileProblem (made again on the opened file, so a file
// swapped for a FIFO in between is refused too, and a file that grows past maxBytes while it is read).
// Throws InputFileError with the reason (without the path).
std::string readInputFile(const std::string& path, std::uintmax_t maxBytes, const char* what);

}  // namespace crumple
