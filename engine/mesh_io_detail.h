// What the mesh readers share (mesh_io.cpp: OBJ and the dispatch, mesh_gltf.cpp, mesh_off_ply.cpp): the limits
// every format applies and a bounded line reader. Not installed: the readers' own business.
#pragma once
#include <cmath>
#include <cstdint>
#include <istream>
#include <string>

#include <crumple/engine/input_file.h>
#include <crumple/engine/mesh_io.h>
#include <crumple/engine/scene.h>

namespace crumple::meshio {

// The largest coordinate (and texture coordinate) any reader accepts: |x| <= 1e30. Beyond it a body's volume and
// inertia leave float range (a vertex at 3e38 is finite and still breaks them).
constexpr double kMaxCoordinate = 1e30;
// A glTF node's scale (and each axis of its matrix) must lie within [1e-6, 1e6] in magnitude.
constexpr double kMinNodeScale = 1e-6, kMaxNodeScale = 1e6;
// The longest text line read (OBJ, ASCII OFF): a file of NUL bytes or one endless line is refused within it.
constexpr size_t kMaxLineBytes = 100000;
// The most triangles a mesh file may make (4194304; the sedan has 60000): a small glTF instancing one mesh from
// thousands of nodes, or a 1 GiB OBJ of faces, must not take gigabytes.
constexpr size_t kMaxTriangles = size_t(1) << 22;
// The largest mesh file read at all.
constexpr std::uintmax_t kMaxFileBytes = kMaxMeshFileBytes;

std::string lower(std::string s);
// A token of the file as a message quotes it: at most 40 characters.
inline std::string capToken(const std::string& token) { return capText(token, 40); }

// Parses all of `token` as a number. Returns "" when it is one with |x| <= limit, else the reason.
std::string parseNumber(const std::string& token, double limit, double& out);

// Reads text lines with a bound: a NUL byte or a line over kMaxLineBytes is a MeshError naming the line.
class LineReader {
 public:
  LineReader(std::istream& in, const std::string& path, const char* what) : in_(in), path_(path), what_(what) {}
  // The next line (without its '\n' and a trailing '\r'); false at the end of the file.
  bool next(std::string& line);
  int lineNo() const { return lineNo_; }
  [[noreturn]] void fail(const std::string& why) const;

 private:
  std::istream& in_;
  std::string path_;
  const char* what_;
  int lineNo_ = 0;
};

}  // namespace crumple::meshio
