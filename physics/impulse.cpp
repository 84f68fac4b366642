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

PatchMatrix patchMatrix(const ImpulseSide& a, const ImpulseSide& b, const ImpulseMatrix& k, const PatchExtent& patch) {
  PatchMatrix p;
  p.patch = patch;
  if (patch.flat() || !k.invertible) return p;
  p.C = b.invInertia * cross(b.r) + a.invInertia * cross(a.r);
  p.W = a.invInertia + b.invInertia;
  // The system in (J, y), T = y1 t1 + y2 t2, is [K, B; B^T, D] with
  // B = C^T [t1 t2], D = [t_i.W t_k]; it is solved through the Schur
  // complement S = D - B^T K^-1 B of K.
  const glm::dmat3 ct = glm::transpose(p.C);
  p.b1 = ct * patch.t1;
  p.b2 = ct * patch.t2;
  p.kb1 = k.inverse * p.b1;
  p.kb2 = k.inverse * p.b2;
  const double s11 = glm::dot(patch.t1, p.W * patch.t1) - glm::dot(p.b1, p.kb1);
  const double s12 = glm::dot(patch.t1, p.W * patch.t2) - glm::dot(p.b1, p.kb2);
  const double s22 = glm::dot(patch.t2, p.W * patch.t2) - glm::dot(p.b2, p.kb2);
  const double det = s11 * s22 - s12 * s12;
  const double scale = std::max(std::abs(s11), std::abs(s22));
  if (!(scale > 0) || !(det > 1e-12 * scale * scale)) return p;
  p.s11 = s22 / det;
  p.s12 = -s12 / det;
  p.s22 = s11 / det;
  p.valid = true;
  return p;
}

bool patchImpulse(const PatchMatrix& p, const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& omega,
                  const glm::dvec3& n, double eps, double mu, FrictionTotals* totals, glm::dvec3& jOut, glm::dvec3& tOut) {
  if (!p.valid || !m.invertible) return false;
  const double un = glm::dot(u, n);
  if (un >= 0) return false;
  const PatchExtent& e = p.patch;
  const glm::dvec3 dv = -eps * un * n - u;
  const double r1 = -glm::dot(e.t1, omega), r2 = -glm::dot(e.t2, omega);
  const glm::dvec3 j0 = m.inverse * dv;
  const double q1 = r1 - glm::dot(p.b1, j0), q2 = r2 - glm::dot(p.b2, j0);
  double y1 = p.s11 * q1 + p.s12 * q2, y2 = p.s12 * q1 + p.s22 * q2;
  glm::dvec3 J = j0 - p.kb1 * y1 - p.kb2 * y2;
  double jn = glm::dot(J, n);
  if (!(jn > 0)) return false;
  // The centre of pressure's offset d from the point: T = d x (jn n), so
  // d = n x T / jn = (-y2 t1 + y1 t2) / jn.
  const double d1 = -y2 / jn, d2 = y1 / jn;
  double s = 1;
  if (d1 > e.hi1) s = std::min(s, e.hi1 / d1);
  if (d1 < e.lo1) s = std::min(s, e.lo1 / d1);
  if (d2 > e.hi2) s = std::min(s, e.hi2 / d2);
  if (d2 < e.lo2) s = std::min(s, e.lo2 / d2);
  if (s < 1) {
    // The patch cannot hold the tilt: the most it can, and the point's target with it.
    y1 *= s;
    y2 *= s;
    J = j0 - p.kb1 * y1 - p.kb2 * y2;
    jn = glm::dot(J, n);
    if (!(jn > 0)) return false;
  }
  const glm::dvec3 T = y1 * e.t1 + y2 * e.t2;
  const double pn = totals ? std::max(0.0, totals->normal) : 0.0;
  const glm::dvec3 pt = totals ? totals->tangential - glm::dot(totals->tangential, n) * n : glm::dvec3(0);
  const glm::dvec3 jt = J - jn * n;
  if (glm::length(pt + jt) > mu * (pn + jn)) return false;
  // Never add kinetic energy (of the relative motion, with the wrench
  // mobility M): dE = x.v + x.M x / 2, and M x is the right-hand side
  // (dv, r1, r2) when the tilt was not clamped.
  double quad;
  if (s == 1) {
    quad = glm::dot(J, dv) + y1 * r1 + y2 * r2;
  } else {
    const glm::dvec3 du = m.K * J + glm::transpose(p.C) * T, dw = p.C * J + p.W * T;
    quad = glm::dot(J, du) + glm::dot(T, dw);
  }
  const double dE = glm::dot(J, u) + glm::dot(T, omega) + 0.5 * quad;
  if (dE > 1e-12 * (std::abs(glm::dot(J, u)) + std::abs(glm::dot(T, omega))) + 1e-15) return false;
  if (totals) {
    totals->normal += jn;
    totals->tangential += jt;
  }
  jOut = J;
  tOut = T;
  return true;
}

}  // namespace crumple
