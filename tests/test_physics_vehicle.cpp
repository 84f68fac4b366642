// The raycast vehicle on a world: springs, engine, steering, brakes.
#include <doctest/doctest.h>

#include <cmath>
#include <memory>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include <crumple/physics/vehicle.h>
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

namespace {
// A rut 3 cm deep and 0.4 m wide along x at z = +0.8 in the ground's top face (shape frame: the 1 m thick
// ground's top is y = 0.5), its floor flat, its walls sloped over 5 cm; nothing rises.
double rutDepth(const glm::dvec3& p, const glm::dvec3& n, glm::dvec3& bent) {
  bent = n;
  if (n.y < 0.9) return 0;
  const double off = std::abs(p.z - 0.8);
  if (off >= 0.25) return 0;
  if (off <= 0.2) return 0.03;
  bent = glm::normalize(glm::dvec3(0, 0.05, (p.z > 0.8 ? -1 : 1) * 0.03));  // the wall's slope
  return 0.03 * (0.25 - off) / 0.05;
}
}  // namespace

TEST_CASE("a ray and a vehicle's wheels feel a rut in a dented ground; undented, nothing changes bit for bit") {
  auto world = [](bool dented) {
    auto w = std::make_unique<World>();
    BodyDef ground;
    ground.shape = makeBox({400, 1, 400});
    ground.origin = {0, -0.5, 0};
    ground.isStatic = true;
    ground.friction = 1.0;
    const int g = w->addBody(ground);
    w->setSurfaceDepth([g](int body, const glm::dvec3& p, const glm::dvec3& n, glm::dvec3& bent) {
      return body == g ? rutDepth(p, n, bent) : (bent = n, 0.0);
    });
    if (dented) w->setDented(g, 0.0, {glm::dvec3(-200, 0.4, 0.5), glm::dvec3(200, 0.6, 1.1)});
    return w;
  };
  // Rays straight down from 1 m: onto the rut's floor, its wall, and beside it.
  for (bool dented : {false, true}) {
    auto w = world(dented);
    RayHit floor, wall, beside;
    REQUIRE(w->raycast({3, 1, 0.8}, {0, -1, 0}, 5, -1, floor));
    REQUIRE(w->raycast({3, 1, 1.025}, {0, -1, 0}, 5, -1, wall));
    REQUIRE(w->raycast({3, 1, 0}, {0, -1, 0}, 5, -1, beside));
    CHECK(beside.distance == Approx(1.0).epsilon(1e-4));
    CHECK(beside.normal.y == Approx(1.0));
    if (dented) {
      CHECK(floor.distance == Approx(1.03).epsilon(2e-4));
      CHECK(wall.distance == Approx(1.015).epsilon(2e-4));
      CHECK(wall.normal.z < -0.4);  // the wall faces back into the rut
    } else {
      CHECK(floor.distance == Approx(1.0).epsilon(1e-4));
    }
  }
  // A car with its left wheels (z = +0.8) in the rut settles 3 cm lower on that side: it rolls towards it.
  auto settle = [&](bool dented) {
    auto w = world(dented);
    BodyDef car;
    car.shape = makeBox({4.0, 0.8, 1.8});
    car.origin = {0, 0.9, 0};
    car.mass = 1200;
    const int i = w->addBody(car);
    VehicleParams p;
    p.wheels = {{1.3, -0.4, 0.8}, {1.3, -0.4, -0.8}, {-1.3, -0.4, 0.8}, {-1.3, -0.4, -0.8}};
    p.wheelRadius = 0.33;
    p.suspensionRest = 0.3;
    Vehicle v(i, p);
    for (int s = 0; s < 480; ++s) {
      v.apply(*w, {}, 1.0 / 240);
      w->step(1.0 / 240);
    }
    return std::make_pair(w->body(i).x, w->body(i).rotation() * glm::dvec3(0, 0, 1));
  };
  const auto [flatX, flatSide] = settle(false);
  const auto [rutX, rutSide] = settle(true);
  MESSAGE("car centre " << flatX.y << " m on flat ground, " << rutX.y << " m with its left wheels in the rut; side "
                        << "axis y " << flatSide.y << " -> " << rutSide.y);
  CHECK(std::abs(flatSide.y) < 1e-4);
  // Left side 3 cm lower across the 1.6 m track: the side axis (+z, towards the left) tips down by ~0.03 / 1.6.
  CHECK(rutSide.y == Approx(-0.03 / 1.6).epsilon(0.15));
  CHECK(rutX.y < flatX.y - 0.01);
}
