// Physics against physics: analytic answers, conservation laws, stacking, tunnelling.
#include <doctest/doctest.h>

#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include "physics/impulse.h"
#include "physics/stress_strain.h"
#include "physics/world.h"

using namespace crumple;
using doctest::Approx;

namespace {
int addGround(World& w, double friction = 0.5, double restitution = 1.0) {
  BodyDef g;
  g.shape = makeBox({40, 1, 40});
  g.origin = {0, -0.5, 0};
  g.isStatic = true;
  g.friction = friction;
  g.restitution = restitution;
  return w.addBody(g);
}
int addBox(World& w, const glm::dvec3& size, const glm::dvec3& origin, double friction, double restitution,
           double density = 1000) {
  BodyDef d;
  d.shape = makeBox(size);
  d.origin = origin;
  d.friction = friction;
  d.restitution = restitution;
  d.density = density;
  return w.addBody(d);
}
}  // namespace

TEST_CASE("eq. 4: two point masses head-on") {
  const glm::dvec3 n(1, 0, 0);
  const glm::dvec3 j = pointMassImpulse(n, 0.5, {2, 0, 0}, {-1, 0, 0}, 2.0, 1.0);
  // u.n = -3, 1/mA + 1/mB = 1.5  =>  j = 1.5 * 3 / 1.5 = 3 along +x on B.
  CHECK(j.x == Approx(3.0));
  // The general K formula with r = 0 agrees.
  ImpulseSide a{0.5, glm::dmat3(0), {}}, b{1.0, glm::dmat3(0), {}};
  const glm::dvec3 jk = frictionlessImpulse(collisionMatrix(a, b), glm::dvec3(-3, 0, 0), n, 0.5);
  CHECK(jk.x == Approx(3.0));
  // Separating: no impulse.
  CHECK(glm::length(frictionlessImpulse(collisionMatrix(a, b), glm::dvec3(1, 0, 0), n, 0.5)) == 0.0);
}

TEST_CASE("impulse at an offset point uses the inertia") {
  // A static A; B a unit-mass body with inertia I = diag(0.1) hit at r = (0, 0.5, 0) along x:
  // n.K.n = 1/m + r_y^2 / I_zz = 1 + 0.25/0.1 = 3.5.
  ImpulseSide a{}, b{1.0, glm::dmat3(10.0), {0, 0.5, 0}};
  const glm::dmat3 K = collisionMatrix(a, b);
  CHECK(glm::dot(glm::dvec3(1, 0, 0), K * glm::dvec3(1, 0, 0)) == Approx(3.5));
  const glm::dvec3 j = frictionlessImpulse(K, {-2, 0, 0}, {1, 0, 0}, 1.0);
  CHECK(j.x == Approx(4.0 / 3.5));
}

TEST_CASE("friction impulse stays in the cone and adds no energy") {
  ImpulseSide a{}, b{1.0, glm::dmat3(6.0), {0.1, -0.5, 0.2}};
  const glm::dmat3 K = collisionMatrix(a, b);
  const glm::dvec3 n(0, 1, 0);
  for (double mu : {0.0, 0.2, 0.5, 1.5}) {
    for (glm::dvec3 u : {glm::dvec3(3, -1, 0), glm::dvec3(0.1, -2, 0.3), glm::dvec3(-5, -0.5, 2)}) {
      const glm::dvec3 j = frictionImpulse(K, u, n, 0.3, mu);
      const double jn = glm::dot(j, n);
      CHECK(jn >= 0);
      CHECK(glm::length(j - jn * n) <= mu * jn + 1e-9);
      CHECK(glm::dot(j, u) + 0.5 * glm::dot(j, K * j) <= 1e-9);
    }
  }
}

