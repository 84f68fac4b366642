// Friction: sticking and sliding on an incline, rolling, tipping while
// sliding to a stop, torsional friction.
#include <doctest/doctest.h>

#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include "physics_fixture.h"

using namespace crumple;
using namespace crumple::test;
using doctest::Approx;

namespace {
// A box resting on an incline of angle theta (rotated about z); returns the
// displacement along the slope after `seconds` and the measured acceleration.
struct InclineResult {
  double travel, accel;
};
InclineResult inclineRun(double thetaDeg, double mu, double seconds) {
  World w;
  const double th = glm::radians(thetaDeg);
  const glm::dquat rot = glm::angleAxis(th, glm::dvec3(0, 0, 1));
  addIncline(w, rot, mu);
  BodyDef box;
  box.shape = makeBox({0.4, 0.4, 0.4});
  box.orientation = rot;
  box.origin = rot * glm::dvec3(0, 0.2 + 0.001, 0);
  box.friction = mu;
  box.restitution = 0;
  w.settings().sleeping = false;
  const int i = w.addBody(box);
  const glm::dvec3 down = rot * glm::dvec3(-1, 0, 0);  // down the slope
  const glm::dvec3 x0 = w.body(i).x;
  const double h = 1.0 / 240;
  const int n = static_cast<int>(seconds / h);
  double v1 = 0;
  for (int s = 0; s < n; ++s) {
    w.step(h);
    if (s == n / 2) v1 = glm::dot(w.body(i).v, down);
  }
  const double v2 = glm::dot(w.body(i).v, down);
  return {glm::dot(w.body(i).x - x0, down), (v2 - v1) / (h * (n - 1 - n / 2))};
}
}  // namespace

TEST_CASE("a block on an incline sticks when mu > tan(theta)") {
  // tan(20 deg) = 0.364
  const InclineResult r = inclineRun(20, 0.5, 2.0);
  CHECK(std::abs(r.travel) < 0.01);
}

TEST_CASE("a block on an incline slides with a = g (sin theta - mu cos theta)") {
  const double theta = 30, mu = 0.2;
  const InclineResult r = inclineRun(theta, mu, 1.0);
  const double expected = 9.81 * (std::sin(glm::radians(theta)) - mu * std::cos(glm::radians(theta)));
  CHECK(r.accel == Approx(expected).epsilon(0.05));
  CHECK(r.travel > 0.5 * expected * 0.8 * 0.8);
}

TEST_CASE("a ball rolls down an incline without slipping: a = 5/7 g sin(theta), v = omega r") {
  World w;
  w.settings().sleeping = false;
  const double th = glm::radians(20.0), r = 0.2;
  const glm::dquat rot = glm::angleAxis(th, glm::dvec3(0, 0, 1));
  addIncline(w, rot, 0.8);
  BodyDef ball;
  ball.shape = makeSphere(r);
  ball.origin = rot * glm::dvec3(0, r, 0);
  ball.friction = 0.8;
  ball.restitution = 0;
  const int i = w.addBody(ball);
  const glm::dvec3 down = rot * glm::dvec3(-1, 0, 0);
  const double h = 1.0 / 240;
  for (int s = 0; s < 240; ++s) w.step(h);
  const double t = w.time();
  const double v = glm::dot(w.body(i).v, down);
  const double expected = 5.0 / 7.0 * 9.81 * std::sin(th) * t;
  MESSAGE("after " << t << " s: v " << v << " m/s (rolling predicts " << expected << "), omega r "
                   << glm::length(w.body(i).w) * r);
  CHECK(v == Approx(expected).epsilon(0.01));
  CHECK(glm::length(w.body(i).w) * r == Approx(v).epsilon(0.01));
  CHECK(std::abs(glm::dot(w.body(i).v, rot * glm::dvec3(0, 1, 0))) < 0.01);  // it stays on the slope
}

TEST_CASE("a tall box sliding to a stop tips over exactly when mu h/2 > w/2") {
  // Friction at the floor decelerates the box and turns it forward; the
  // floor's pressure moves to the leading edge to hold it, and can hold it
  // while mu (h/2) <= w/2: for 0.2 x 0.8 x 0.2, up to mu = 0.25.
  for (double mu : {0.2, 0.3}) {
    CAPTURE(mu);
    World w;
    addGround(w, mu, 0.0);
    const int i = addBox(w, {0.2, 0.8, 0.2}, {0, 0.4, 0}, mu, 0.0);
    w.setVelocity(i, {3, 0, 0});
    double tilt = 0;
    for (int s = 0; s < 480; ++s) {
      w.step(1.0 / 240);
      tilt = std::max(tilt, glm::angle(w.body(i).q));
    }
    if (mu < 0.25) {
      CHECK(tilt < 0.05);
      CHECK(w.body(i).x.x == Approx(9.0 / (2 * mu * 9.81)).epsilon(0.02));  // v^2 / (2 mu g)
    } else {
      CHECK(glm::angle(w.body(i).q) == Approx(glm::half_pi<double>()).epsilon(0.02));  // on its side
    }
  }
}

TEST_CASE("a box spun on the floor stops by torsional friction in about the analytic time") {
  // A uniformly pressed square of half side a resists twist with mu m g times
  // its mean lever 0.77 a: t_stop = omega0 I / (mu m g 0.77 a), I = m (2a)^2 / 6.
  World w;
  const double mu = 0.5, a = 0.2, omega0 = 4.0;
  addGround(w, mu, 0.0);
  BodyDef d;
  d.shape = makeBox({2 * a, 2 * a, 2 * a});
  d.origin = {0, a, 0};
  d.friction = mu;
  d.restitution = 0;
  d.angularVelocity = {0, omega0, 0};
  const int i = w.addBody(d);
  const double tStop = omega0 * (4 * a * a / 6) / (mu * 9.81 * 0.77 * a);
  const double h = 1.0 / 240;
  double atHalf = 0;
  for (int s = 1; s <= static_cast<int>(2 * tStop / h); ++s) {
    w.step(h);
    if (s == static_cast<int>(0.5 * tStop / h)) atHalf = w.body(i).w.y;
  }
  MESSAGE("spin at t_stop/2 = " << atHalf << " rad/s (analytic " << omega0 / 2 << "), at 2 t_stop " << w.body(i).w.y);
  CHECK(atHalf == Approx(omega0 / 2).epsilon(0.25));
  CHECK(std::abs(w.body(i).w.y) < 0.05 * omega0);
  CHECK(glm::length(glm::dvec2(w.body(i).x.x, w.body(i).x.z)) < 0.01);  // it spins in place
}
