// The physics fuzzer's invariants (physics_scenario.h) on its corpus
// (tests/fuzz/corpus/physics/: every case a fuzzing run found, kept as a
// regression) and on a range of generated scenes.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "physics_scenario.h"

using namespace crumple;

TEST_CASE("physics fuzz corpus: every kept case keeps the invariants") {
  const std::filesystem::path dir = std::filesystem::path(CRUMPLE_FUZZ_CORPUS) / "physics";
  REQUIRE(std::filesystem::is_directory(dir));
  int cases = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream f(entry.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    CAPTURE(entry.path().filename().string());
    CHECK(test::runScenario(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()) == "");
    ++cases;
  }
  CHECK(cases > 0);
}

TEST_CASE("physics fuzz: 200 generated scenes keep the invariants (spins, mass ratios, joints, kinematic paths, "
          "vehicles, overlaps)") {
  int sources = 0, vehicles = 0;
  for (uint32_t seed = 0; seed < 200; ++seed) {
    const uint8_t bytes[4] = {static_cast<uint8_t>(seed), static_cast<uint8_t>(seed >> 8), 0x5a, 0xc3};
    CAPTURE(seed);
    CHECK(test::runScenario(bytes, sizeof bytes) == "");
    test::ScenarioInput in(bytes, sizeof bytes);
    test::Scenario sc;
    test::buildScenario(sc, in);
    sources += sc.energySources;
    vehicles += !sc.vehicles.empty();
  }
  // The range covers both kinds: scenes held to conserve energy and scenes with sources, vehicles among them.
  CHECK(sources > 40);
  CHECK(sources < 180);
  CHECK(vehicles > 20);
}
