// Sleeping: stillness measured by motion, and only for islands that rest on something.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include "physics_fixture.h"
#include "test_meshes.h"

using namespace crumple;
using namespace crumple::test;
using doctest::Approx;

namespace {
// A kinematic box sliding at a constant velocity (it never sleeps).
int addSliding(World& w, const glm::dvec3& size, const glm::dvec3& origin, const glm::dvec3& velocity) {
  BodyDef k;
  k.shape = makeBox(size);
  k.origin = origin;
  k.kinematic = true;
  k.linearVelocity = velocity;
  return w.addBody(k);
}
}  // namespace

TEST_CASE("a stack of boxes falls asleep at 60 Hz as at 240 Hz (stillness by motion, not velocity)") {
  for (double hz : {60.0, 240.0}) {
    CAPTURE(hz);
    PhysicsTestContext c(hz);
    c.addGround(0.6, 0.0);
    std::vector<int> ids;
    for (int k = 0; k < 5; ++k) ids.push_back(c.addBox({0.5, 0.5, 0.5}, {0, 0.25 + 0.5 * k, 0}, 0.5, 0.0));
    // At 60 Hz gravity adds g h = 0.16 m/s a step, more than the sleep
    // threshold: a stacked box ends every step still approaching the one below
    // by about that much (the contact step stops penetration at the predicted
    // positions, the projection the rest), yet it does not move.
    c.simulateSteps(static_cast<int>(3 * hz));
    for (int k = 0; k < 5; ++k) {
      CAPTURE(k);
      CHECK(c.body(ids[static_cast<size_t>(k)]).asleep);
      CHECK(c.body(ids[static_cast<size_t>(k)]).x.y == Approx(0.25 + 0.5 * k).epsilon(0.01));
    }
  }
}

TEST_CASE("a slow body in zero gravity never falls asleep: it keeps its momentum") {
  World w;
  w.settings().gravity = glm::dvec3(0);
  BodyDef d;
  d.shape = makeBox({0.3, 0.3, 0.3});
  d.linearVelocity = {0.02, 0, -0.01};  // below the sleep thresholds
  d.angularVelocity = {0, 0.03, 0};
  const int i = w.addBody(d);
  for (int s = 0; s < 480; ++s) w.step(1.0 / 240);  // 2 s, four times the sleep time
  CHECK(!w.body(i).asleep);
  CHECK(w.body(i).v.x == Approx(0.02));
  CHECK(w.body(i).v.z == Approx(-0.01));
  CHECK(w.body(i).x.x == Approx(0.04).epsilon(0.01));
}

TEST_CASE("a sleeping stack is still met: a box dropped on it wakes it and rests on top; a moving kinematic body wakes a sleeper") {
  // The broad phase tests no pair of two bodies that cannot make one (asleep, static, still kinematic) and
  // builds no grid while nothing can: what wakes must still find the sleepers.
  PhysicsTestContext c(240);
  c.addGround(0.6, 0.0);
  std::vector<int> stack;
  for (int k = 0; k < 3; ++k) stack.push_back(c.addBox({0.5, 0.5, 0.5}, {0, 0.25 + 0.5 * k, 0}, 0.5, 0.0));
  const int lone = c.addBox({0.5, 0.5, 0.5}, {3, 0.25, 0}, 0.5, 0.0);
  c.simulateSteps(3 * 240);
  for (int i : stack) REQUIRE(c.body(i).asleep);
  REQUIRE(c.body(lone).asleep);
  c.simulateSteps(10);  // a world that is all asleep steps on
  CHECK(c.world().lastStats().pairs == 0);
  // A box dropped from 1 m onto the stack: it lands on the top box and stays there.
  const int dropped = c.addBox({0.5, 0.5, 0.5}, {0, 2.75, 0}, 0.5, 0.0);
  c.simulateSteps(240);
  CHECK(c.body(dropped).x.y == Approx(1.75).epsilon(0.01));
  CHECK(std::abs(c.body(dropped).x.x) < 0.05);
  // A kinematic paddle sliding into the lone sleeping box wakes it and pushes it along.
  addSliding(c.world(), {0.2, 0.5, 0.5}, {2.2, 0.3, 0}, {1, 0, 0});
  c.simulateSteps(240);  // 1 s: the paddle's face travels from 2.3 m to 3.3 m, 0.55 m past the box's near face
  CHECK_FALSE(c.body(lone).asleep);
  CHECK(c.body(lone).x.x > 3.45);
}