namespace {
// B rests on a static A with its contact point 0.1 m off its centre of mass,
// sinking, tilting and twisting. Unit mass, inertia diag(1/6) (a unit cube);
// a square patch of half side `half` about the point, first axis `t1`.
struct PatchCase {
  glm::dvec3 n{0, 1, 0}, r{0.1, -0.5, 0}, v{0, -1, 0}, w{0.3, 0.4, 0.2};
  glm::dmat3 invI{6.0};
  ImpulseSide a{}, b{1.0, invI, r};
  ImpulseMatrix k{collisionMatrix(a, b)};
  PatchExtent e;
  PatchCase(const glm::dvec3& t1, double half) {
    e.n = n;
    e.t1 = t1;
    e.t2 = glm::cross(n, e.t1);
    e.lo1 = e.lo2 = -half;
    e.hi1 = e.hi2 = half;
  }
};
}  // namespace

TEST_CASE("a patch impulse holds a face: no relative tilt or twist, centre of pressure inside the patch") {
  PatchCase pc({0, 0, 1}, 0.5);
  const glm::dvec3 &n = pc.n, &r = pc.r, &v = pc.v, &w = pc.w;
  const glm::dmat3& invI = pc.invI;
  const ImpulseSide &a = pc.a, &b = pc.b;
  const ImpulseMatrix& k = pc.k;
  PatchExtent& e = pc.e;
  auto after = [&](const glm::dvec3& j, const glm::dvec3& t, glm::dvec3& v2, glm::dvec3& w2) {
    v2 = v + j;
    w2 = w + invI * (glm::cross(r, j) + t);
  };
  SUBCASE("sticking: the point stops, tilt and twist stop") {
    glm::dvec3 j, t;
    REQUIRE(patchImpulse(patchMatrix(a, b, k, e), k, v + glm::cross(w, r), w, n, 0.0, 2.0, nullptr, j, t));
    glm::dvec3 v2, w2;
    after(j, t, v2, w2);
    CHECK(glm::length(v2 + glm::cross(w2, r)) < 1e-9);
    CHECK(glm::length(w2) < 1e-9);
    // The tilt torque is the moment of the normal impulse moved by d inside the patch.
    const double jn = glm::dot(j, n);
    const glm::dvec3 d = glm::cross(n, t - glm::dot(t, n) * n) / jn;
    CHECK(jn > 0);
    CHECK(std::abs(glm::dot(d, e.t1)) <= 0.5);
    CHECK(std::abs(glm::dot(d, e.t2)) <= 0.5);
    // The twist needed lies within torsional friction at mu = 2.
    CHECK(std::abs(glm::dot(t, n)) <= 2.0 * jn * 0.77 * 0.5 + 1e-12);
  }
  SUBCASE("a narrow patch cannot hold the tilt: its centre of pressure sits on the edge") {
    e.lo1 = e.lo2 = -0.01;
    e.hi1 = e.hi2 = 0.01;
    glm::dvec3 j, t;
    REQUIRE(patchImpulse(patchMatrix(a, b, k, e), k, v + glm::cross(w, r), w, n, 0.0, 2.0, nullptr, j, t));
    const double jn = glm::dot(j, n);
    const glm::dvec3 d = glm::cross(n, t - glm::dot(t, n) * n) / jn;
    CHECK(std::max(std::abs(glm::dot(d, e.t1)), std::abs(glm::dot(d, e.t2))) == Approx(0.01));
    glm::dvec3 v2, w2;
    after(j, t, v2, w2);
    CHECK(glm::dot(v2 + glm::cross(w2, r), n) == Approx(0.0).epsilon(1e-9));  // the point still stops sinking
    CHECK(glm::length(w2 - glm::dot(w2, n) * n) > 0.01);                     // but the body tips
  }
  SUBCASE("torsional friction is bounded by mu jn times the patch's lever") {
    const double mu = 0.1;
    const glm::dvec3 spin(0, 3, 0);
    const glm::dvec3 u = v + glm::cross(spin, r);
    glm::dvec3 j, t;
    if (patchImpulse(patchMatrix(a, b, k, e), k, u, spin, n, 0.0, mu, nullptr, j, t)) {
      const double jn = glm::dot(j, n);
      CHECK(std::abs(glm::dot(t, n)) <= mu * jn * 0.77 * 0.5 * (1 + 1e-9));
      CHECK(glm::length(j - jn * n) <= mu * jn * (1 + 1e-9));
    }
  }
}

