// The impulse formulas on their own (Guendelman et al. 2003 section 7, the
// deformation paper's eq. 4, patch impulses) and the stress-strain model's
// equations 5 and 6 at their edges.
#include <doctest/doctest.h>

#include <cmath>
#include <initializer_list>

#include <crumple/physics/impulse.h>
#include <crumple/deform/model/stress_strain.h>

using namespace crumple;
using doctest::Approx;

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
    bool whole = false;
    REQUIRE(patchImpulse(patchMatrix(a, b, k, e), k, v + glm::cross(w, r), w, n, 0.0, 2.0, nullptr, j, t, &whole));
    CHECK(whole);  // every target met: no relative motion left
    glm::dvec3 v2, w2;
    after(j, t, v2, w2);
    CHECK(glm::length(v2 + glm::cross(w2, r)) < 1e-9);
    CHECK(glm::length(w2) < 1e-9);
    // A second impulse at what is left finds only rounding.
    glm::dvec3 j2(0), t2(0);
    if (patchImpulse(patchMatrix(a, b, k, e), k, v2 + glm::cross(w2, r), w2, n, 0.0, 2.0, nullptr, j2, t2))
      CHECK(glm::length(j2) + glm::length(t2) < 1e-9);
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
    bool whole = true;
    REQUIRE(patchImpulse(patchMatrix(a, b, k, e), k, v + glm::cross(w, r), w, n, 0.0, 2.0, nullptr, j, t, &whole));
    CHECK_FALSE(whole);  // the tilt was clamped
    const double jn = glm::dot(j, n);
    const glm::dvec3 d = glm::cross(n, t - glm::dot(t, n) * n) / jn;
    CHECK(std::max(std::abs(glm::dot(d, e.t1)), std::abs(glm::dot(d, e.t2))) == Approx(0.01));
    glm::dvec3 v2, w2;
    after(j, t, v2, w2);
    CHECK(glm::dot(v2 + glm::cross(w2, r), n) == Approx(0.0).epsilon(1e-9));  // the point still stops sinking
    CHECK(glm::length(w2 - glm::dot(w2, n) * n) > 0.01);                      // but the body tips
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
  bool whole = true;
  REQUIRE(patchImpulse(p, k, v + glm::cross(w, r), w, n, 0.0, 2.0, nullptr, j, t, &whole));
  CHECK_FALSE(whole);  // the tilt across the line and the twist are left to the other support
  const glm::dvec3 v2 = v + j, w2 = w + invI * (glm::cross(r, j) + t);
  CHECK(glm::length(v2 + glm::cross(w2, r)) < 1e-9);                   // the point stops
  CHECK(std::abs(glm::dot(w2, line)) < 1e-9);                          // no tilt about the line
  CHECK(glm::length(glm::cross(t, line)) < 1e-12);                     // the torque is about the line only
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
