// Torque-free rotation against the analytic solution: angular momentum and
// kinetic energy of a free body kept at any spin, a symmetric top's
// precession, the intermediate-axis flip's period (Landau & Lifshitz,
// Mechanics, section 37), and the principal axes of inertia.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <crumple/physics/mesh.h>
#include <crumple/physics/rotation.h>
#include "physics_fixture.h"

using namespace crumple;

namespace {

glm::dvec3 angularMomentum(const RigidBody& b) { return b.angularMomentum(); }
double spinEnergy(const RigidBody& b) { return 0.5 * glm::dot(b.w, b.angularMomentum()); }

WorldSettings freeSpace() {
  WorldSettings s;
  s.gravity = glm::dvec3(0);
  s.sleeping = false;
  return s;
}

int addSpinning(World& w, std::shared_ptr<const Shape> shape, const glm::dvec3& omega, double mass,
                const glm::dquat& orientation = glm::dquat(1, 0, 0, 0), const glm::dvec3& origin = glm::dvec3(0)) {
  BodyDef d;
  d.origin = origin;
  d.shape = std::move(shape);
  d.mass = mass;
  d.orientation = orientation;
  d.angularVelocity = omega;
  return w.addBody(d);
}

// The complete elliptic integral of the first kind K(k), by the arithmetic-geometric mean.
double ellipticK(double k) {
  double a = 1, b = std::sqrt(1 - k * k);
  for (int i = 0; i < 40 && std::abs(a - b) > 1e-16 * a; ++i) {
    const double m = 0.5 * (a + b);
    b = std::sqrt(a * b);
    a = m;
  }
  return M_PI / (2 * a);
}

}  // namespace

TEST_CASE("a free box spinning at 10 to 100 rad/s about each axis keeps |L| and gains no energy over 10 s") {
  // The box of 1 x 0.2 x 0.05 m, 10 kg, at 240 Hz: each principal axis, with a small part about the other two.
  for (double speed : {10.0, 30.0, 50.0, 100.0}) {
    for (int axis = 0; axis < 3; ++axis) {
      CAPTURE(speed);
      CAPTURE(axis);
      test::PhysicsTestContext ctx(240, freeSpace());
      glm::dvec3 omega(0.02 * speed);
      omega[axis] = speed;
      const int box = addSpinning(ctx.world(), makeBox({1, 0.2, 0.05}), omega, 10);
      const RigidBody& b = ctx.world().body(box);
      const glm::dvec3 l0 = angularMomentum(b);
      const double e0 = spinEnergy(b);
      double worstL = 0, mostE = e0;
      for (int s = 0; s < 2400; ++s) {
        ctx.world().step(1.0 / 240);
        worstL = std::max(worstL, glm::length(angularMomentum(b) - l0) / glm::length(l0));
        mostE = std::max(mostE, spinEnergy(b));
      }
      CHECK(worstL < 1e-9);  // the vector, not only its size
      CAPTURE(mostE / e0 - 1);
      CHECK(mostE <= e0 * (1 + 1e-10));  // rounding over 2400 steps, no drift
      CHECK(spinEnergy(b) >= e0 * (1 - 1e-9));
      CHECK(glm::length(b.v) == 0.0);
    }
  }
}

TEST_CASE("a body of uneven mass (a tetrahedron: its inertia not diagonal) keeps L and its energy") {
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {0.4f, 0, 0}, {0, 0.7f, 0}, {0, 0, 1.1f}};
  m.computeNormals();
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  test::PhysicsTestContext ctx(240, freeSpace());
  const int t = addSpinning(ctx.world(), makeMeshShape(m, 16), {7, -31, 13}, 3,
                            glm::normalize(glm::dquat(0.9, 0.1, -0.3, 0.2)));
  const RigidBody& b = ctx.world().body(t);
  // Its tensor is not diagonal in its own axes, and the principal frame diagonalises it.
  CHECK(std::abs(b.inertiaBody[0][1]) > 1e-3 * b.inertiaBody[0][0]);
  const glm::dmat3 p = glm::mat3_cast(b.principal.frame);
  const glm::dmat3 d = glm::transpose(p) * b.inertiaBody * p;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) CHECK(std::abs(d[c][r] - (r == c ? b.principal.moments[r] : 0.0)) < 1e-12 * b.principal.moments.z);
  CHECK(b.principal.moments.x <= b.principal.moments.y);
  CHECK(b.principal.moments.y <= b.principal.moments.z);
  const glm::dvec3 l0 = angularMomentum(b);
  const double e0 = spinEnergy(b);
  for (int s = 0; s < 2400; ++s) ctx.world().step(1.0 / 240);
  CHECK(glm::length(angularMomentum(b) - l0) < 1e-9 * glm::length(l0));
  CHECK(std::abs(spinEnergy(b) - e0) < 1e-9 * e0);
}

