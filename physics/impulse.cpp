#include <crumple/physics/impulse.h>

#include <algorithm>
#include <cmath>

namespace crumple {

namespace {
// M [r]x ([r]x v = r x v), column by column: M (r x e_k), each r x e_k with two components that are not zero.
glm::dmat3 timesCross(const glm::dmat3& m, const glm::dvec3& r) {
  return glm::dmat3(r.z * m[1] - r.y * m[2], r.x * m[2] - r.z * m[0], r.y * m[0] - r.x * m[1]);
}
// [r]x M: column k is r x M e_k.
glm::dmat3 crossTimes(const glm::dvec3& r, const glm::dmat3& m) {
  return glm::dmat3(glm::cross(r, m[0]), glm::cross(r, m[1]), glm::cross(r, m[2]));
}
// Kinetic energy change of the relative motion for impulse j: dE = j.u + 1/2 j.K j.
double energyChange(const glm::dmat3& K, const glm::dvec3& u, const glm::dvec3& j) {
  return glm::dot(j, u) + 0.5 * glm::dot(j, K * j);
}
}  // namespace

glm::dmat3 collisionMatrix(const ImpulseSide& a, const ImpulseSide& b, glm::dmat3* coupling) {
  const glm::dmat3 ta = timesCross(a.invInertia, a.r), tb = timesCross(b.invInertia, b.r);
  glm::dmat3 k((a.invMass + b.invMass));
  k -= crossTimes(a.r, ta);
  k -= crossTimes(b.r, tb);
  if (coupling) *coupling = tb + ta;
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
// Earlier impulses at a contact in this step: the normal total, and the
// friction total in today's tangent plane. holds(j): j keeps the totals in
// Coulomb's cone.
struct Earlier {
  double pn = 0;
  glm::dvec3 pt{0};
  Earlier(const FrictionTotals* t, const glm::dvec3& n) {
    if (!t) return;
    pn = std::max(0.0, t->normal);
    pt = t->tangential - glm::dot(t->tangential, n) * n;
  }
  bool holds(const glm::dvec3& j, const glm::dvec3& n, double mu) const {
    const double jn = glm::dot(j, n);
    return glm::length(pt + (j - jn * n)) <= mu * (pn + jn);
  }
};

glm::dvec3 coulombImpulse(const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& n, double eps, double mu,
                          const FrictionTotals* earlier) {
  const glm::dmat3& K = m.K;
  const double un = glm::dot(u, n);
  if (!(mu > 0)) return frictionlessImpulse(K, u, n, eps);
  const Earlier before(earlier, n);
  const double pn = before.pn, ptLen = glm::length(before.pt);
  if (m.invertible) {
    // Sticking: the relative velocity becomes -eps (u.n) n.
    const glm::dvec3 j = m.inverse * (-eps * un * n - u);
    if (glm::dot(j, n) >= 0 && before.holds(j, n, mu) &&
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
  setPatchMatrix(p, a, b, k);
  return p;
}

void setPatchMatrix(PatchMatrix& p, const ImpulseSide& a, const ImpulseSide& b, const ImpulseMatrix& k) {
  const bool needed = !p.patch.flat() && k.invertible;  // (else the matrix stays invalid: C is not read)
  setPatchMatrix(p, a, b, k, needed ? timesCross(b.invInertia, b.r) + timesCross(a.invInertia, a.r) : glm::dmat3(0));
}

void setPatchMatrix(PatchMatrix& p, const ImpulseSide& a, const ImpulseSide& b, const ImpulseMatrix& k,
                    const glm::dmat3& coupling) {
  p.valid = false;
  p.hinge = false;
  p.s1 = 0;
  const PatchExtent& patch = p.patch;
  if (patch.flat() || !k.invertible) return;
  p.C = coupling;
  p.W = a.invInertia + b.invInertia;
  // The system in (J, y), T = y1 t1 + y2 t2 + y3 n, is [K, B; B^T, D] with
  // B = C^T [t1 t2 n], D = [e_i.W e_k]; it is solved through the Schur
  // complement S = D - B^T K^-1 B of K: with the twist (3x3), and without it
  // (2x2, for a twist held at the torsional friction limit).
  const glm::dmat3 ct = glm::transpose(p.C);
  const glm::dvec3 axes[3] = {patch.t1, patch.t2, patch.n};
  for (int i = 0; i < 3; ++i) {
    p.b[i] = ct * axes[i];
    p.kb[i] = k.inverse * p.b[i];
  }
  const glm::dvec3 wAxes[3] = {p.W * axes[0], p.W * axes[1], p.W * axes[2]};
  glm::dmat3 schur;
  double scale = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      p.w[i][j] = glm::dot(axes[i], wAxes[j]);
      schur[j][i] = p.w[i][j] - glm::dot(p.b[i], p.kb[j]);
      scale = std::max(scale, std::abs(schur[j][i]));
    }
  if (!(scale > 0)) return;
  const double det2 = schur[0][0] * schur[1][1] - schur[1][0] * schur[1][0];
  if (!(det2 > 1e-12 * scale * scale)) return;
  p.s2[0][0] = schur[1][1] / det2;
  p.s2[0][1] = p.s2[1][0] = -schur[1][0] / det2;
  p.s2[1][1] = schur[0][0] / det2;
  const double det3 = glm::determinant(schur);
  if (!(det3 > 1e-12 * scale * scale * scale)) return;
  p.s3 = glm::inverse(schur);
  // The lever of torsional friction: the mean distance from the centre of a
  // uniformly pressed rectangle, about 0.77 of its mean half side.
  p.twistRadius = patch.twistRadius();
  p.valid = true;
}

PatchMatrix lineMatrix(const ImpulseSide& a, const ImpulseSide& b, const ImpulseMatrix& k, const PatchExtent& patch,
                       const glm::dvec3& axis) {
  PatchMatrix p;
  const glm::dvec3 along = axis - glm::dot(axis, patch.n) * patch.n;
  if (!k.invertible || !(glm::length(along) > 1e-9) || patch.hi1 - patch.lo1 <= 0 || patch.hi2 - patch.lo2 <= 0)
    return p;
  // The patch in axes along and across the line: its corners' extent.
  PatchExtent e;
  e.n = patch.n;
  e.t1 = glm::normalize(along);
  e.t2 = glm::cross(e.n, e.t1);
  for (double c1 : {patch.lo1, patch.hi1})
    for (double c2 : {patch.lo2, patch.hi2}) {
      const glm::dvec3 d = c1 * patch.t1 + c2 * patch.t2;
      e.lo1 = std::min(e.lo1, glm::dot(d, e.t1));
      e.hi1 = std::max(e.hi1, glm::dot(d, e.t1));
      e.lo2 = std::min(e.lo2, glm::dot(d, e.t2));
      e.hi2 = std::max(e.hi2, glm::dot(d, e.t2));
    }
  p.patch = e;
  p.C = timesCross(b.invInertia, b.r) + timesCross(a.invInertia, a.r);
  p.W = a.invInertia + b.invInertia;
  p.b[0] = glm::transpose(p.C) * e.t1;
  p.kb[0] = k.inverse * p.b[0];
  const double w11 = glm::dot(e.t1, p.W * e.t1), schur = w11 - glm::dot(p.b[0], p.kb[0]);
  if (!(schur > 1e-12 * w11)) return p;
  p.s1 = 1 / schur;
  p.hinge = true;
  p.valid = true;
  return p;
}

namespace {
// What every patch impulse ends with: Coulomb's cone over the totals, no gain
// of kinetic energy (of the relative motion, with the wrench mobility M:
// dE = x.v + x.M x / 2; `quad` is x.M x where known, NaN to compute it), the
// totals, the result.
// (Always inlined: a call cost the pile of 1000 boxes 1.4 million calls of ~120 instructions.)
[[gnu::always_inline]] inline bool finishPatch(const PatchMatrix& p, const ImpulseMatrix& m, const glm::dvec3& u,
                                               const glm::dvec3& omega, const glm::dvec3& n, double mu,
                                               FrictionTotals* totals, const glm::dvec3& J, const glm::dvec3& T,
                                               double quad, glm::dvec3& jOut, glm::dvec3& tOut) {
  if (!Earlier(totals, n).holds(J, n, mu)) return false;
  if (std::isnan(quad)) {
    const glm::dvec3 du = m.K * J + glm::transpose(p.C) * T, dw = p.C * J + p.W * T;
    quad = glm::dot(J, du) + glm::dot(T, dw);
  }
  const double dE = glm::dot(J, u) + glm::dot(T, omega) + 0.5 * quad;
  if (dE > 1e-12 * (std::abs(glm::dot(J, u)) + std::abs(glm::dot(T, omega))) + 1e-15) return false;
  if (totals) {
    const double jn = glm::dot(J, n);
    totals->normal += jn;
    totals->tangential += J - jn * n;
  }
  jOut = J;
  tOut = T;
  return true;
}

// A largest s in [0, 1] with alpha + s beta <= 0 (s = 0 if none).
void limitScale(double& s, double alpha, double beta) {
  if (alpha + beta <= 0) return;
  s = std::min(s, beta > 0 && alpha <= 0 ? -alpha / beta : 0.0);
}
}  // namespace

bool patchImpulse(const PatchMatrix& p, const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& omega,
                  const glm::dvec3& n, double eps, double mu, FrictionTotals* totals, glm::dvec3& jOut,
                  glm::dvec3& tOut, bool* whole) {
  if (whole) *whole = false;
  if (!p.valid || !m.invertible) return false;
  const double un = glm::dot(u, n);
  if (un >= 0) return false;
  const PatchExtent& e = p.patch;
  const glm::dvec3 dv = -eps * un * n - u;
  if (p.hinge) {
    // The tilt about t1 only: T = y t1, its centre of pressure d = y / jn across the line.
    const glm::dvec3 j0 = m.inverse * dv;
    const double r1 = -glm::dot(e.t1, omega);
    double y = (r1 - glm::dot(p.b[0], j0)) * p.s1;
    const double A = glm::dot(j0, n), B = glm::dot(p.kb[0], n) * y;
    double s = 1;
    limitScale(s, y - e.hi2 * A, e.hi2 * B);   // y s <= hi2 (A - s B)
    limitScale(s, e.lo2 * A - y, -e.lo2 * B);  // y s >= lo2 (A - s B)
    y *= std::max(s, 0.0);
    const glm::dvec3 J = j0 - p.kb[0] * y;
    if (!(glm::dot(J, n) > 0)) return false;
    return finishPatch(p, m, u, omega, n, mu, totals, J, y * e.t1, std::nan(""), jOut, tOut);
  }
  const double r[3] = {-glm::dot(e.t1, omega), -glm::dot(e.t2, omega), -glm::dot(n, omega)};
  const glm::dvec3 j0 = m.inverse * dv;
  // Sticking in all six: the point's target, no relative tilt, no relative twist.
  const glm::dvec3 q(r[0] - glm::dot(p.b[0], j0), r[1] - glm::dot(p.b[1], j0), r[2] - glm::dot(p.b[2], j0));
  glm::dvec3 y = p.s3 * q;
  glm::dvec3 J = j0 - p.kb[0] * y[0] - p.kb[1] * y[1] - p.kb[2] * y[2];
  double jn = glm::dot(J, n);
  if (!(jn > 0)) return false;
  bool exact = true;
  // Torsional friction: |twist torque| <= mu jn times the patch's twist lever,
  // else the twist slides at that limit and tilt and point are solved without it.
  const double twistLimit = mu * jn * p.twistRadius;
  if (std::abs(y[2]) > twistLimit) {
    exact = false;
    y[2] = std::copysign(twistLimit, y[2]);
  }
  auto solveTilt = [&] {
    const glm::dvec3 jt = j0 - p.kb[2] * y[2];
    const double q1 = r[0] - p.w[0][2] * y[2] - glm::dot(p.b[0], jt),
                 q2 = r[1] - p.w[1][2] * y[2] - glm::dot(p.b[1], jt);
    y[0] = p.s2[0][0] * q1 + p.s2[0][1] * q2;
    y[1] = p.s2[1][0] * q1 + p.s2[1][1] * q2;
  };
  if (!exact) {
    solveTilt();
    J = j0 - p.kb[0] * y[0] - p.kb[1] * y[1] - p.kb[2] * y[2];  // (else y, and so J, are as above)
    jn = glm::dot(J, n);
    if (!(jn > 0)) return false;
  }
  // The centre of pressure's offset d from the point: the tilt torque is
  // d x (jn n), so d = n x T / jn = (-y2 t1 + y1 t2) / jn.
  // Scaling the tilt torque by s scales d's numerator by s and makes the
  // normal impulse A - s B: the largest s that keeps d in the patch is exact.
  const double num[2] = {-y[1], y[0]}, lo[2] = {e.lo1, e.lo2}, hi[2] = {e.hi1, e.hi2};
  double s = 1;
  glm::dvec3 jTwist(0), jTilt(0);
  double A = 0, B = 0;
  bool split = false;  // jTwist, jTilt, A and B made (only where d leaves the patch at s = 1)
  for (int k = 0; k < 2; ++k) {
    const double bound = num[k] > 0 ? hi[k] : lo[k];
    if (num[k] == 0 || std::abs(num[k]) <= std::abs(bound) * jn) continue;  // inside at s = 1
    if (!split) {
      jTwist = j0 - p.kb[2] * y[2];
      jTilt = p.kb[0] * y[0] + p.kb[1] * y[1];
      A = glm::dot(jTwist, n);
      B = glm::dot(jTilt, n);
      split = true;
    }
    const double den = num[k] + bound * B;
    const double sk = den != 0 ? bound * A / den : 0.0;
    s = std::min(s, std::clamp(sk, 0.0, 1.0));
  }
  if (s < 1) {
    // The patch cannot hold the tilt: the most it can, and the point's target with it.
    exact = false;
    y[0] *= s;
    y[1] *= s;
    J = jTwist - s * jTilt;
    jn = glm::dot(J, n);
    if (!(jn > 0)) return false;
  }
  const glm::dvec3 T = y[0] * e.t1 + y[1] * e.t2 + y[2] * n;
  // x.M x is the right-hand side (dv, r) dotted with x when nothing was clamped.
  const double quad = exact ? glm::dot(J, dv) + y[0] * r[0] + y[1] * r[1] + y[2] * r[2] : std::nan("");
  if (!finishPatch(p, m, u, omega, n, mu, totals, J, T, quad, jOut, tOut)) return false;
  if (whole) *whole = exact;
  return true;
}

}  // namespace crumple