TEST_CASE("a world asleep is left as it was: the same motion when woken, after 3 steps asleep or 300") {
  // Boxes, a ball, a capsule and a torus come to rest and fall asleep; the world then steps on asleep for a
  // while, and a box dropped onto it wakes it. Each pair's candidate lists and kept contacts, and each sleeping
  // body's bounds and rotation, wait out the asleep steps: what the woken bodies do may not depend on how long
  // they slept. All asleep, or beside a kinematic body that keeps moving far away (the world then steps in full).
  auto run = [](int asleepSteps, bool far, int& lastPairs) {
    PhysicsTestContext c(240);
    c.addGround(0.6, 0.0);
    for (int k = 0; k < 3; ++k) c.addBox({0.5, 0.5, 0.5}, {0.6 * k - 0.6, 0.25, 0}, 0.5, 0.0);
    c.addBox({0.5, 0.5, 0.5}, {-0.3, 0.75, 0}, 0.5, 0.0);
    c.addSphere(0.2, {0.6, 0.7, 0}, 0.5, 0.0);
    addShape(c.world(), makeCapsule(0.1, 0.4), {0, 0.12, 0.8}, 0.5, 0.0);
    addShape(c.world(), makeMeshShape(torusMesh(0.3f, 0.1f, 16, 8), 32), {0, 0.11, -0.9}, 0.5, 0.0);
    const int resting = static_cast<int>(c.world().size());
    if (far) addSliding(c.world(), {0.5, 0.5, 0.5}, {40, 0.5, 40}, {0.05, 0, 0});
    const int awakeAtRest = far ? 1 : 0;
    // The state of the bodies that rest (the far one moves on).
    auto restingHash = [&] {
      uint64_t h = 1469598103934665603ull;
      for (int i = 0; i < resting; ++i) {
        const RigidBody& b = c.body(i);
        for (const double v :
             {b.x.x, b.x.y, b.x.z, b.q.w, b.q.x, b.q.y, b.q.z, b.v.x, b.v.y, b.v.z, b.w.x, b.w.y, b.w.z}) {
          uint64_t bits;
          std::memcpy(&bits, &v, sizeof bits);
          h = (h ^ bits) * 1099511628211ull;
        }
      }
      return h;
    };
    for (int s = 0; s < 4 * 240 && (s == 0 || c.world().lastStats().awake > awakeAtRest); ++s)
      c.world().step(c.stepSize());
    REQUIRE(c.world().lastStats().awake == awakeAtRest);
    const uint64_t still = restingHash();
    c.simulateSteps(asleepSteps);
    CHECK(restingHash() == still);
    CHECK(c.world().lastStats().pairs == 0);
    CHECK(c.world().lastStats().awake == awakeAtRest);
    c.addBox({0.3, 0.3, 0.3}, {-0.25, 1.6, 0.05}, 0.5, 0.0);
    c.simulateSteps(150);  // (it lands after about 0.45 s; the world is still awake at 0.63 s)
    lastPairs = c.world().lastStats().pairs;
    CHECK(c.world().lastStats().awake > awakeAtRest);
    return restingHash();
  };
  for (bool far : {false, true}) {
    CAPTURE(far);
    int pairsShort = 0, pairsLong = 0;
    const uint64_t woken = run(3, far, pairsShort);
    MESSAGE("woken state hash " << woken);
    CHECK(run(300, far, pairsLong) == woken);
    CHECK(pairsShort == pairsLong);
    CHECK(pairsShort > 0);
  }
}
