// Sleeping: stillness measured by motion, and only for islands that rest on something.
#include <doctest/doctest.h>

#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include "physics_fixture.h"

using namespace crumple;
using namespace crumple::test;
using doctest::Approx;

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
