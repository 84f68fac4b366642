// libFuzzer target: random physics scenarios (tests/physics_scenario.h) must keep
// every invariant at every step; a broken one is printed and aborts (a finding).
#include <cstdio>
#include <cstdlib>

#include "../physics_scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string failure = crumple::test::runScenario(data, size);
  if (!failure.empty()) {
    std::fprintf(stderr, "physics invariant broken: %s\n", failure.c_str());
    std::abort();
  }
  return 0;
}