TEST_CASE("a symmetric top's axis precesses about L at |L| / I_1, and a ball's spin stays") {
  // A 0.2 x 0.2 x 1 m box: I_x = I_y (the transverse moment), its long axis z the symmetry axis.
  test::PhysicsTestContext ctx(240, freeSpace());
  const int top = addSpinning(ctx.world(), makeBox({0.2, 0.2, 1}), {3, 0, 40}, 5);
  const int ball = addSpinning(ctx.world(), makeSphere(0.3), {50, -20, 10}, 5, glm::dquat(1, 0, 0, 0), {5, 0, 0});
  const RigidBody& b = ctx.world().body(top);
  const glm::dvec3 l = angularMomentum(b);
  const double transverse = b.inertiaBody[0][0];
  const glm::dvec3 axis0 = b.rotation()[2];
  const int steps = 1200;
  for (int s = 0; s < steps; ++s) ctx.world().step(1.0 / 240);
  const double t = steps / 240.0;
  // The analytic axis: axis0 turned about L by |L| t / I_1.
  const double angle = glm::length(l) * t / transverse;
  const glm::dvec3 n = glm::normalize(l);
  const glm::dvec3 expected = axis0 * std::cos(angle) + glm::cross(n, axis0) * std::sin(angle) +
                              n * glm::dot(n, axis0) * (1 - std::cos(angle));
  CHECK(glm::length(b.rotation()[2] - expected) < 1e-9);
  CHECK(angle > 10);  // several turns of precession, not a small angle
  // A ball's spin is constant and its orientation has turned by exactly w t.
  const RigidBody& s = ctx.world().body(ball);
  CHECK(glm::length(s.w - glm::dvec3(50, -20, 10)) < 1e-12);
}

TEST_CASE("the intermediate-axis flip has the analytic period within 2%") {
  // A 0.1 x 0.2 x 0.4 m box: I_z < I_y < I_x, spun mostly about y (the intermediate axis).
  for (double hz : {240.0, 60.0}) {
    CAPTURE(hz);
    test::PhysicsTestContext ctx(hz, freeSpace());
    const int box = addSpinning(ctx.world(), makeBox({0.1, 0.2, 0.4}), {0.3, 10, 0.1}, 2);
    const RigidBody& b = ctx.world().body(box);
    const double i1 = b.inertiaBody[2][2], i2 = b.inertiaBody[1][1], i3 = b.inertiaBody[0][0];
    REQUIRE(i1 < i2);
    REQUIRE(i2 < i3);
    const double m2 = glm::dot(angularMomentum(b), angularMomentum(b)), e = spinEnergy(b);
    // Landau & Lifshitz (37.10): with M^2 > 2 E I_2 as written, else I_1 and I_3 swapped.
    double a1 = i1, a3 = i3;
    if (m2 < 2 * e * i2) std::swap(a1, a3);
    const double rate = std::sqrt((a3 - i2) * (m2 - 2 * e * a1) / (a1 * i2 * a3));
    const double k2 = (i2 - a1) * (2 * e * a3 - m2) / ((a3 - i2) * (m2 - 2 * e * a1));
    REQUIRE(k2 > 0);
    REQUIRE(k2 < 1);
    const double period = 4 * ellipticK(std::sqrt(k2)) / rate;
    // The body-frame angular velocity's y part changes sign twice a period: the times it turns negative.
    std::vector<double> flips;
    double last = b.w.y;
    const double h = 1.0 / hz;
    for (int s = 0; s < static_cast<int>(8 * period * hz); ++s) {
      ctx.world().step(h);
      const double now = (glm::transpose(b.rotation()) * b.w).y;
      if (last > 0 && now <= 0) flips.push_back((s + last / (last - now)) * h);
      last = now;
    }
    REQUIRE(flips.size() >= 5);
    const double measured = (flips.back() - flips.front()) / static_cast<double>(flips.size() - 1);
    CAPTURE(measured);
    CAPTURE(period);
    CHECK(std::abs(measured - period) < 0.02 * period);
  }
}

TEST_CASE("principal axes of a turned tensor: ascending moments, a right-handed frame that diagonalises it") {
  const glm::dmat3 r = glm::mat3_cast(glm::normalize(glm::dquat(0.3, -0.5, 0.7, 0.2)));
  const glm::dmat3 tensor = r * glm::dmat3(glm::dvec3(5, 0, 0), glm::dvec3(0, 2, 0), glm::dvec3(0, 0, 3)) *
                            glm::transpose(r);
  const PrincipalInertia p = principalInertia(tensor);
  CHECK(p.moments.x == doctest::Approx(2).epsilon(1e-12));
  CHECK(p.moments.y == doctest::Approx(3).epsilon(1e-12));
  CHECK(p.moments.z == doctest::Approx(5).epsilon(1e-12));
  const glm::dmat3 f = glm::mat3_cast(p.frame);
  CHECK(glm::determinant(f) == doctest::Approx(1).epsilon(1e-12));
  for (int k = 0; k < 3; ++k) CHECK(glm::length(tensor * f[k] - p.moments[k] * f[k]) < 1e-12);
  // A diagonal tensor keeps its axes (up to order and sign).
  const PrincipalInertia d = principalInertia(glm::dmat3(glm::dvec3(4, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 9)));
  CHECK(d.moments == glm::dvec3(1, 4, 9));
}

