#include "physics/impulse.h"

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
  const glm::dmat3& K = m.K;
  const double un = glm::dot(u, n);
  if (un >= 0) return glm::dvec3(0);
  if (!(mu > 0)) return frictionlessImpulse(K, u, n, eps);
  if (m.invertible) {
    // Sticking: the relative velocity becomes -eps (u.n) n.
    const glm::dvec3 j = m.inverse * (-eps * un * n - u);
    const double jn = glm::dot(j, n);
    const glm::dvec3 jt = j - jn * n;
    if (jn >= 0 && glm::length(jt) <= mu * jn && energyChange(K, u, j) <= 1e-12 * std::abs(glm::dot(j, u)) + 1e-15) {
      return j;
    }
  }
  const glm::dvec3 ut = u - un * n;
  const double utLen = glm::length(ut);
  if (utLen < 1e-12) return frictionlessImpulse(K, u, n, eps);
  const glm::dvec3 t = ut / utLen;
  const glm::dvec3 dir = n - mu * t;
  const double denom = glm::dot(n, K * dir);
  if (!(denom > 0)) return frictionlessImpulse(K, u, n, eps);
  glm::dvec3 j = -(1 + eps) * un / denom * dir;
  // Friction may not reverse the sliding direction: cap the tangential part at
  // the impulse that stops sliding, which also keeps the energy from rising.
  if (energyChange(K, u, j) > 0) j = frictionlessImpulse(K, u, n, eps);
  return j;
}

}  // namespace crumple
