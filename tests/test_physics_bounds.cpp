// Corrections are bounded: a joint that starts violated and bodies that start
// deep inside each other part at most at WorldSettings::maxCorrectionSpeed,
// gaining no energy, instead of being flung apart in one step.
#include <algorithm>
#include <cmath>
#include <vector>

#include "physics_fixture.h"

using namespace crumple;
using namespace crumple::test;

namespace {
// The fastest any body moved over a step (displacement / h) or had as velocity, over `steps` steps.
struct Motion {
  double fastestMove = 0, fastestVelocity = 0;
};
Motion watch(World& w, double h, int steps) {
  Motion m;
  std::vector<glm::dvec3> last;
  for (const RigidBody& b : w.bodies()) last.push_back(b.x);
  for (int s = 0; s < steps; ++s) {
    REQUIRE(w.step(h));
    for (size_t i = 0; i < w.bodies().size(); ++i) {
      const RigidBody& b = w.bodies()[i];
      m.fastestMove = std::max(m.fastestMove, glm::length(b.x - last[i]) / h);
      m.fastestVelocity = std::max(m.fastestVelocity, glm::length(b.v));
      last[i] = b.x;
    }
  }
  return m;
}
}  // namespace

TEST_CASE("a slider whose limit starts 4.5 m away closes it at the correction speed, not in one step") {
  WorldSettings settings;
  settings.gravity = glm::dvec3(0);
  PhysicsTestContext t(240, settings);
  const int a = t.addBox({0.4, 0.4, 0.4}, {0, 1, 0}, 0.5, 0);
  const int b = t.addBox({0.4, 0.4, 0.4}, {0, 1, 0}, 0.5, 0);
  JointDef j;
  j.type = JointType::Slider;
  j.a = a;
  j.b = b;
  j.anchor = {0, 1, 0};
  j.axis = {1, 0, 0};
  j.limited = true;
  j.lower = 0;
  j.upper = 0.5;
  const int joint = t.world().addJoint(j);
  t.world().setPose(b, {{5, 1, 0}, glm::dquat(1, 0, 0, 0)});  // b moved 5 m along: 4.5 m past the upper limit
  const double speed = t.world().settings().maxCorrectionSpeed;
  const Motion m = watch(t.world(), 1.0 / 240, 2 * 240);
  MESSAGE("fastest move " << m.fastestMove << " m/s, velocity " << m.fastestVelocity << " m/s");
  // Equal masses: each closes half the gap, at half the relative speed at most.
  CHECK(m.fastestMove <= speed * (1 + 1e-6));
  CHECK(m.fastestVelocity <= speed * (1 + 1e-6));
  CHECK(m.fastestMove > 0.4 * speed);  // and it does close, at that speed
  // 4.5 m at 4 m/s: within the limits after 2 s.
  CHECK(t.world().jointState(joint).offset < 0.5 + 1e-3);
  CHECK(t.world().jointState(joint).offset > -1e-3);
}

TEST_CASE("a ball joint whose anchors start 3 m apart and a weld turned 2 rad close within the correction speed") {
  WorldSettings settings;
  settings.gravity = glm::dvec3(0);
  PhysicsTestContext t(240, settings);
  const int ball = t.addSphere(0.2, {3, 2, 0}, 0.5, 0);
  JointDef j;
  j.type = JointType::Ball;
  j.b = ball;
  j.anchor = {3, 2, 0};
  t.world().addJoint(j);
  t.world().setPose(ball, {{0, 2, 0}, glm::dquat(1, 0, 0, 0)});  // moved 3 m off its anchor
  const int box = t.addBox({0.5, 0.5, 0.5}, {0, 5, 0}, 0.5, 0);
  JointDef weld;
  weld.type = JointType::Fixed;
  weld.b = box;
  weld.anchor = {0, 5, 0};
  t.world().addJoint(weld);
  t.world().setPose(box, {{0, 5, 0}, glm::angleAxis(2.0, glm::dvec3(0, 0, 1))});  // turned 2 rad off its weld
  const double speed = t.world().settings().maxCorrectionSpeed;
  double fastestTurn = 0;
  Motion m;
  for (int s = 0; s < 240; ++s) {
    const Motion one = watch(t.world(), 1.0 / 240, 1);
    m.fastestMove = std::max(m.fastestMove, one.fastestMove);
    m.fastestVelocity = std::max(m.fastestVelocity, one.fastestVelocity);
    fastestTurn = std::max(fastestTurn, glm::length(t.body(box).w));
  }
  CHECK(m.fastestMove <= speed * (1 + 1e-6));
  CHECK(fastestTurn <= speed * (1 + 1e-6));
  CHECK(glm::length(t.body(ball).x - glm::dvec3(3, 2, 0)) < 1e-3);
  CHECK(std::abs(t.body(box).q.w) > std::cos(0.5e-3));  // back within 1 mrad of its weld
}

TEST_CASE("boxes inside a box grown to 10 km part at the correction speed and gain no energy") {
  PhysicsTestContext t(240);
  addGround(t.world());
  std::vector<int> small;
  for (int k = 0; k < 6; ++k) small.push_back(t.addBox({0.5, 0.5, 0.5}, {0.55 * k - 1.4, 0.25, 0}, 0.5, 0.2));
  t.addBox({10000, 10000, 10000}, {0, 0.25, 0}, 0.5, 0.2);  // all of them inside it, and deep in the ground
  const double speed = t.world().settings().maxCorrectionSpeed;
  const Motion m = watch(t.world(), 1.0 / 240, 240);
  MESSAGE("fastest move " << m.fastestMove << " m/s, velocity " << m.fastestVelocity << " m/s");
  // The projection moves a body at most `speed`; the impulses only take approach away (and gravity adds g t).
  CHECK(m.fastestMove <= speed + m.fastestVelocity + 1e-9);
  CHECK(m.fastestVelocity < 9.81 * 1.0 + 1.0);
}
