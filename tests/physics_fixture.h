// The physics tests' shared fixture, in the style of Jolt's PhysicsTestContext:
// a world with a fixed step, helpers that add a ground, boxes and spheres, and
// "step for so many seconds". Every helper does exactly what the tests did by
// hand before (same BodyDef fields, same order), so scenes built with it step
// to the same bits.
#pragma once
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>

#include <crumple/physics/world.h>

namespace crumple::test {

// Uniform numbers in [0, 1) from a fixed linear congruential sequence: the same scene on every platform.
struct Uniform {
  uint64_t state;
  explicit Uniform(uint64_t seed) : state(seed) {}
  double operator()() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  }
};

// A static 40 x 1 x 40 m slab whose top face is the plane y = 0.
inline int addGround(World& w, double friction = 0.5, double restitution = 1.0) {
  BodyDef g;
  g.shape = makeBox({40, 1, 40});
  g.origin = {0, -0.5, 0};
  g.isStatic = true;
  g.friction = friction;
  g.restitution = restitution;
  return w.addBody(g);
}

// A dynamic body of `shape` whose shape frame is at `origin`.
inline int addShape(World& w, std::shared_ptr<const Shape> shape, const glm::dvec3& origin, double friction,
                    double restitution, double density = 1000) {
  BodyDef d;
  d.shape = std::move(shape);
  d.origin = origin;
  d.friction = friction;
  d.restitution = restitution;
  d.density = density;
  return w.addBody(d);
}

// A dynamic box of the given size whose shape frame (its centre) is at `origin`.
inline int addBox(World& w, const glm::dvec3& size, const glm::dvec3& origin, double friction, double restitution,
                  double density = 1000) {
  return addShape(w, makeBox(size), origin, friction, restitution, density);
}

// A dynamic sphere centred at `origin`.
inline int addSphere(World& w, double radius, const glm::dvec3& origin, double friction, double restitution,
                     double density = 1000) {
  return addShape(w, makeSphere(radius), origin, friction, restitution, density);
}

// A static slab whose top face is a plane through the origin tilted by `rot`.
inline int addIncline(World& w, const glm::dquat& rot, double mu) {
  BodyDef plane;
  plane.shape = makeBox({20, 1, 4});
  plane.orientation = rot;
  plane.origin = rot * glm::dvec3(0, -0.5, 0);
  plane.isStatic = true;
  plane.friction = mu;
  plane.restitution = 0;
  return w.addBody(plane);
}

// A world stepped at a fixed rate (240 Hz unless told).
class PhysicsTestContext {
 public:
  explicit PhysicsTestContext(double hz = 240, const WorldSettings& settings = {}) : world_(settings), hz_(hz) {}

  World& world() { return world_; }
  const World& world() const { return world_; }
  WorldSettings& settings() { return world_.settings(); }
  double stepSize() const { return 1.0 / hz_; }
  const RigidBody& body(int i) const { return world_.body(i); }

  int addGround(double friction = 0.5, double restitution = 1.0) {
    return test::addGround(world_, friction, restitution);
  }
  int addBox(const glm::dvec3& size, const glm::dvec3& origin, double friction, double restitution,
             double density = 1000) {
    return test::addBox(world_, size, origin, friction, restitution, density);
  }
  int addSphere(double radius, const glm::dvec3& origin, double friction, double restitution, double density = 1000) {
    return test::addSphere(world_, radius, origin, friction, restitution, density);
  }
  int add(const BodyDef& def) { return world_.addBody(def); }

  // Steps `steps` times at the context's rate.
  void simulateSteps(int steps) {
    for (int s = 0; s < steps; ++s) world_.step(1.0 / hz_);
  }
  // Steps for `seconds` (rounded to whole steps).
  void simulate(double seconds) { simulateSteps(static_cast<int>(std::lround(seconds * hz_))); }

 private:
  World world_;
  double hz_;
};

}  // namespace crumple::test