TEST_CASE("a hinge patch (one of two supports) holds only the tilt about the line through the supports") {
  const PatchCase pc({1, 0, 0}, 0.3);
  const glm::dvec3 &n = pc.n, &r = pc.r, &v = pc.v, &w = pc.w, line(0, 0, 1);
  const glm::dmat3& invI = pc.invI;
  const ImpulseMatrix& k = pc.k;
  const PatchMatrix p = lineMatrix(pc.a, pc.b, k, pc.e, line);
  REQUIRE(p.valid);
  glm::dvec3 j, t;
  REQUIRE(patchImpulse(p, k, v + glm::cross(w, r), w, n, 0.0, 2.0, nullptr, j, t));
  const glm::dvec3 v2 = v + j, w2 = w + invI * (glm::cross(r, j) + t);
  CHECK(glm::length(v2 + glm::cross(w2, r)) < 1e-9);      // the point stops
  CHECK(std::abs(glm::dot(w2, line)) < 1e-9);             // no tilt about the line
  CHECK(glm::length(glm::cross(t, line)) < 1e-12);        // the torque is about the line only
  CHECK(std::abs(glm::dot(t, line)) <= 0.3 * glm::dot(j, n) + 1e-12);  // its centre of pressure in the patch
}

TEST_CASE("eq. 6 and eq. 5 at their edges") {
  CHECK(yieldThreshold(0.0) == 0.0);
  CHECK(yieldThreshold(0.5) == Approx(1.0));
  CHECK(std::isinf(yieldThreshold(1.0)));
  CHECK(percentDeform(0.1, 5.0, yieldThreshold(1.0)) == 0.0);  // eps = 1 never deforms
  CHECK(percentDeform(0.1, 1.0, 1.0) == 0.0);                  // exactly at the threshold
  CHECK(percentDeform(0.1, 0.5, 1.0) == 0.0);                  // below
  CHECK(percentDeform(0.1, 3.0, 1.0) == Approx(0.2));          // above: kappa (j - Y)
  CHECK(percentDeform(0.1, 3.0, yieldThreshold(0.0)) == Approx(0.3));
  CHECK(deformDepth(0.05, 0.2) == Approx(0.01));
  CHECK(percentDeform(0.1, std::nan(""), 1.0) == 0.0);
  CHECK(percentDeformFromStress(2e6, 1e6, 1e8, 1e10) == Approx(1e6 * (1e-8 - 1e-10)));
  CHECK(percentDeformFromStress(0.5e6, 1e6, 1e8, 1e10) == 0.0);
}

TEST_CASE("free fall matches x = x0 - g t^2 / 2") {
  World w;
  BodyDef d;
  d.shape = makeSphere(0.5);
  d.origin = {0, 100, 0};
  const int i = w.addBody(d);
  const double h = 1.0 / 240;
  for (int s = 0; s < 240; ++s) w.step(h);
  // Symplectic Euler: x_n = x0 - g h^2 n(n+1)/2
  CHECK(w.body(i).x.y == Approx(100 - 9.81 * h * h * 240 * 241 / 2).epsilon(1e-9));
  CHECK(w.body(i).v.y == Approx(-9.81).epsilon(1e-9));
}

TEST_CASE("a bouncing sphere reaches eps^2 h") {
  for (double eps : {0.9, 0.5}) {
    World w;
    addGround(w, 0.0, 1.0);
    BodyDef d;
    d.shape = makeSphere(0.25);
    d.origin = {0, 0.25 + 2.0, 0};
    d.restitution = eps;
    d.friction = 0.0;
    const int i = w.addBody(d);
    const double h = 1.0 / 240;
    bool bounced = false;
    double apex = 0;
    for (int s = 0; s < 240 * 3; ++s) {
      w.step(h);
      const auto& b = w.body(i);
      if (b.v.y > 0) bounced = true;
      if (bounced) apex = std::max(apex, b.x.y - 0.25);
      if (bounced && b.v.y < 0) break;
    }
    CHECK(bounced);
    CHECK(apex == Approx(eps * eps * 2.0).epsilon(0.04));
  }
}

