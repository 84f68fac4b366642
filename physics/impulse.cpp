#include "physics/impulse.h"

#include <algorithm>
#include <cmath>

namespace crumple {

namespace {
glm::dmat3 cross(const glm::dvec3& r) {
  // Column-major: columns are the images of the basis vectors.
  return glm::dmat3(0, r.z, -r.y, -r.z, 0, r.x, r.y, -r.x, 0);
}
// Kinetic energy change of the relative motion for impulse j: dE = j.u + 1/2 j.K j.
double energyChange(const glm::dmat3& K, const glm::dvec3& u, const glm::dvec3& j) {
  return glm::dot(j, u) + 0.5 * glm::dot(j, K * j);
}
}  // namespace

glm::dmat3 collisionMatrix(const ImpulseSide& a, const ImpulseSide& b) {
  glm::dmat3 k((a.invMass + b.invMass));
  const glm::dmat3 ra = cross(a.r), rb = cross(b.r);
  k -= ra * a.invInertia * ra;
  k -= rb * b.invInertia * rb;
  return k;
}

glm::dvec3 pointMassImpulse(const glm::dvec3& n, double eps, const glm::dvec3& vA, const glm::dvec3& vB, double mA,
                            double mB) {
  return -n * (1 + eps) * glm::dot(n, vB - vA) / (1 / mA + 1 / mB);
}

glm::dvec3 frictionlessImpulse(const glm::dmat3& K, const glm::dvec3& u, const glm::dvec3& n, double eps) {
  const double un = glm::dot(u, n);
  const double nkn = glm::dot(n, K * n);
  if (un >= 0 || !(nkn > 0)) return glm::dvec3(0);
  return -(1 + eps) * un / nkn * n;
}

ImpulseMatrix::ImpulseMatrix(const glm::dmat3& k) : K(k) {
  invertible = std::abs(glm::determinant(K)) > 1e-300;
  if (invertible) inverse = glm::inverse(K);
}

glm::dvec3 frictionImpulse(const glm::dmat3& K, const glm::dvec3& u, const glm::dvec3& n, double eps, double mu) {
  if (glm::dot(u, n) >= 0) return glm::dvec3(0);
  if (!(mu > 0)) return frictionlessImpulse(K, u, n, eps);
  return frictionImpulse(ImpulseMatrix(K), u, n, eps, mu);
}

glm::dvec3 frictionImpulse(const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& n, double eps, double mu) {
  return frictionImpulse(m, u, n, eps, mu, nullptr);
}

namespace {
glm::dvec3 coulombImpulse(const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& n, double eps, double mu,
                          const FrictionTotals* earlier) {
  const glm::dmat3& K = m.K;
  const double un = glm::dot(u, n);
  if (!(mu > 0)) return frictionlessImpulse(K, u, n, eps);
  // Earlier impulses at this contact in this step, the friction in today's tangent plane.
  const double pn = earlier ? std::max(0.0, earlier->normal) : 0.0;
  const glm::dvec3 pt = earlier ? earlier->tangential - glm::dot(earlier->tangential, n) * n : glm::dvec3(0);
  const double ptLen = glm::length(pt);
  if (m.invertible) {
    // Sticking: the relative velocity becomes -eps (u.n) n.
    const glm::dvec3 j = m.inverse * (-eps * un * n - u);
    const double jn = glm::dot(j, n);
    const glm::dvec3 jt = j - jn * n;
    if (jn >= 0 && glm::length(pt + jt) <= mu * (pn + jn) &&
        energyChange(K, u, j) <= 1e-12 * std::abs(glm::dot(j, u)) + 1e-15) {
      return j;
    }
  }
  const glm::dvec3 ut = u - un * n;
  const double utLen = glm::length(ut);
  if (utLen < 1e-12) return frictionlessImpulse(K, u, n, eps);
  // Sliding: j = lambda (n - m t), t the sliding direction; the normal part
  // lambda = c / (n.K(n - m t)) makes the normal velocity change c.
  const glm::dvec3 t = ut / utLen;
  const double c = -(1 + eps) * un;
  const glm::dvec3 kn = K * n, kt = K * t;
  const double a = glm::dot(n, kn), b = glm::dot(n, kt), e = glm::dot(t, kt);
  // The friction coefficient of this impulse: mu, or more where earlier
  // impulses left friction unused (the total m lambda + |pt| may reach
  // mu (pn + lambda)): m (c + s b) <= s a + mu c with s the unused friction.
  double fm = mu;
  const double spare = mu * pn - ptLen;
  if (spare > 0 && c + spare * b > 0) fm = (spare * a + mu * c) / (c + spare * b);
  // Kinetic friction opposes sliding; it may stop it, never reverse it: t.(u + K j)
  // = |u_t| + c (b - m e) / (a - m b) falls with m (e a >= b^2, K positive
  // definite) and is zero at m = (|u_t| a + c b) / (|u_t| b + c e).
  const double stopLower = utLen * b + c * e;
  if (stopLower > 0) fm = std::min(fm, (utLen * a + c * b) / stopLower);
  fm = std::max(fm, 0.0);
  const double denom = a - fm * b;
  if (!(denom > 0)) return frictionlessImpulse(K, u, n, eps);
  const glm::dvec3 j = c / denom * (n - fm * t);
  // Never add kinetic energy.
  if (energyChange(K, u, j) > 0) return frictionlessImpulse(K, u, n, eps);
  return j;
}
}  // namespace

glm::dvec3 frictionImpulse(const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& n, double eps, double mu,
                           FrictionTotals* totals) {
  if (glm::dot(u, n) >= 0) return glm::dvec3(0);
  const glm::dvec3 j = coulombImpulse(m, u, n, eps, mu, totals);
  if (totals) {
    const double jn = glm::dot(j, n);
    totals->normal += jn;
    totals->tangential += j - jn * n;
  }
  return j;
}

}  // namespace crumple
