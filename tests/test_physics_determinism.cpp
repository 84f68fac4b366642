// Determinism: the same scene twice gives the same bits, and a golden state
// hash pins them.
//
// The golden hash: a reference scene stepped a fixed number of times must
// end in exactly the same bits. Any change of the simulator's behaviour, however
// small (an operation reordered, a pass added), changes the hash; a pure
// restructuring does not. The physics library is built with -ffp-contract=off
// (and no fast-math), so the bits do not depend on the compiler's choice to
// fuse a*b+c; x86-64's SSE2 doubles do the rest.
//
// To change behaviour on purpose: check the rest of the suite and the shipped
// scenes' outputs, then replace kGoldenHash with the value this test prints
// when it fails, and say why in the commit.
#include <doctest/doctest.h>

#include <cinttypes>
#include <cstdio>
#include <string>

#include "physics_fixture.h"

using namespace crumple;
using namespace crumple::test;

namespace {

// A four-level box pyramid and a mixed pile of spinning boxes and spheres
// dropped onto it: collisions with events, resting contact with patches, shock
// propagation through the levels, the projection, and sleeping.
World& referenceScene(PhysicsTestContext& c) {
  c.addGround(0.6, 0.1);
  const int levels = 4;
  for (int row = 0; row < levels; ++row)
    for (int k = 0; k < levels - row; ++k)
      c.addBox({0.5, 0.5, 0.5}, {(k - (levels - row - 1) / 2.0) * 0.51, 0.25 + row * 0.5, 0}, 0.6, 0.1);
  for (int k = 0; k < 8; ++k) {
    BodyDef d;
    d.shape = k % 2 ? makeBox({0.3, 0.2, 0.4}) : makeSphere(0.15);
    d.origin = {0.1 * (k % 3) - 0.1, 2.6 + 0.45 * k, 0.05 * (k % 4)};
    d.angularVelocity = {0.1 * k, 0, 0.2};
    d.friction = 0.5;
    d.restitution = 0.3;
    c.add(d);
  }
  return c.world();
}

std::string hex(uint64_t h) {
  char s[32];
  std::snprintf(s, sizeof s, "0x%016" PRIx64, h);
  return s;
}

}  // namespace

TEST_CASE("golden state hash: a pyramid with a mixed pile dropped on it, 3 s at 240 Hz") {
  // Update on purpose only (see the top of this file).
  constexpr uint64_t kGoldenHash = 0xb4e4e7a83fdd8dccull;
  PhysicsTestContext c;
  World& w = referenceScene(c);
  int events = 0;
  for (int s = 0; s < 720; ++s) {
    w.step(c.stepSize());
    events += static_cast<int>(w.events().size());
  }
  const uint64_t h = w.stateHash();
  MESSAGE("reference scene: " << events << " collision events, " << w.lastStats().awake << " bodies awake at 3 s");
  CHECK_MESSAGE(h == kGoldenHash, "state hash "
                                      << hex(h) << ", golden " << hex(kGoldenHash)
                                      << ": the simulator's behaviour changed (update kGoldenHash only on purpose)");
}

TEST_CASE("the same scene twice gives bit-identical states") {
  auto run = [] {
    World w;
    addGround(w);
    for (int k = 0; k < 12; ++k) {
      BodyDef d;
      d.shape = k % 2 ? makeBox({0.3, 0.2, 0.4}) : makeSphere(0.15);
      d.origin = {0.1 * (k % 3), 0.5 + 0.45 * k, 0.05 * (k % 4)};
      d.angularVelocity = {0.1 * k, 0, 0.2};
      w.addBody(d);
    }
    for (int s = 0; s < 600; ++s) w.step(1.0 / 240);
    return w.stateHash();
  };
  CHECK(run() == run());
}
