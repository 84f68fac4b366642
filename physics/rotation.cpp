#include <crumple/physics/rotation.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace crumple {

PrincipalInertia principalInertia(const glm::dmat3& inertia) {
  // Cyclic Jacobi rotations on the symmetric tensor (glm: m[col][row]); v collects them (columns: eigenvectors).
  double a[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a[r][c] = 0.5 * (inertia[c][r] + inertia[r][c]);
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int sweep = 0; sweep < 60; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off <= 1e-32 * diag || off == 0) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == 0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < 3; ++k) {  // a <- a J (columns p, q)
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {  // a <- J^T a (rows p, q)
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {  // v <- v J
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  std::array<int, 3> order{0, 1, 2};
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return a[x][x] < a[y][y]; });
  PrincipalInertia out;
  glm::dmat3 frame;
  for (int k = 0; k < 3; ++k) {
    const int src = order[static_cast<size_t>(k)];
    out.moments[k] = a[src][src];
    frame[k] = glm::normalize(glm::dvec3(v[0][src], v[1][src], v[2][src]));
  }
  if (glm::determinant(frame) < 0) frame[2] = -frame[2];
  out.frame = glm::normalize(glm::quat_cast(frame));
  return out;
}

namespace {
// sin x and cos x: for |x| <= 1/2 (every turn of a substep but the fastest) their Taylor polynomials (truncated
// far below an ulp, rounded within about one) by Horner's rule (no fused multiply-add: the same bits from every
// machine and build, and about half the instructions of the C library's); std::sin and std::cos beyond.
void sinCos(double x, double& s, double& c) {
  if (!(std::abs(x) <= 0.5)) {
    s = std::sin(x);
    c = std::cos(x);
    return;
  }
  const double x2 = x * x;
  s = x + x * x2 *
              (-1.0 / 6 +
               x2 * (1.0 / 120 +
                     x2 * (-1.0 / 5040 +
                           x2 * (1.0 / 362880 +
                                 x2 * (-1.0 / 39916800 + x2 * (1.0 / 6227020800 + x2 * (-1.0 / 1307674368000)))))));
  c = 1 + x2 * (-0.5 +
                x2 * (1.0 / 24 +
                      x2 * (-1.0 / 720 +
                            x2 * (1.0 / 40320 +
                                  x2 * (-1.0 / 3628800 + x2 * (1.0 / 479001600 + x2 * (-1.0 / 87178291200)))))));
}
}  // namespace

glm::dquat rotateBy(const glm::dquat& q, const glm::dvec3& w, double h) {
  const double speed = glm::length(w);
  if (!(speed > 0)) return q;
  double s, c;
  sinCos(0.5 * h * speed, s, c);
  const glm::dvec3 axis = w * (s / speed);
  return glm::normalize(glm::dquat(c, axis.x, axis.y, axis.z) * q);
}

namespace {
// The rotation taking unit-length direction `from` to `to` (same length), the shorter way.
glm::dquat between(const glm::dvec3& from, const glm::dvec3& to) {
  const glm::dvec3 axis = glm::cross(from, to);
  return glm::normalize(glm::dquat(glm::length(from) * glm::length(to) + glm::dot(from, to), axis.x, axis.y, axis.z));
}
}  // namespace

FreeRotation freeRotation(const PrincipalInertia& inertia, const glm::dquat& q, const glm::dvec3& w, double h) {
  const glm::dvec3& moments = inertia.moments;
  if (w.x == 0 && w.y == 0 && w.z == 0) return {q, w};
  // Equal moments: w stays, the body turns about it.
  const double tolerance = 1e-12 * moments.z;
  if (moments.z - moments.x <= tolerance) return {rotateBy(q, w, h), w};
  glm::dquat frame = q * inertia.frame;  // principal axes -> world
  glm::dvec3 l = moments * (glm::conjugate(frame) * w);  // angular momentum, principal axes
  const glm::dvec3 momentum = frame * l;                  // and world: kept
  const glm::dvec3 inverse = 1.0 / moments;
  const double middle = moments.y;
  // |L|^2 / (2 I_m): a turn about L itself; L in the principal axes stays.
  frame = rotateBy(frame, momentum / middle, h);
  // 1/2 c_k L_k^2: a turn about principal axis k by h c_k L_k (L_k stays during it).
  // (frame r and conj(r) l written out for r = (cos a/2, sin a/2 e_k): a turn about principal axis k, 0 or 2.)
  auto turn = [&](int k, double dt) {
    const double angle = dt * (inverse[k] - inverse.y) * l[k];
    if (angle == 0) return;
    double s, c;
    sinCos(0.5 * angle, s, c);
    const double ca = c * c - s * s, sa = 2 * s * c;  // cos a, sin a
    const glm::dquat f = frame;
    if (k == 0) {
      frame = glm::dquat(f.w * c - f.x * s, f.x * c + f.w * s, f.y * c + f.z * s, f.z * c - f.y * s);
      l = glm::dvec3(l.x, l.y * ca + l.z * sa, l.z * ca - l.y * sa);
    } else {  // k == 2
      frame = glm::dquat(f.w * c - f.z * s, f.x * c + f.y * s, f.y * c - f.x * s, f.z * c + f.w * s);
      l = glm::dvec3(l.x * ca + l.y * sa, l.y * ca - l.x * sa, l.z);
    }
  };
  // A symmetric top (two moments equal): one of the two parts vanishes and the other's flow is exact, whole in one
  // turn; the energy stays as it was (the turn keeps L_k and |L|), so it needs no correction.
  if (moments.y - moments.x <= tolerance || moments.z - moments.y <= tolerance) {
    turn(moments.y - moments.x <= tolerance ? 2 : 0, h);
    frame = glm::normalize(frame);
    return {glm::normalize(frame * glm::conjugate(inertia.frame)), frame * (l * inverse)};
  }
  const double energy = 0.5 * glm::dot(l, l * inverse);  // (before the turns: what the correction brings back)
  turn(0, 0.5 * h);
  turn(2, h);
  turn(0, 0.5 * h);
  // The energy back to its value: L moved on its sphere (|L| kept) along the energy's gradient to the level set,
  // and the body turned so that its world angular momentum stays.
  const double l2 = glm::dot(l, l);
  glm::dvec3 target = l;
  for (int it = 0; it < 4; ++it) {
    const double gap = 0.5 * glm::dot(target, target * inverse) - energy;
    if (!(std::abs(gap) > 1e-15 * energy)) break;
    const glm::dvec3 g = target * inverse;
    const glm::dvec3 t = g - (glm::dot(g, target) / l2) * target;
    const double tt = glm::dot(t, t);
    if (!(tt > 1e-30 * glm::dot(g, g))) break;
    target -= (gap / tt) * t;
    target *= std::sqrt(l2 / glm::dot(target, target));
  }
  if (target != l) {
    frame = frame * between(target, l);
    l = target;
  }
  frame = glm::normalize(frame);
  return {glm::normalize(frame * glm::conjugate(inertia.frame)), frame * (l * inverse)};
}

}  // namespace crumple
