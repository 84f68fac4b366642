// libFuzzer target: one mesh format through crumple::loadMeshFile (the reader crumple-sim uses), the input written
// to a temporary file with the format's extension (CRUMPLE_FUZZ_EXT: .obj, .off, .ply, .gltf, .glb). A MeshError
// is the answer to a broken file; anything else escaping, a crash, a leak, undefined behaviour, a run over
// -timeout or memory over -rss_limit_mb is a finding.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <crumple/core/log.h>
#include <crumple/engine/mesh_io.h>

namespace fs = std::filesystem;

namespace {
fs::path folder;  // this process's own: fuzzing jobs run side by side
fs::path input;
}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  crumple::setLogLevel(crumple::LogLevel::Error);  // "dropped N duplicate faces"
  const char* tmp = std::getenv("TMPDIR");
  folder = fs::path(tmp && *tmp ? tmp : "/tmp") / ("crumple-fuzz-" + std::to_string(getpid()));
  fs::create_directories(folder);
  input = folder / (std::string("input") + CRUMPLE_FUZZ_EXT);
  std::atexit([] {
    std::error_code ec;
    fs::remove_all(folder, ec);
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  {
    std::ofstream out(input, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    crumple::loadMeshFile(input.string());
  } catch (const crumple::MeshError&) {
  }
  return 0;
}