TEST_CASE("head-on collision of unequal masses with partial restitution, zero gravity") {
  WorldSettings s;
  s.gravity = {0, 0, 0};
  World w(s);
  BodyDef a, b;
  a.shape = makeSphere(0.5);
  a.origin = {-2, 0, 0};
  a.linearVelocity = {3, 0, 0};
  a.mass = 2;
  a.restitution = 0.6;
  a.friction = 0;
  b = a;
  b.origin = {2, 0, 0};
  b.linearVelocity = {-1, 0, 0};
  b.mass = 1;
  b.restitution = 0.8;
  const int ia = w.addBody(a), ib = w.addBody(b);
  const double p0 = 2 * 3 + 1 * -1;
  for (int s2 = 0; s2 < 480; ++s2) w.step(1.0 / 240);
  const double va = w.body(ia).v.x, vb = w.body(ib).v.x;
  CHECK(2 * va + vb == Approx(p0));
  // eps = min(0.6, 0.8): v_b - v_a = eps * 4
  CHECK(vb - va == Approx(0.6 * 4.0));
  CHECK(w.body(ia).v.y == Approx(0.0));
}

TEST_CASE("momentum is conserved among tumbling boxes in zero gravity") {
  WorldSettings s;
  s.gravity = {0, 0, 0};
  World w(s);
  glm::dvec3 p0(0), L0(0);
  for (int k = 0; k < 6; ++k) {
    BodyDef d;
    d.shape = makeBox({0.5 + 0.1 * k, 0.4, 0.6});
    d.origin = {std::cos(k * 1.1) * 1.5, std::sin(k * 0.7) * 1.5, (k % 3) * 0.8 - 0.8};
    d.linearVelocity = -d.origin * 0.8;
    d.angularVelocity = {0.3 * k, -0.2, 0.1};
    d.restitution = 0.5;
    d.friction = 0.3;
    w.addBody(d);
  }
  for (const auto& b : w.bodies()) p0 += b.mass * b.v;
  int collisions = 0;
  for (int k = 0; k < 480; ++k) {
    w.step(1.0 / 240);
    collisions += static_cast<int>(w.events().size());
  }
  CHECK(collisions >= 3);
  glm::dvec3 p1(0);
  for (const auto& b : w.bodies()) p1 += b.mass * b.v;
  CHECK(glm::length(p1 - p0) < 1e-9 * (1 + glm::length(p0)));
  (void)L0;
}

