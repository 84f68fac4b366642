// Joints, kinematic bodies and collision filtering, tested against mechanics:
// a pendulum's period, chains that stay joined, limits that hold, motors that
// reach their speed within their torque, welds that break at their impulse,
// Newton's cradle, a ragdoll that lands without gaining energy.
#include <doctest/doctest.h>

#include <cmath>
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <vector>

#include "physics/world.h"
#include "physics_fixture.h"

using namespace crumple;
using namespace crumple::test;

namespace {

constexpr double kPi = 3.14159265358979323846;

double anchorGap(const World& w, int joint) {
  // The distance between the two bodies' copies of the anchor.
  const JointDef& d = w.jointDef(joint);
  (void)d;
  return w.jointState(joint).offset;
}

// World position of a body-frame point given relative to the centre of mass at creation.
glm::dvec3 pointOnBody(const World& w, int body, const glm::dvec3& localFromCom) {
  const RigidBody& b = w.body(body);
  return b.x + b.rotation() * localFromCom;
}

double kineticEnergy(const World& w) {
  double e = 0;
  for (const RigidBody& b : w.bodies()) {
    if (!b.dynamic()) continue;
    const glm::dmat3 r = b.rotation();
    const glm::dvec3 l = r * (b.inertiaBody * (glm::transpose(r) * b.w));
    e += 0.5 * b.mass * glm::dot(b.v, b.v) + 0.5 * glm::dot(b.w, l);
  }
  return e;
}

double potentialEnergy(const World& w) {
  double e = 0;
  for (const RigidBody& b : w.bodies())
    if (b.dynamic()) e += b.mass * 9.81 * b.x.y;
  return e;
}

}  // namespace

TEST_CASE("joints: a sphere on a ball joint swings with the physical pendulum's period and keeps its length") {
  PhysicsTestContext t;
  const double L = 1.0, r = 0.1, theta0 = 5.0 * kPi / 180;
  const glm::dvec3 pivot(0, 2, 0);
  const int ball = t.addSphere(r, pivot + glm::dvec3(L * std::sin(theta0), -L * std::cos(theta0), 0), 0.5, 0.5);
  JointDef j;
  j.type = JointType::Ball;
  j.a = -1;
  j.b = ball;
  j.anchor = pivot;
  t.world().addJoint(j);
  const double m = t.body(ball).mass;
  const double I = 0.4 * m * r * r + m * L * L;
  const double expected = 2 * kPi * std::sqrt(I / (m * 9.81 * L));
  // Period from the upward zero crossings of x (interpolated), over ~8 periods.
  std::vector<double> crossings;
  double prevX = t.body(ball).x.x, maxLengthError = 0;
  const double h = t.stepSize();
  for (int s = 0; s < static_cast<int>(8.5 * expected / h); ++s) {
    t.world().step(h);
    const double x = t.body(ball).x.x;
    if (prevX < 0 && x >= 0) crossings.push_back(t.world().time() - h * x / (x - prevX));
    prevX = x;
    maxLengthError = std::max(maxLengthError, std::abs(glm::length(t.body(ball).x - pivot) - L));
  }
  REQUIRE(crossings.size() >= 6);
  const double period = (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  MESSAGE("pendulum period " << period << " s, expected " << expected << " s, length error " << maxLengthError);
  CHECK(std::abs(period - expected) < 0.01 * expected);
  CHECK(maxLengthError < 0.002);
}

TEST_CASE("joints: a chain of 20 links hanging from one end stays joined, and so does a 100 kg body on 1 kg links") {
  for (int heavy = 0; heavy < 2; ++heavy) {
    CAPTURE(heavy);
    PhysicsTestContext t;
    const int links = heavy ? 10 : 20;
    const double len = 0.2;
    // Links laid out horizontally from the pivot, so the chain falls and swings.
    std::vector<int> body;
    std::vector<int> joint;
    const glm::dvec3 pivot(0, 5, 0);
    for (int i = 0; i < links; ++i) {
      BodyDef d;
      d.shape = makeBox({len, 0.04, 0.04});
      d.origin = pivot + glm::dvec3((i + 0.5) * len, 0, 0);
      d.mass = 1.0;
      body.push_back(t.world().addBody(d));
      JointDef j;
      j.type = JointType::Ball;
      j.a = i == 0 ? -1 : body[static_cast<size_t>(i - 1)];
      j.b = body.back();
      j.anchor = pivot + glm::dvec3(i * len, 0, 0);
      joint.push_back(t.world().addJoint(j));
    }
    if (heavy) {
      BodyDef d;
      d.shape = makeBox({0.3, 0.3, 0.3});
      d.origin = pivot + glm::dvec3(links * len + 0.15, 0, 0);
      d.mass = 100;
      body.push_back(t.world().addBody(d));
      JointDef j;
      j.type = JointType::Ball;
      j.a = body[static_cast<size_t>(links - 1)];
      j.b = body.back();
      j.anchor = pivot + glm::dvec3(links * len, 0, 0);
      joint.push_back(t.world().addJoint(j));
    }
    double worst = 0;
    for (int s = 0; s < 3 * 240; ++s) {
      t.world().step(t.stepSize());
      for (size_t k = 0; k < joint.size(); ++k) {
        // Gap between the end of one link and the start of the next (or the pivot).
        const glm::dvec3 start = pointOnBody(t.world(), body[k], glm::dvec3(-len / 2, 0, 0));
        const glm::dvec3 prevEnd = k == 0 ? pivot : pointOnBody(t.world(), body[k - 1], glm::dvec3(len / 2, 0, 0));
        const glm::dvec3 heavyStart =
            (heavy && k + 1 == joint.size()) ? pointOnBody(t.world(), body[k], glm::dvec3(-0.15, 0, 0)) : start;
        worst = std::max(worst, glm::length(heavyStart - prevEnd));
      }
    }
    MESSAGE(std::string(heavy ? "100 kg on 1 kg links" : "20 links") << ": largest gap " << worst * 1000 << " mm");
    CHECK(worst < 0.005);
    CHECK(std::isfinite(t.body(body.back()).x.y));
  }
}
