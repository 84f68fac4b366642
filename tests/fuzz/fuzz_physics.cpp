// libFuzzer target: random physics scenarios (tests/physics_scenario.h) must keep
// every invariant at every step; a broken one is printed and aborts (a finding).
#include <cstdio>
#include <cstdlib>

#include "../physics_scenario.h"

// CRUMPLE_FUZZ_JOINTS=1 adds joints to the scenes (physics_scenario.h says why they are off by default).
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool joints = [] {
    const char* v = std::getenv("CRUMPLE_FUZZ_JOINTS");
    return v && std::string(v) == "1";
  }();
  const std::string failure = crumple::test::runScenario(data, size, 120, nullptr, joints);
  if (!failure.empty()) {
    std::fprintf(stderr, "physics invariant broken: %s\n", failure.c_str());
    std::abort();
  }
  return 0;
}