// The contact step skips predicting a body's poses where its velocities alone show they cannot have moved past
// the refresh tolerance (contact_step.cpp, stillAtLook): that rests on two turns of one orientation by exp(h w1)
// and exp(h w2) being at most h |w1 - w2| apart in angle, as rotateBy computes them.
TEST_CASE("two turns of one orientation by rotateBy differ by at most h |w1 - w2| in angle") {
  uint64_t state = 7;
  auto u = [&]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0 * 2 - 1;
  };
  double tightest = 0;  // the largest ratio of angle to bound seen
  for (int k = 0; k < 20000; ++k) {
    const glm::dquat q = glm::normalize(glm::dquat(u(), u(), u(), u()) + glm::dquat(1e-3, 0, 0, 0));
    const double scale = std::pow(10.0, 3 * u());  // 1e-3 to 1e3 rad/s
    const glm::dvec3 w1 = scale * glm::dvec3(u(), u(), u());
    const double dscale = std::pow(10.0, 3 * u() - 3);  // changes of 1e-6 to 1 of the speed
    const glm::dvec3 w2 = w1 + dscale * scale * glm::dvec3(u(), u(), u());
    const double h = k % 2 ? 1.0 / 60 : 1.0 / 240;
    const double angle = 2 * std::acos(std::min(1.0, std::abs(glm::dot(rotateBy(q, w1, h), rotateBy(q, w2, h)))));
    const double bound = h * glm::length(w2 - w1);
    // (an angle from acos near 1 reads ~1e-8 rad where there is none: the step's test allows 1e-6 per metre)
    REQUIRE(angle <= bound + 1e-7);
    if (bound > 1e-3) tightest = std::max(tightest, angle / bound);  // (where the acos noise is below 1e-4)
  }
  // Not a bound far too wide to matter: the same axis turned further is the equality case.
  CHECK(tightest > 0.99);
  CHECK(tightest <= 1 + 1e-4);
}

// The looks ahead predict a turn by exp(h w) (StepContext::predict); the position update turns the body
// torque-free. Their gap is the precession of w over the substep: |dw/dt| = |I^-1 (L x w)| <= |w|^2 (I_max -
// I_min) / (2 I_min), so about h^2 |w|^2 (I_max - I_min) / (4 I_min) in angle, which the step's margins allow for.
TEST_CASE("a predicted turn exp(h w) stays within h^2 |w|^2 (I_max - I_min) / (4 I_min) of the torque-free turn") {
  uint64_t state = 11;
  auto u = [&]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0 * 2 - 1;
  };
  double tightest = 0;
  for (int k = 0; k < 20000; ++k) {
    PrincipalInertia inertia;
    std::vector<double> m = {1.5 + u(), 2.5 + 1.5 * u(), 3 + 2 * u()};
    std::sort(m.begin(), m.end());
    inertia.moments = glm::dvec3(m[0], m[1], m[2]);
    inertia.frame = glm::normalize(glm::dquat(u(), u(), u(), u()) + glm::dquat(1e-3, 0, 0, 0));
    const glm::dquat q = glm::normalize(glm::dquat(u(), u(), u(), u()) + glm::dquat(1e-3, 0, 0, 0));
    const double h = k % 2 ? 1.0 / 60 : 1.0 / 240;
    // Turns of up to a tenth of a radian a step (faster spins take substeps).
    const glm::dvec3 w = (0.1 * (0.5 + 0.5 * u()) / h) * glm::normalize(glm::dvec3(u(), u(), u()) + 1e-9);
    const glm::dquat exact = freeRotation(inertia, q, w, h).q;
    const double angle = 2 * std::acos(std::min(1.0, std::abs(glm::dot(rotateBy(q, w, h), exact))));
    const double bound = h * h * glm::dot(w, w) * (m[2] - m[0]) / (4 * m[0]);
    REQUIRE(angle <= 1.1 * bound + 1e-7);
    if (bound > 1e-3) tightest = std::max(tightest, angle / bound);
  }
  MESSAGE("largest angle over the bound: " << tightest);
  CHECK(tightest > 0.5);  // (the bound is the gap's own order, not one far too wide to matter)
}
