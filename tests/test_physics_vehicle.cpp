// The raycast vehicle on a world: springs, engine, steering, brakes.
#include <doctest/doctest.h>

#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include "physics/vehicle.h"
#include "physics_fixture.h"

using namespace crumple;
using namespace crumple::test;
using doctest::Approx;

TEST_CASE("a raycast vehicle rests on its springs, accelerates, steers and brakes") {
  World w;
  BodyDef ground;
  ground.shape = makeBox({400, 1, 400});
  ground.origin = {0, -0.5, 0};
  ground.isStatic = true;
  ground.friction = 1.0;
  w.addBody(ground);
  BodyDef car;
  car.shape = makeBox({4.0, 0.8, 1.8});
  car.origin = {0, 0.9, 0};
  car.mass = 1200;
  car.friction = 0.5;
  const int i = w.addBody(car);
  VehicleParams p;
  p.wheels = {{1.3, -0.4, 0.8}, {1.3, -0.4, -0.8}, {-1.3, -0.4, 0.8}, {-1.3, -0.4, -0.8}};
  p.wheelRadius = 0.33;
  p.suspensionRest = 0.3;
  Vehicle v(i, p);
  const double h = 1.0 / 240;
  auto run = [&](VehicleControls c, double seconds) {
    for (int s = 0; s < static_cast<int>(seconds / h); ++s) {
      v.apply(w, c, h);
      w.step(h);
    }
  };
  run({}, 2.0);
  // At rest the springs carry the weight: compression = m g / (4 k).
  const double expected = 1200 * 9.81 / (4 * p.stiffness);
  for (const auto& wheel : v.wheels()) {
    CHECK(wheel.onGround);
    CHECK(wheel.compression == Approx(expected).epsilon(0.05));
  }
  CHECK(std::abs(v.speed(w)) < 0.01);
  run({1.0, 0, 0, false}, 1.0);
  const double speed = v.speed(w);
  // Full throttle: a = F / m (no drag), friction permitting.
  CHECK(speed == Approx(p.engineForce / 1200 * 1.0).epsilon(0.1));
  const glm::dvec3 heading0 = w.body(i).rotation() * glm::dvec3(1, 0, 0);
  run({0.0, 0.4, 0, false}, 1.0);
  const glm::dvec3 heading1 = w.body(i).rotation() * glm::dvec3(1, 0, 0);
  CHECK(glm::cross(heading0, heading1).y > 0.1);  // steering left turns the car about +y
  run({0, 0, 1.0, false}, 4.0);
  CHECK(std::abs(v.speed(w)) < 0.05);  // brakes stop it
  CHECK(w.body(i).x.y == Approx(0.9).epsilon(0.1));
}

namespace {
// The documented car-into-wall scene's car (docs/scene-format.md) on its road, at rest, 240 Hz: the largest
// vertical velocity change in one step over `seconds`, the largest speed, and the first step's change.
struct SettleResult {
  double firstStep = 0, largestChange = 0, fastest = 0;
};
SettleResult settleCar(double mass, double stiffness, double damping, double seconds) {
  World w;
  BodyDef road;
  road.shape = makeBox({40, 0.4, 10});
  road.origin = {10, -0.2, 0};
  road.isStatic = true;
  road.friction = 1.0;
  w.addBody(road);
  BodyDef car;
  car.shape = makeBox({4, 1, 1.8});
  car.origin = {0, 0.75, 0};
  car.mass = mass;
  const int i = w.addBody(car);
  VehicleParams p;
  p.wheels = {{1.3, -0.3, 1.0}, {1.3, -0.3, -1.0}, {-1.3, -0.3, 1.0}, {-1.3, -0.3, -1.0}};
  p.wheelRadius = 0.33;
  p.suspensionRest = 0.25;
  p.stiffness = stiffness;
  p.damping = damping;
  Vehicle v(i, p);
  const double h = 1.0 / 240;
  SettleResult r;
  for (int s = 0; s < static_cast<int>(seconds / h); ++s) {
    const double before = w.body(i).v.y;
    v.apply(w, {}, h);
    REQUIRE(w.step(h));
    const double change = std::abs(w.body(i).v.y - before);
    if (s == 0) r.firstStep = change;
    r.largestChange = std::max(r.largestChange, change);
    r.fastest = std::max(r.fastest, glm::length(w.body(i).v));
  }
  return r;
}
}  // namespace

TEST_CASE("a car set on its wheels settles without a kick, at any mass and damping the scene format accepts") {
  // The default car: its springs start compressed 13 cm (5.6 cm more than its weight needs).
  const SettleResult standard = settleCar(1200, 40000, 4000, 3);
  CHECK(standard.firstStep < 0.05);
  CHECK(standard.fastest < 0.5);
  // A 1 kg car on the same springs, and a damper of 1e9 N s/m: stiff, but no explosion.
  for (const auto& [mass, damping] : {std::pair{1.0, 4000.0}, std::pair{1200.0, 1e9}, std::pair{1.0, 1e9},
                                      std::pair{100.0, 4000.0}}) {
    CAPTURE(mass);
    CAPTURE(damping);
    const SettleResult r = settleCar(mass, 40000, damping, 3);
    CHECK(r.fastest < 50);
    CHECK(r.firstStep < 50);
  }
  // The stiffest springs the format accepts on a 1 kg car.
  CHECK(settleCar(1, 1e9, 4000, 3).fastest < 50);
}