namespace {
// A box resting on an incline of angle theta (rotated about z); returns the
// displacement along the slope after `seconds` and the measured acceleration.
struct InclineResult {
  double travel, accel;
};
// A static slab whose top face is a plane through the origin tilted by `rot` about z.
void addIncline(World& w, const glm::dquat& rot, double mu) {
  BodyDef plane;
  plane.shape = makeBox({20, 1, 4});
  plane.orientation = rot;
  plane.origin = rot * glm::dvec3(0, -0.5, 0);
  plane.isStatic = true;
  plane.friction = mu;
  plane.restitution = 0;
  w.addBody(plane);
}

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

TEST_CASE("a stack of boxes falls asleep at 60 Hz as at 240 Hz (stillness by motion, not velocity)") {
  for (double hz : {60.0, 240.0}) {
    CAPTURE(hz);
    World w;
    addGround(w, 0.6, 0.0);
    std::vector<int> ids;
    for (int k = 0; k < 5; ++k) {
      BodyDef d;
      d.shape = makeBox({0.5, 0.5, 0.5});
      d.origin = {0, 0.25 + 0.5 * k, 0};
      d.restitution = 0;
      ids.push_back(w.addBody(d));
    }
    // At 60 Hz gravity adds g h = 0.16 m/s a step, more than the sleep
    // threshold: a stacked box ends every step still approaching the one below
    // by about that much (the contact step stops penetration at the predicted
    // positions, the projection the rest), yet it does not move.
    for (int s = 0; s < static_cast<int>(3 * hz); ++s) w.step(1.0 / hz);
    for (int k = 0; k < 5; ++k) {
      CAPTURE(k);
      CHECK(w.body(ids[static_cast<size_t>(k)]).asleep);
      CHECK(w.body(ids[static_cast<size_t>(k)]).x.y == Approx(0.25 + 0.5 * k).epsilon(0.01));
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

TEST_CASE("a 10-level box pyramid stands for 10 s with drift under 1 cm, sleeping or not") {
  for (bool sleeping : {true, false}) {
  CAPTURE(sleeping);
  World w;
  w.settings().sleeping = sleeping;
  addGround(w, 0.6, 0.0);
  const int levels = 10;
  const double size = 0.5;
  std::vector<int> ids;
  std::vector<glm::dvec3> start;
  for (int row = 0; row < levels; ++row) {
    const int count = levels - row;
    for (int k = 0; k < count; ++k) {
      BodyDef d;
      d.shape = makeBox({size, size, size});
      d.origin = {(k - (count - 1) / 2.0) * size * 1.02, size / 2 + row * size, 0};
      d.friction = 0.6;
      d.restitution = 0.0;
      ids.push_back(w.addBody(d));
      start.push_back(w.body(ids.back()).x);
    }
  }
  const double h = 1.0 / 240;
  for (int s = 0; s < 2400; ++s) w.step(h);
  double drift = 0;
  for (size_t k = 0; k < ids.size(); ++k) drift = std::max(drift, glm::length(w.body(ids[k]).x - start[k]));
  MESSAGE("pyramid max drift after 10 s" << std::string(sleeping ? "" : " (no sleeping)") << ": " << drift << " m");
  CHECK(drift < 0.01);
  }
}

TEST_CASE("a tower of ten boxes, every other one 5 cm off, dropped with 10 cm gaps, stands and falls asleep") {
  // One column of crumple-bench's pile. Each box lands on an off-centre face:
  // an impulse at one point spins it, and the tower used to lean and fall.
  World w;
  addGround(w, 0.6, 0.1);
  std::vector<int> ids;
  for (int k = 0; k < 10; ++k) ids.push_back(addBox(w, {0.4, 0.4, 0.4}, {0.05 * (k % 2), 0.3 + 0.5 * k, 0}, 0.6, 0.1));
  double asleepAt = -1;
  for (int s = 1; s <= 720; ++s) {
    w.step(1.0 / 240);
    if (asleepAt < 0 && w.lastStats().awake == 0) asleepAt = s / 240.0;
  }
  double lean = 0, tilt = 0;
  for (int k = 0; k < 10; ++k) {
    const RigidBody& b = w.body(ids[static_cast<size_t>(k)]);
    lean = std::max(lean, glm::length(glm::dvec2(b.x.x - 0.05 * (k % 2), b.x.z)));
    tilt = std::max(tilt, glm::angle(b.q));
    CHECK(b.x.y == Approx(0.2 + 0.4 * k).epsilon(0.01));
  }
  MESSAGE("offset tower: lean " << lean << " m, tilt " << tilt << " rad, asleep at " << asleepAt << " s");
  CHECK(lean < 0.02);
  CHECK(tilt < 0.02);
  CHECK(asleepAt > 0);
  CHECK(asleepAt < 2.0);
}

TEST_CASE("heavy bodies on light ones: each box ten times heavier than the one below rests still") {
  World w;
  w.settings().sleeping = false;  // the solver must hold them, not sleep
  addGround(w, 0.6, 0.0);
  std::vector<int> ids;
  for (int k = 0; k < 4; ++k)  // 12.5 kg ... 12.5 t
    ids.push_back(addBox(w, {0.5, 0.5, 0.5}, {0.03 * (k % 2), 0.25 + 0.5 * k, 0}, 0.6, 0.0, 100 * std::pow(10.0, k)));
  for (int s = 0; s < 1200; ++s) w.step(1.0 / 240);
  for (int k = 0; k < 4; ++k) {
    CAPTURE(k);
    const RigidBody& b = w.body(ids[static_cast<size_t>(k)]);
    CHECK(b.x.y == Approx(0.25 + 0.5 * k).epsilon(0.002));
    CHECK(std::abs(b.x.x - 0.03 * (k % 2)) < 0.002);
    CHECK(glm::angle(b.q) < 0.005);
  }
}

TEST_CASE("uneven stacks under a shared lid: the contact graph's cycle collapses and the lid rests level") {
  // Left: one 0.5 m box; right: two 0.25 m boxes; a plank across both. By
  // breadth-first levels the plank and the upper right box share a level and
  // touch each other: a cycle that must neither loop nor topple anything.
  World w;
  addGround(w, 0.6, 0.0);
  auto box = [&](glm::dvec3 size, glm::dvec3 origin) { return addBox(w, size, origin, 0.6, 0.0); };
  box({0.5, 0.5, 0.5}, {-0.6, 0.25, 0});
  box({0.5, 0.25, 0.5}, {0.6, 0.125, 0});
  box({0.5, 0.25, 0.5}, {0.6, 0.375, 0});
  const int lid = box({1.8, 0.1, 0.5}, {0, 0.55, 0});
  const glm::dvec3 start = w.body(lid).x;
  for (int s = 0; s < 1200; ++s) w.step(1.0 / 240);
  const RigidBody& l = w.body(lid);
  REQUIRE(std::isfinite(l.x.x + l.x.y + l.x.z));
  CHECK(glm::length(l.x - start) < 0.005);
  CHECK(glm::angle(l.q) < 0.01);
  CHECK(w.lastStats().awake == 0);
}

TEST_CASE("a running-bond wall (each block half on two below) of six courses stands and falls asleep") {
  // Blocks 0.3 m thick: each rests on two supports side by side, and nothing
  // but their patches keeps it from rocking out of the wall's plane (at the
  // origin the wall is symmetric to the last bit and that mode never starts).
  World w;
  addGround(w, 0.7, 0.1);
  const double L = 0.6, H = 0.3, T = 0.3;
  std::vector<int> ids;
  std::vector<glm::dvec3> start;
  for (int course = 0; course < 6; ++course) {
    const bool odd = course % 2 == 1;
    const int count = odd ? 13 : 12;
    for (int i = 0; i < count; ++i) {
      const bool half = odd && (i == 0 || i == count - 1);
      const double z = !odd ? -L * 5.5 + L * i : half ? (i == 0 ? -1 : 1) * (L * 6 - L / 4) : -L * 6 + L * i;
      // Off the origin: rounding breaks the wall's symmetry, as anywhere else it would.
      ids.push_back(addBox(w, {T, H, half ? L / 2 - 0.01 : L - 0.01}, {12, H / 2 + (H + 0.0005) * course, z}, 0.7, 0.1, 1800));
      start.push_back(w.body(ids.back()).x);
    }
  }
  double asleepAt = -1;
  for (int s = 1; s <= 600; ++s) {
    w.step(1.0 / 240);
    if (asleepAt < 0 && w.lastStats().awake == 0) asleepAt = s / 240.0;
  }
  double drift = 0;
  for (size_t k = 0; k < ids.size(); ++k) drift = std::max(drift, glm::length(w.body(ids[k]).x - start[k]));
  MESSAGE("running-bond wall: drift " << drift << " m, asleep at " << asleepAt << " s");
  CHECK(drift < 0.01);
  CHECK(asleepAt > 0);
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

TEST_CASE("a fast box does not tunnel through a thin static rail at 40 m/s (and 150 m/s)") {
  // Substeps keep every body's travel per substep under half the thinnest body's
  // half thickness; with at most 16 substeps at 240 Hz a 0.2 m rail holds up to
  // 0.5 * 0.1 m * 16 * 240 /s = 192 m/s.
  for (double speed : {40.0, 150.0}) {
  CAPTURE(speed);
  WorldSettings s;
  s.gravity = {0, 0, 0};
  World w(s);
  BodyDef rail;
  rail.shape = makeBox({0.2, 0.8, 6});
  rail.isStatic = true;
  rail.restitution = 0.2;
  w.addBody(rail);
  BodyDef car;
  car.shape = makeBox({4.2, 1.3, 1.8});
  car.origin = {-4, 0, 0};
  car.linearVelocity = {speed, 0, 0};
  car.mass = 1200;
  car.restitution = 0.2;
  const int i = w.addBody(car);
  for (int k = 0; k < 120; ++k) w.step(1.0 / 240);
  CHECK(w.body(i).x.x < -2.1 + 0.05);   // front face never past the rail's near face (by more than 5 cm)
  CHECK(w.body(i).v.x <= 0.0);
  }
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

#include "test_meshes.h"

TEST_CASE("100 nonconvex tori dropped in a pile come to rest with no NaN and no explosion") {
  World w;
  addGround(w, 0.6, 0.2);
  // Walls keep the pile together.
  for (int k = 0; k < 4; ++k) {
    BodyDef wall;
    wall.shape = makeBox(k < 2 ? glm::dvec3(0.2, 16, 3.4) : glm::dvec3(3.4, 16, 0.2));
    wall.origin = k == 0 ? glm::dvec3(-1.6, 8, 0) : k == 1 ? glm::dvec3(1.6, 8, 0) : k == 2 ? glm::dvec3(0, 8, -1.6) : glm::dvec3(0, 8, 1.6);
    wall.isStatic = true;
    w.addBody(wall);
  }
  const auto torus = makeMeshShape(test::torusMesh(0.3f, 0.1f, 16, 8), 32);
  std::vector<int> ids;
  double potential = 0;
  for (int k = 0; k < 100; ++k) {
    BodyDef d;
    d.shape = torus;
    d.origin = {-1.2 + 0.8 * (k % 4), 0.5 + 0.85 * (k / 16), -1.2 + 0.8 * ((k / 4) % 4)};
    d.orientation = glm::angleAxis(0.7 * k, glm::normalize(glm::dvec3(1, 0.3 * (k % 3), 0.5)));
    d.restitution = 0.3;
    d.friction = 0.5;
    d.density = 800;
    ids.push_back(w.addBody(d));
    potential += w.body(ids.back()).mass * 9.81 * w.body(ids.back()).x.y;
  }
  const double fallSpeed = std::sqrt(2 * 9.81 * 7.0);
  double maxSpeed = 0;
  const int steps = 240 * 3;
  for (int s = 0; s < steps; ++s) {
    w.step(1.0 / 240);
    for (int i : ids) {
      const auto& b = w.body(i);
      REQUIRE(std::isfinite(b.x.x + b.x.y + b.x.z + b.v.x + b.v.y + b.v.z + b.w.x + b.w.y + b.w.z));
      maxSpeed = std::max(maxSpeed, glm::length(b.v));
    }
  }
  double kinetic = 0, lowest = 1e9, highest = -1e9, potentialEnd = 0;
  for (int i : ids) {
    const auto& b = w.body(i);
    kinetic += 0.5 * b.mass * glm::dot(b.v, b.v);
    potentialEnd += b.mass * 9.81 * b.x.y;
    lowest = std::min(lowest, b.x.y);
    highest = std::max(highest, b.x.y);
    CHECK(std::abs(b.x.x) < 1.6);
    CHECK(std::abs(b.x.z) < 1.6);
  }
  const double released = potential - potentialEnd;
  MESSAGE("tori: max speed " << maxSpeed << " m/s (free fall " << fallSpeed << "), kinetic energy at 3 s " << kinetic
                             << " J of " << released << " J released, heights " << lowest << ".." << highest);
  CHECK(maxSpeed < fallSpeed * 1.1);  // no explosion: nothing moves faster than the fall itself
  CHECK(lowest > 0.0);                // nothing fell through the ground (tube radius 0.1)
  CHECK(released > 0);
  CHECK(kinetic < 0.01 * released);   // the pile has come (nearly) to rest
}

#include "physics/vehicle.h"

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
