// libFuzzer target: the scene loader (crumple::parseScene) on the input's bytes, with scenes/ as the folder that
// mesh and image paths are relative to. A SceneError is the answer to bad input; anything else escaping, a crash,
// a leak, undefined behaviour, a run over -timeout or memory over -rss_limit_mb is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include <crumple/core/log.h>
#include <crumple/engine/scene.h>

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  crumple::setLogLevel(crumple::LogLevel::Error);  // "unknown key, ignored" on every other input
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    crumple::parseScene(text, "fuzz.json", CRUMPLE_SCENES);
  } catch (const crumple::SceneError&) {
  }
  return 0;
}
