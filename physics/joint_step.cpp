// Joints in the step (Weinstein, Teran & Fedkiw 2006, "Dynamic simulation of
// articulated rigid bodies with contact and collision"), as impulses like the
// contacts.
//
// Each joint is a set of rows: directions in the space of (relative velocity of
// the anchors, relative angular velocity) of B against A that it forbids:
//   ball      3 linear                       (the anchors coincide)
//   hinge     3 linear + 2 angular           (+ the axes stay aligned)
//   slider    2 linear normal to the axis + 3 angular
//   fixed     3 linear + 3 angular
//   distance  1 linear along the anchors' line (one-sided for a range)
// An impulse sum_k lambda_k row_k (a linear impulse at the anchors and a pure
// torque impulse, on B, their opposites on A) changes the rows' quantities by
// M lambda, where M = rows W rows^T and W is the 6x6 matrix of the two bodies'
// inverse masses and inertias at the anchors (K, its coupling to the turn, and
// the sum of the inverse inertias).
//
// Guarantees:
// - preStabilize (twice a substep; the second call only when the contact step
//   touched a joined body): motors first (velocity targets; the impulse over a
//   substep is at most maxForce h, over both calls of the substep), then the
//   joints' rows are solved for the impulses that make them hold at the end of
//   the substep, at the poses the position update will reach with the
//   velocities (x + h v, q integrated from omega). Each pass is a Newton step
//   on the linearisation of all joints at once: the joints that form a spanning
//   forest over the bodies (what cannot move counting as one; taken strongest
//   first: welds, hinges and sliders, balls, rods) are solved together by
//   a sparse L D L^T factorisation over the joint graph (linear in the joints
//   for chains and trees); each joint that closes a loop (a second joint
//   between the same bodies, a ring, a second anchor to the world) is then
//   solved alone (Gauss-Seidel). Passes go on until every joint's predicted
//   violation is under jointTolerance or `sweeps` passes are done. Limits are
//   one-sided rows at the bound, acting only where the predicted angle (hinge),
//   offset (slider) or distance would leave the range.
// - postStabilize (after the positions): the relative velocity each joint
//   forbids is removed (limits: only the part that leaves the range), one pass
//   of the same solve (the rows are linear), up to `jointPostIterations` where
//   limits, ranges or loops take part; then every hinge's unwrapped angle is
//   updated.
// - projectJoints (in the position step's projection, after each iteration over
//   the contacts): one Gauss-Seidel sweep that translates each joint's bodies,
//   split by inverse mass, to close its anchor gap (the part the joint forbids),
//   no body further than the projection's reach (maxCorrectionSpeed x h) in all.
// - findAnchored: ctx.anchored marks the bodies welded to the world or to a
//   static body through fixed joints that hold (the collision step's elastic
//   impulse treats them as part of what they are welded to).
// - Breaking (at the end of each pre- and post-stabilisation call): a joint
//   whose linear impulse summed over the step so far passes its breakImpulse
//   breaks at the call's start (one JointBreak, with the impulse it was asked
//   for): the call is solved again from its start without it, and it enforces
//   nothing from then on.
// - A joint between two bodies that cannot move (static, kinematic, asleep) does
//   nothing; a sleeping body joined to an awake one is woken first.
#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <type_traits>
#include <utility>

#include "physics/step_context.h"

namespace crumple::detail {

namespace {

constexpr double kPi = 3.14159265358979323846;

double wrapAngle(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a <= -kPi) a += 2 * kPi;
  return a;
}

glm::dmat3 skew(const glm::dvec3& r) {
  // [r]x: skew(r) * v = r x v (GLM matrices are column-major)
  return glm::dmat3(0, r.z, -r.y, -r.z, 0, r.x, r.y, -r.x, 0);
}

// Two unit directions normal to n and to each other.
void normalBasis(const glm::dvec3& n, glm::dvec3& t1, glm::dvec3& t2) {
  const glm::dvec3 helper = std::abs(n.x) < 0.57 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  t1 = glm::normalize(glm::cross(n, helper));
  t2 = glm::cross(n, t1);
}

// One body's side of a joint (the world when index < 0): what stays put within
// a pre- or post-stabilisation call (the pose, its rotation, the inverse mass
// and world inverse inertia) and what a pass refreshes (the velocities and the
// pose they reach after h).
struct Side {
  int index = -1;
  double invMass = 0;
  glm::dmat3 invInertia{0};
  Pose pose;       // now
  Pose predicted;  // after h with the current velocities
  glm::dmat3 R{1}, Rp{1};  // rotations of pose and predicted
  glm::dvec3 v{0}, w{0};

  // A body-frame point or direction (world coordinates for the world), now or predicted.
  glm::dvec3 point(const glm::dvec3& local, bool pred) const {
    if (index < 0) return local;
    return pred ? predicted.position + Rp * local : pose.position + R * local;
  }
  glm::dvec3 dir(const glm::dvec3& local, bool pred) const {
    if (index < 0) return local;
    return (pred ? Rp : R) * local;
  }
  glm::dquat rot(bool pred) const {
    if (index < 0) return glm::dquat(1, 0, 0, 0);
    return pred ? predicted.orientation : pose.orientation;
  }
  // The velocities from the body, and (pre) the pose they reach after h.
  void refresh(const StepContext& ctx, double h, bool pred) {
    if (index < 0) return;
    const RigidBody& b = ctx.body(index);
    if (!b.movable()) return;
    v = b.v;
    w = b.w;
    if (pred) {
      predicted = {b.x + h * b.v, turn(b, b.w, h).q};
      Rp = glm::mat3_cast(predicted.orientation);
    }
  }
};

// A side now: the pose, the inverse masses, the velocities (predicted = now).
Side sideAt(const StepContext& ctx, int i) {
  Side s;
  s.index = i;
  if (i < 0) return s;
  const RigidBody& b = ctx.body(i);
  s.pose = {b.x, b.q};
  s.predicted = s.pose;
  s.R = s.Rp = glm::mat3_cast(b.q);
  if (!b.movable()) return s;
  if (b.dynamic()) {
    s.invMass = b.invMass;
    s.invInertia = b.invInertiaWorld();  // at the pose now (post-stabilisation runs after the position update)
  }
  s.v = b.v;
  s.w = b.w;
  return s;
}

// The 6x6 map from (linear impulse at the anchors, torque impulse) on B to the
// change of (relative anchor velocity, relative angular velocity).
struct Mobility {
  glm::dmat3 K{0}, C{0}, A{0};  // [[K, C], [C^T, A]]
  glm::dvec3 ra{0}, rb{0};      // levers (now)
};

Mobility mobility(const Side& a, const Side& b, const glm::dvec3& ra, const glm::dvec3& rb) {
  Mobility m;
  m.ra = ra;
  m.rb = rb;
  const glm::dmat3 sa = skew(ra), sb = skew(rb);
  m.K = glm::dmat3(a.invMass + b.invMass) - sa * a.invInertia * sa - sb * b.invInertia * sb;
  m.C = -(sb * b.invInertia + sa * a.invInertia);
  m.A = a.invInertia + b.invInertia;
  return m;
}

struct Row {
  glm::dvec3 lin{0}, ang{0};
};

// Solves M lambda = rhs for up to 6 rows (Gaussian elimination, partial
// pivoting); a row whose pivot vanishes (a direction neither body can move in)
// gets lambda 0.
void solveRows(const Mobility& m, const Row* rows, int n, const double* rhs, double* lambda) {
  double M[6][7];
  double scale = 0;
  for (int i = 0; i < n; ++i) {
    const glm::dvec3 ul = m.K * rows[i].lin + m.C * rows[i].ang;  // W row_i
    const glm::dvec3 ua = glm::transpose(m.C) * rows[i].lin + m.A * rows[i].ang;
    for (int j = 0; j < n; ++j) M[j][i] = glm::dot(rows[j].lin, ul) + glm::dot(rows[j].ang, ua);
    M[i][n] = rhs[i];
  }
  for (int i = 0; i < n; ++i) scale = std::max(scale, std::abs(M[i][i]));
  const double tiny = 1e-12 * std::max(scale, 1e-300);
  bool dead[6] = {};
  for (int c = 0; c < n; ++c) {
    int p = c;
    for (int r = c + 1; r < n; ++r)
      if (std::abs(M[r][c]) > std::abs(M[p][c])) p = r;
    if (std::abs(M[p][c]) <= tiny) {
      dead[c] = true;
      continue;
    }
    if (p != c) {
      for (int k = 0; k <= n; ++k) std::swap(M[p][k], M[c][k]);
    }
    for (int r = c + 1; r < n; ++r) {
      const double f = M[r][c] / M[c][c];
      if (f == 0) continue;
      for (int k = c; k <= n; ++k) M[r][k] -= f * M[c][k];
    }
  }
  for (int c = n - 1; c >= 0; --c) {
    if (dead[c]) {
      lambda[c] = 0;
      continue;
    }
    double x = M[c][n];
    for (int k = c + 1; k < n; ++k) x -= M[c][k] * lambda[k];
    lambda[c] = x / M[c][c];
  }
}

// Applies a linear impulse j at the anchors and a torque impulse t on B (their opposites on A).
void applyImpulse(StepContext& ctx, const glm::dvec3& ra, const glm::dvec3& rb, const Side& a, const Side& b,
                  const glm::dvec3& j, const glm::dvec3& t) {
  if (a.index >= 0 && (a.invMass > 0)) {
    RigidBody& A = ctx.body(a.index);
    A.v -= j * a.invMass;
    A.w -= a.invInertia * (glm::cross(ra, j) + t);
  }
  if (b.index >= 0 && (b.invMass > 0)) {
    RigidBody& B = ctx.body(b.index);
    B.v += j * b.invMass;
    B.w += b.invInertia * (glm::cross(rb, j) + t);
  }
}

// Applies sum lambda_k row_k on B (its opposite on A) and books it on the joint.
void applyRows(StepContext& ctx, Joint& jt, const glm::dvec3& ra, const glm::dvec3& rb, const Side& a, const Side& b,
               const Row* rows, int n, const double* lambda) {
  glm::dvec3 j(0), t(0);
  for (int k = 0; k < n; ++k) {
    j += lambda[k] * rows[k].lin;
    t += lambda[k] * rows[k].ang;
  }
  applyImpulse(ctx, ra, rb, a, b, j, t);
  jt.stepImpulse += j;
  jt.callLinear += j;
  jt.callTurnA += glm::cross(ra, j) + t;
  jt.callTurnB += glm::cross(rb, j) + t;
}

// A rotation vector of the small rotation q (angle times axis).
glm::dvec3 rotationVector(glm::dquat q) {
  if (q.w < 0) q = -q;
  const glm::dvec3 v(q.x, q.y, q.z);
  const double s = glm::length(v);
  if (s < 1e-12) return 2.0 * v;
  return v * (2 * std::atan2(s, q.w) / s);
}

// The hinge angle at the sides' poses (predicted or now): B's reference direction against A's about A's axis.
double hingeAngle(const Joint& jt, const Side& a, const Side& b, bool pred) {
  const glm::dvec3 n = a.dir(jt.axisA, pred), ra = a.dir(jt.refA, pred), rb = b.dir(jt.refB, pred);
  return std::atan2(glm::dot(n, glm::cross(ra, rb)), glm::dot(ra, rb));
}

bool active(const StepContext& ctx, const Joint& jt) {
  if (jt.removed || jt.broken) return false;
  const bool ma = jt.def.a >= 0 && ctx.body(jt.def.a).dynamic(), mb = ctx.body(jt.def.b).dynamic();
  return ma || mb;
}

// What a joint forbids in one pass: its rows (at most 6), their errors (the
// predicted violation for pre, the relative velocity for post) and the levers
// the impulses act at (pre: at the substep's end; post: now).
struct JointRows {
  int n = 0;
  Row rows[6];
  double err[6] = {};
  glm::dvec3 ra{0}, rb{0};
  double worst = 0;  // m or rad (pre); m or rad per substep (post)
};

constexpr int kMainRows = 1, kLimitRow = 2;

// The rows of joint jt towards its end-of-substep target (pre = true) or its
// velocity target (pre = false); a hinge's or slider's limit row joins them
// where the predicted angle or offset leaves the range (pre), or sits at a
// bound and moves out of it (post).
//
// Pre, a joint that starts the substep violated by more than `reach` (m, or rad
// for turns: maxCorrectionSpeed x h) in a row is asked to close only `reach` of
// that violation by the substep's end (its bodies' own motion still counts in
// full): a joint that starts far apart closes over a few steps instead of
// flinging its bodies.
JointRows jointRows(const Joint& jt, const Side& a, const Side& b, double h, bool pre, double reach,
                    int parts = kMainRows | kLimitRow) {
  const JointDef& d = jt.def;
  JointRows out;
  // What a row's violation now exceeds reach by (0 within it).
  auto excess = [reach](double now) { return now > reach ? now - reach : (now < -reach ? now + reach : 0.0); };
  const bool bounded = pre && reach >= 0;
  // Errors at the poses the substep will reach, and (pre) the levers there too: the impulse stands for the
  // joint's force over the substep, and with the end's levers the Newton step's matrix is the derivative of
  // the end-of-substep gap (with the start's levers it was off by the turn over the substep, and chains of
  // light links under a heavy body diverged unless their substeps kept each turn small). Post: now.
  const glm::dvec3 e = b.point(jt.rB, pre) - a.point(jt.rA, pre);  // anchor gap
  // A slider's B anchor runs along A's axis: its rows hold B's anchor to the point of A's axis it is at, so A's
  // side acts at that point (A's anchor + the gap), not at A's anchor. The rows' rates are then the exact
  // derivatives of their errors (A turning carries the axis, and a bead far along a turning rod with it), and the
  // impulses turn A as the bead pushes it there.
  const glm::dvec3 ra = d.a < 0 ? glm::dvec3(0) : a.dir(jt.rA, pre) + (d.type == JointType::Slider ? e : glm::dvec3(0));
  const glm::dvec3 rb = b.dir(jt.rB, pre);
  out.ra = ra;
  out.rb = rb;
  const glm::dvec3 eNow = bounded ? b.point(jt.rB, false) - a.point(jt.rA, false) : glm::dvec3(0);
  const glm::dvec3 u = (b.v + glm::cross(b.w, rb)) - (a.v + glm::cross(a.w, ra));
  const glm::dvec3 omega = b.w - a.w;
  Row* rows = out.rows;
  double* err = out.err;
  int& n = out.n;
  auto linear = [&](const glm::dvec3& dir) {
    rows[n] = {dir, glm::dvec3(0)};
    err[n++] = pre ? glm::dot(dir, e) - (bounded ? excess(glm::dot(dir, eNow)) : 0.0) : glm::dot(dir, u);
  };
  auto angular = [&](const glm::dvec3& dir, double angleError, double angleNow) {
    rows[n] = {glm::dvec3(0), dir};
    err[n++] = pre ? angleError - (bounded ? excess(angleNow) : 0.0) : glm::dot(dir, omega);
  };
  const bool axial = d.type == JointType::Hinge || d.type == JointType::Slider;
  const glm::dvec3 axis = axial ? glm::normalize(a.dir(jt.axisA, pre)) : glm::dvec3(0, 1, 0);
  glm::dvec3 t1(0), t2(0);
  if (axial) normalBasis(axis, t1, t2);
  // Relative turn of B against its target relative to A (fixed, slider).
  auto turnError = [&](bool at) { return rotationVector(b.rot(at) * glm::conjugate(a.rot(at) * jt.rel0)); };
  if (parts & kMainRows) switch (d.type) {
    case JointType::Ball:
      for (int k = 0; k < 3; ++k) linear(glm::dvec3(k == 0, k == 1, k == 2));
      break;
    case JointType::Fixed: {
      for (int k = 0; k < 3; ++k) linear(glm::dvec3(k == 0, k == 1, k == 2));
      const glm::dvec3 th = pre ? turnError(true) : glm::dvec3(0);
      const glm::dvec3 now = bounded ? turnError(false) : glm::dvec3(0);
      for (int k = 0; k < 3; ++k) angular(glm::dvec3(k == 0, k == 1, k == 2), th[k], now[k]);
      break;
    }
    case JointType::Hinge: {
      for (int k = 0; k < 3; ++k) linear(glm::dvec3(k == 0, k == 1, k == 2));
      const glm::dvec3 th = pre ? glm::cross(axis, glm::normalize(b.dir(jt.axisB, true))) : glm::dvec3(0);
      const glm::dvec3 now =
          bounded ? glm::cross(glm::normalize(a.dir(jt.axisA, false)), glm::normalize(b.dir(jt.axisB, false)))
                  : glm::dvec3(0);
      angular(t1, glm::dot(th, t1), glm::dot(now, t1));
      angular(t2, glm::dot(th, t2), glm::dot(now, t2));
      break;
    }
    case JointType::Slider: {
      linear(t1);
      linear(t2);
      const glm::dvec3 th = pre ? turnError(true) : glm::dvec3(0);
      const glm::dvec3 now = bounded ? turnError(false) : glm::dvec3(0);
      for (int k = 0; k < 3; ++k) angular(glm::dvec3(k == 0, k == 1, k == 2), th[k], now[k]);
      break;
    }
    case JointType::Distance: {
      const double len = glm::length(e);
      if (len < 1e-9) break;
      const glm::dvec3 dir = e / len;
      const double lenNow = bounded ? glm::length(eNow) : 0.0;
      if (jt.minLength == jt.maxLength) {
        linear(dir);
        if (pre) err[n - 1] = len - jt.length - (bounded ? excess(lenNow - jt.length) : 0.0);
      } else if (pre && (len > jt.maxLength || len < jt.minLength)) {
        linear(dir);
        const double bound = len > jt.maxLength ? jt.maxLength : jt.minLength;
        const double over = bounded ? excess(lenNow - bound) : 0.0;
        // Only what is still beyond the bound in the bound's direction is left for later.
        err[n - 1] = len - bound - ((over > 0) == (len > bound) ? over : 0.0);
      } else if (!pre) {
        // Post: only at a bound and moving out of the range.
        const double l = glm::length(b.point(jt.rB, false) - a.point(jt.rA, false));
        const double speed = glm::dot(dir, u);
        if ((l >= jt.maxLength - 1e-6 && speed > 0) || (l <= jt.minLength + 1e-6 && speed < 0)) linear(dir);
      }
      break;
    }
  }
  if (axial && d.limited && (parts & kLimitRow)) {
    // The angle or offset: predicted (pre) or now (post).
    const bool hinge = d.type == JointType::Hinge;
    const double value = hinge ? jt.angle + wrapAngle(hingeAngle(jt, a, b, pre) - wrapAngle(jt.angle))
                               : glm::dot(e, axis);
    const double rate = hinge ? glm::dot(axis, omega) : glm::dot(axis, u);
    const Row row = hinge ? Row{glm::dvec3(0), axis} : Row{axis, glm::dvec3(0)};
    const double tol = 1e-6;
    if (pre && (value > d.upper || value < d.lower)) {
      rows[n] = row;
      const double bound = value > d.upper ? d.upper : d.lower;
      double over = 0;
      if (bounded) {
        const double now = hinge ? jt.angle + wrapAngle(hingeAngle(jt, a, b, false) - wrapAngle(jt.angle))
                                 : glm::dot(eNow, glm::normalize(a.dir(jt.axisA, false)));
        over = excess(now - bound);
        if ((over > 0) != (value > bound)) over = 0;  // now beyond the other side: nothing to leave for later
      }
      err[n++] = value - bound - over;
    } else if (!pre && ((value >= d.upper - tol && rate > 0) || (value <= d.lower + tol && rate < 0))) {
      rows[n] = row;
      err[n++] = rate;
    }
  }
  for (int k = 0; k < n; ++k) out.worst = std::max(out.worst, std::abs(err[k]) * (pre ? 1.0 : h));
  return out;
}

// ---- the direct solve ---------------------------------------------------------
//
// Every pass solves all joints' rows at once: A lambda = rhs with
// A = J W J^T (J the rows against the bodies' velocities, W their inverse
// masses and inertias), one block per joint, joints coupled where they share
// a dynamic body. A is factored as L D L^T over the joint graph in a minimum
// degree order: a chain or any tree of bodies (whose joint graph is chordal)
// is factored with no fill, in time linear in its joints, so a chain of any
// length is solved in one pass instead of converging over Gauss-Seidel sweeps.
// A row whose pivot vanishes (a direction no body can move in, or a joint
// repeating another) gets lambda 0.

struct Block {
  double m[6][6];
};

// A joint's end on one body: per row, the direction g it moves the body's (v, omega) in, and W g.
struct RowEnd {
  double g[6][6], wg[6][6];
};

// The symmetric (pseudo-)inverse of the n x n positive semi-definite matrix a
// (LDL^T without pivoting). A pivot that is not above 1e-9 of the row's own
// diagonal before any elimination (`scale`: what is left of it is rounding, the
// row repeats others) is dropped: that row gets lambda 0.
template <int n>
void pseudoInverseN(const Block& a, const double* scale, Block& inv) {
  double L[n][n] = {}, d[n] = {}, invd[n] = {};
  for (int k = 0; k < n; ++k) {
    double dk = a.m[k][k];
    for (int j = 0; j < k; ++j) dk -= L[k][j] * L[k][j] * d[j];
    const bool dead = !(dk > 1e-9 * scale[k]) || !(scale[k] > 0);
    d[k] = dead ? 0 : dk;
    invd[k] = dead ? 0 : 1 / dk;
    L[k][k] = 1;
    for (int i = k + 1; i < n; ++i) {
      if (dead) {
        L[i][k] = 0;
        continue;
      }
      double s = a.m[i][k];
      for (int j = 0; j < k; ++j) s -= L[i][j] * L[k][j] * d[j];
      L[i][k] = s / dk;
    }
  }
  // inv = L^-T diag(invd) L^-1, column by column.
  for (int c = 0; c < n; ++c) {
    double y[n];
    for (int i = 0; i < n; ++i) {
      double s = i == c ? 1.0 : 0.0;
      for (int j = 0; j < i; ++j) s -= L[i][j] * y[j];
      y[i] = s;
    }
    for (int i = 0; i < n; ++i) y[i] *= invd[i];
    for (int i = n - 1; i >= 0; --i) {
      double s = y[i];
      for (int j = i + 1; j < n; ++j) s -= L[j][i] * y[j];
      y[i] = s;
    }
    for (int i = 0; i < n; ++i) inv.m[i][c] = y[i];
  }
}

// Calls f(std::integral_constant<int, n>) for n in 1..6 (0: nothing), so that the small dense loops below are
// unrolled for each row count.
template <class F, int... N>
void withSizeIn(int n, F&& f, std::integer_sequence<int, N...>) {
  (void)((n == N + 1 && (f(std::integral_constant<int, N + 1>{}), true)) || ...);
}
template <class F>
void withSize(int n, F&& f) {
  withSizeIn(n, f, std::make_integer_sequence<int, 6>{});
}

// out (np x nq) = inv (np x np) * off (np x nq).
template <int np>
void leftMultiply(const Block& inv, const Block& off, int nq, Block& out) {
  for (int i = 0; i < np; ++i)
    for (int c = 0; c < nq; ++c) {
      double v = 0;
      for (int k = 0; k < np; ++k) v += inv.m[i][k] * off.m[k][c];
      out.m[i][c] = v;
    }
}

// target (nq x nr) -= a^T b, a: np x nq, b: np x nr.
template <int np>
void subtractProduct(const Block& a, const Block& b, int nq, int nr, Block& target) {
  for (int i = 0; i < nq; ++i)
    for (int c = 0; c < nr; ++c) {
      double v = 0;
      for (int k = 0; k < np; ++k) v += a.m[k][i] * b.m[k][c];
      target.m[i][c] -= v;
    }
}

}  // namespace

// The joints of a call, the bodies they join and the elimination order (kept
// in StepContext::jointSolver while `signature` stays the same), and what each
// pass fills in.
struct JointSystem {
  std::vector<int> signature;             // per active joint: id, and which of its ends are dynamic
  std::vector<int> joints;                // active joints (ids), in id order
  std::vector<int> slot;                  // per body index: its side in `sides`, or -1
  std::vector<Side> sides;                // [0] is the world
  std::vector<std::pair<int, int>> ends;  // per active joint: the slots of a and b
  // Joints that close a loop (through each other or through what cannot move,
  // e.g. a second joint between the same two bodies): solved one by one
  // (Gauss-Seidel) between the direct solves of the others, which form a forest.
  std::vector<int> loops;
  std::vector<std::pair<int, int>> loopEnds;
  // Per dynamic body slot: the joints (places in `joints`) on it, with +1 on B, -1 on A.
  std::vector<std::vector<std::pair<int, int>>> onBody;
  bool conditional = false;               // some rows come and go (limits, distance ranges)
  std::vector<int> order, place;          // elimination position -> joint, joint -> position
  std::vector<std::vector<int>> later;    // per position: the later positions L couples it to (sorted)
  // Per pass.
  std::vector<JointRows> rows;            // per joint
  std::vector<Block> diag, inv;           // per position
  std::vector<std::array<double, 6>> scale;  // per position: the diagonal before elimination
  std::vector<std::vector<Block>> off;    // per position, along `later`
  std::vector<std::array<double, 6>> x;   // per position
  std::vector<Block> scratch;
  std::vector<RowEnd> endScratch;  // per joint on the body being assembled
};

JointSolverCache::JointSolverCache() = default;
JointSolverCache::JointSolverCache(const JointSolverCache&) {}
JointSolverCache& JointSolverCache::operator=(const JointSolverCache& o) {
  if (this != &o) system.reset();
  return *this;
}
JointSolverCache::~JointSolverCache() = default;

namespace {

// The system of this call: the cached one with the sides brought up to date
// while the active joints and which of their ends are dynamic stay the same,
// else built anew.
JointSystem& buildSystem(StepContext& ctx) {
  if (!ctx.jointSolver.system) ctx.jointSolver.system = std::make_unique<JointSystem>();
  JointSystem& s = *ctx.jointSolver.system;
  auto code = [&](const Joint& jt) {
    return (jt.def.a >= 0 && ctx.body(jt.def.a).dynamic() ? 1 : 0) | (ctx.body(jt.def.b).dynamic() ? 2 : 0);
  };
  // Compared in place (no vector built when it is the same).
  size_t at = 0;
  bool same = true;
  for (size_t i = 0; i < ctx.joints.size() && same; ++i) {
    const Joint& jt = ctx.joints[i];
    if (!active(ctx, jt)) continue;
    same = at + 1 < s.signature.size() && s.signature[at] == static_cast<int>(i) && s.signature[at + 1] == code(jt);
    at += 2;
  }
  if (same && at == s.signature.size()) {
    for (size_t k = 1; k < s.sides.size(); ++k) s.sides[k] = sideAt(ctx, s.sides[k].index);
    return s;
  }
  s.signature.clear();
  for (size_t i = 0; i < ctx.joints.size(); ++i) {
    const Joint& jt = ctx.joints[i];
    if (!active(ctx, jt)) continue;
    s.signature.push_back(static_cast<int>(i));
    s.signature.push_back(code(jt));
  }
  s.conditional = false;
  s.slot.assign(ctx.bodies.size(), -1);
  s.sides.assign(1, Side{});
  s.joints.clear();
  s.ends.clear();
  s.loops.clear();
  s.loopEnds.clear();
  s.onBody.assign(1, {});
  auto slotOf = [&](int body) {
    if (body < 0) return 0;
    int& k = s.slot[static_cast<size_t>(body)];
    if (k < 0) {
      k = static_cast<int>(s.sides.size());
      s.sides.push_back(sideAt(ctx, body));
      s.onBody.emplace_back();
    }
    return k;
  };
  std::vector<int> active;
  std::vector<std::pair<int, int>> ends;
  for (size_t i = 0; i < ctx.joints.size(); ++i) {
    const Joint& jt = ctx.joints[i];
    if (!crumple::detail::active(ctx, jt)) continue;
    const int sa = slotOf(jt.def.a), sb = slotOf(jt.def.b);
    active.push_back(static_cast<int>(i));
    ends.emplace_back(sa, sb);
  }
  // A spanning forest over the bodies (what cannot move counting as one): the joints taken strongest first (most
  // rows: a weld, then a hinge or a slider, a ball, a rod), then by id; one whose ends the forest already connects
  // closes a loop. The forest is solved directly; the loops one by one around it. (With every joint of a component
  // that holds a loop solved one by one, a heavy body welded on a long lever to a body held by a ring of joints
  // kept only part of gravity's pull out of its velocity each substep.)
  auto rowCount = [&](int i) {
    switch (ctx.joints[static_cast<size_t>(i)].def.type) {
      case JointType::Fixed: return 6;
      case JointType::Hinge:
      case JointType::Slider: return 5;
      case JointType::Ball: return 3;
      default: return 1;
    }
  };
  std::vector<size_t> strongest(active.size());
  for (size_t k = 0; k < strongest.size(); ++k) strongest[k] = k;
  std::stable_sort(strongest.begin(), strongest.end(),
                   [&](size_t p, size_t q) { return rowCount(active[p]) > rowCount(active[q]); });
  DisjointSets forest;
  forest.reset(s.sides.size());
  for (size_t k = 1; k < s.sides.size(); ++k)
    if (!(s.sides[k].invMass > 0)) forest.unite(static_cast<int>(k), 0);  // what cannot move is one
  std::vector<char> closesLoop(active.size(), 0);
  for (size_t k : strongest) closesLoop[k] = !forest.unite(ends[k].first, ends[k].second);
  for (size_t k = 0; k < active.size(); ++k) {
    const int i = active[k];
    const Joint& jt = ctx.joints[static_cast<size_t>(i)];
    const int sa = ends[k].first, sb = ends[k].second;
    if (closesLoop[k]) {
      s.loops.push_back(i);
      s.loopEnds.emplace_back(sa, sb);
      continue;
    }
    const int kk = static_cast<int>(s.joints.size());
    s.joints.push_back(i);
    s.ends.emplace_back(sa, sb);
    const bool axial = jt.def.type == JointType::Hinge || jt.def.type == JointType::Slider;
    if ((axial && jt.def.limited) || (jt.def.type == JointType::Distance && jt.minLength != jt.maxLength))
      s.conditional = true;
    if (s.sides[static_cast<size_t>(sa)].invMass > 0) s.onBody[static_cast<size_t>(sa)].emplace_back(kk, -1);
    if (s.sides[static_cast<size_t>(sb)].invMass > 0) s.onBody[static_cast<size_t>(sb)].emplace_back(kk, +1);
  }
  // Minimum degree order over the joint graph (ties: the lower id), with the fill it makes.
  const size_t n = s.joints.size();
  std::vector<std::vector<int>> adj(n);
  auto link = [&](int p, int q) {
    auto& l = adj[static_cast<size_t>(p)];
    const auto it = std::lower_bound(l.begin(), l.end(), q);
    if (it == l.end() || *it != q) l.insert(it, q);
  };
  for (const auto& list : s.onBody)
    for (size_t i = 0; i < list.size(); ++i)
      for (size_t j = 0; j < list.size(); ++j)
        if (list[i].first != list[j].first) link(list[i].first, list[j].first);
  std::set<std::pair<size_t, int>> queue;
  for (size_t k = 0; k < n; ++k) queue.emplace(adj[k].size(), static_cast<int>(k));
  s.order.clear();
  s.place.assign(n, -1);
  std::vector<std::vector<int>> laterJoints;
  while (!queue.empty()) {
    const int p = queue.begin()->second;
    queue.erase(queue.begin());
    s.place[static_cast<size_t>(p)] = static_cast<int>(s.order.size());
    s.order.push_back(p);
    const std::vector<int> nb = adj[static_cast<size_t>(p)];
    for (int q : nb) {
      queue.erase({adj[static_cast<size_t>(q)].size(), q});
      auto& l = adj[static_cast<size_t>(q)];
      l.erase(std::lower_bound(l.begin(), l.end(), p));
      for (int r : nb)
        if (r != q) link(q, r);
      queue.emplace(l.size(), q);
    }
    laterJoints.push_back(nb);
  }
  s.later.assign(n, {});
  for (size_t p = 0; p < n; ++p) {
    for (int q : laterJoints[p]) s.later[p].push_back(s.place[static_cast<size_t>(q)]);
    std::sort(s.later[p].begin(), s.later[p].end());
  }
  s.rows.resize(n);
  s.diag.resize(n);
  s.inv.resize(n);
  s.scale.resize(n);
  s.off.resize(n);
  for (size_t p = 0; p < n; ++p) s.off[p].resize(s.later[p].size());
  s.x.resize(n);
  return s;
}

// The velocities (and, pre, the predicted poses) of the bodies, then each joint's rows.
double lookAtJoints(const StepContext& ctx, JointSystem& s, double h, bool pre) {
  for (size_t k = 1; k < s.sides.size(); ++k) s.sides[k].refresh(ctx, h, pre);
  const double reach = ctx.settings.maxCorrectionSpeed * h;
  double worst = 0;
  for (size_t k = 0; k < s.joints.size(); ++k) {
    const Joint& jt = ctx.joints[static_cast<size_t>(s.joints[k])];
    s.rows[k] = jointRows(jt, s.sides[static_cast<size_t>(s.ends[k].first)],
                          s.sides[static_cast<size_t>(s.ends[k].second)], h, pre, reach);
    worst = std::max(worst, s.rows[k].worst);
  }
  for (size_t k = 0; k < s.loops.size(); ++k) {
    const Joint& jt = ctx.joints[static_cast<size_t>(s.loops[k])];
    worst = std::max(worst, jointRows(jt, s.sides[static_cast<size_t>(s.loopEnds[k].first)],
                                      s.sides[static_cast<size_t>(s.loopEnds[k].second)], h, pre, reach)
                                .worst);
  }
  return worst;
}

// A hinge's or slider's motor: one row along the axis towards its speed, its
// impulse over the substep clamped to maxForce h.
void solveMotor(StepContext& ctx, Joint& jt, Side& a, Side& b, double h) {
  const JointDef& d = jt.def;
  a.refresh(ctx, h, true);
  b.refresh(ctx, h, true);
  const glm::dvec3 rb = b.dir(jt.rB, false);
  // A slider's A side acts at the point of its axis where B's anchor is (see jointRows).
  const glm::dvec3 ra = d.a < 0 ? glm::dvec3(0)
                                : a.dir(jt.rA, false) + (d.type == JointType::Slider
                                                             ? b.point(jt.rB, false) - a.point(jt.rA, false)
                                                             : glm::dvec3(0));
  const Mobility m = mobility(a, b, ra, rb);
  const bool hinge = d.type == JointType::Hinge;
  const glm::dvec3 axis = glm::normalize(a.dir(jt.axisA, true));
  const Row row = hinge ? Row{glm::dvec3(0), axis} : Row{axis, glm::dvec3(0)};
  const glm::dvec3 u = (b.v + glm::cross(b.w, rb)) - (a.v + glm::cross(a.w, ra));
  const double rate = hinge ? glm::dot(axis, b.w - a.w) : glm::dot(axis, u);
  // The effect of a unit impulse along the row on the rate.
  const glm::dvec3 ul = m.K * row.lin + m.C * row.ang, ua = glm::transpose(m.C) * row.lin + m.A * row.ang;
  const double mass = glm::dot(row.lin, ul) + glm::dot(row.ang, ua);
  if (!(mass > 0)) return;
  const double l = -(rate - d.motor.speed) / mass;
  const double cap = d.motor.maxForce * h;
  const double total = std::clamp(jt.motorImpulse + l, -cap, cap);
  const double lambda = total - jt.motorImpulse;
  jt.motorImpulse = total;
  if (lambda != 0) applyRows(ctx, jt, ra, rb, a, b, &row, 1, &lambda);
}

// One joint alone, a Newton step with the velocities of the moment; pre: its
// motor, its limit row, then its other rows; post: its rows, then its limit row.
void solveAlone(StepContext& ctx, Joint& jt, Side& a, Side& b, double h, bool pre) {
  if (pre && jt.def.motor.enabled && (jt.def.type == JointType::Hinge || jt.def.type == JointType::Slider))
    solveMotor(ctx, jt, a, b, h);
  for (int part : {pre ? kLimitRow : kMainRows, pre ? kMainRows : kLimitRow}) {
    a.refresh(ctx, h, pre);
    b.refresh(ctx, h, pre);
    const JointRows jr = jointRows(jt, a, b, h, pre, ctx.settings.maxCorrectionSpeed * h, part);
    if (jr.n == 0) continue;
    double rhs[6], lambda[6];
    for (int r = 0; r < jr.n; ++r) rhs[r] = pre ? -jr.err[r] / h : -jr.err[r];
    solveRows(mobility(a, b, jr.ra, jr.rb), jr.rows, jr.n, rhs, lambda);
    applyRows(ctx, jt, jr.ra, jr.rb, a, b, jr.rows, jr.n, lambda);
  }
}

// One Gauss-Seidel sweep over the joints of components with loops (a second
// joint between two bodies, a ring, a second anchor to what cannot move),
// where a direct solve would split the load between redundant rows at random:
// each joint alone in id order.
void solveLoops(StepContext& ctx, JointSystem& s, double h, bool pre) {
  for (size_t k = 0; k < s.loops.size(); ++k)
    solveAlone(ctx, ctx.joints[static_cast<size_t>(s.loops[k])], s.sides[static_cast<size_t>(s.loopEnds[k].first)],
               s.sides[static_cast<size_t>(s.loopEnds[k].second)], h, pre);
}

// Solves every joint's rows at once and applies the impulses.
void solveSystem(StepContext& ctx, JointSystem& s, double h, bool pre) {
  const size_t n = s.joints.size();
  auto size = [&](int pos) { return s.rows[static_cast<size_t>(s.order[static_cast<size_t>(pos)])].n; };
  for (size_t p = 0; p < n; ++p) {
    s.diag[p] = {};
    for (Block& b : s.off[p]) b = {};
  }
  // A: per body, the effect of each of its joints' rows on each of its joints' rows. A row k of a joint's end
  // on the body (sign +1 on B, -1 on A) moves the body's (v, omega) along sign (lin_k, r x lin_k + ang_k) =: g_k;
  // the block entry of rows a of p and b of q is g_a . W g_b, W = diag(1/m, I^-1).
  std::vector<RowEnd>& ends = s.endScratch;
  for (size_t slot = 1; slot < s.onBody.size(); ++slot) {
    const auto& list = s.onBody[slot];
    if (list.empty()) continue;
    const Side& body = s.sides[slot];
    ends.resize(list.size());
    for (size_t i = 0; i < list.size(); ++i) {
      const JointRows& jr = s.rows[static_cast<size_t>(list[i].first)];
      const glm::dvec3 r = list[i].second > 0 ? jr.rb : jr.ra;
      const double sign = list[i].second;
      for (int k = 0; k < jr.n; ++k) {
        const glm::dvec3 lin = sign * jr.rows[k].lin;
        const glm::dvec3 ang = sign * (glm::cross(r, jr.rows[k].lin) + jr.rows[k].ang);
        const glm::dvec3 wl = body.invMass * lin, wa = body.invInertia * ang;
        double* g = ends[i].g[k];
        double* wg = ends[i].wg[k];
        g[0] = lin.x, g[1] = lin.y, g[2] = lin.z, g[3] = ang.x, g[4] = ang.y, g[5] = ang.z;
        wg[0] = wl.x, wg[1] = wl.y, wg[2] = wl.z, wg[3] = wa.x, wg[4] = wa.y, wg[5] = wa.z;
      }
    }
    for (size_t i = 0; i < list.size(); ++i) {
      const int p = s.place[static_cast<size_t>(list[i].first)];
      const int np = s.rows[static_cast<size_t>(list[i].first)].n;
      for (size_t j = 0; j < list.size(); ++j) {
        const int q = s.place[static_cast<size_t>(list[j].first)];
        if (q < p) continue;  // the block (p, q) with p first in the order
        const int nq = s.rows[static_cast<size_t>(list[j].first)].n;
        Block* blk = &s.diag[static_cast<size_t>(p)];
        if (q != p) {
          const auto& l = s.later[static_cast<size_t>(p)];
          blk = &s.off[static_cast<size_t>(p)][static_cast<size_t>(std::lower_bound(l.begin(), l.end(), q) - l.begin())];
        }
        const RowEnd& ei = ends[i];
        const RowEnd& ej = ends[j];
        for (int a = 0; a < np; ++a)
          for (int c = 0; c < nq; ++c) {
            const double* x = ei.g[a];
            const double* y = ej.wg[c];
            blk->m[a][c] += x[0] * y[0] + x[1] * y[1] + x[2] * y[2] + x[3] * y[3] + x[4] * y[4] + x[5] * y[5];
          }
      }
    }
  }
  // Factor: eliminate each position into the later ones it is coupled to; the
  // off-diagonal blocks become D_p^-1 A_pq.
  for (size_t p = 0; p < n; ++p)
    for (int k = 0; k < size(static_cast<int>(p)); ++k) s.scale[p][static_cast<size_t>(k)] = s.diag[p].m[k][k];
  for (size_t p = 0; p < n; ++p) {
    const int np = size(static_cast<int>(p));
    const auto& later = s.later[p];
    std::vector<Block>& off = s.off[p];
    std::vector<Block>& scaled = s.scratch;
    scaled.resize(off.size());
    withSize(np, [&](auto NP) {
      constexpr int kNp = NP();
      pseudoInverseN<kNp>(s.diag[p], s.scale[p].data(), s.inv[p]);
      for (size_t e = 0; e < later.size(); ++e) leftMultiply<kNp>(s.inv[p], off[e], size(later[e]), scaled[e]);
      for (size_t e1 = 0; e1 < later.size(); ++e1) {
        const int q = later[e1], nq = size(q);
        for (size_t e2 = e1; e2 < later.size(); ++e2) {
          const int r = later[e2], nr = size(r);
          Block* target = &s.diag[static_cast<size_t>(q)];
          if (r != q) {
            const auto& l = s.later[static_cast<size_t>(q)];
            target = &s.off[static_cast<size_t>(q)]
                           [static_cast<size_t>(std::lower_bound(l.begin(), l.end(), r) - l.begin())];
          }
          subtractProduct<kNp>(off[e1], scaled[e2], nq, nr, *target);
        }
      }
    });
    off.swap(scaled);
  }
  // Solve: forward, the diagonal, back.
  for (size_t p = 0; p < n; ++p) {
    const JointRows& jr = s.rows[static_cast<size_t>(s.order[p])];
    for (int k = 0; k < jr.n; ++k) s.x[p][static_cast<size_t>(k)] = pre ? -jr.err[k] / h : -jr.err[k];
  }
  std::array<double, 6> y{};
  for (size_t p = 0; p < n; ++p) {
    const int np = size(static_cast<int>(p));
    for (size_t e = 0; e < s.later[p].size(); ++e) {
      const int q = s.later[p][e], nq = size(q);
      for (int c = 0; c < nq; ++c) {
        double v = 0;
        for (int k = 0; k < np; ++k) v += s.off[p][e].m[k][c] * s.x[p][static_cast<size_t>(k)];
        s.x[static_cast<size_t>(q)][static_cast<size_t>(c)] -= v;
      }
    }
  }
  for (size_t p = 0; p < n; ++p) {
    const int np = size(static_cast<int>(p));
    for (int i = 0; i < np; ++i) {
      double v = 0;
      for (int k = 0; k < np; ++k) v += s.inv[p].m[i][k] * s.x[p][static_cast<size_t>(k)];
      y[static_cast<size_t>(i)] = v;
    }
    for (int i = 0; i < np; ++i) s.x[p][static_cast<size_t>(i)] = y[static_cast<size_t>(i)];
  }
  for (size_t p = n; p-- > 0;) {
    const int np = size(static_cast<int>(p));
    for (size_t e = 0; e < s.later[p].size(); ++e) {
      const int q = s.later[p][e], nq = size(q);
      for (int i = 0; i < np; ++i) {
        double v = 0;
        for (int c = 0; c < nq; ++c) v += s.off[p][e].m[i][c] * s.x[static_cast<size_t>(q)][static_cast<size_t>(c)];
        s.x[p][static_cast<size_t>(i)] -= v;
      }
    }
  }
  // Apply, in id order.
  for (size_t k = 0; k < n; ++k) {
    const JointRows& jr = s.rows[k];
    if (jr.n == 0) continue;
    Joint& jt = ctx.joints[static_cast<size_t>(s.joints[k])];
    applyRows(ctx, jt, jr.ra, jr.rb, s.sides[static_cast<size_t>(s.ends[k].first)],
              s.sides[static_cast<size_t>(s.ends[k].second)], jr.rows, jr.n,
              s.x[static_cast<size_t>(s.place[k])].data());
  }
}

// A pass (after a look at the joints): the forest at once, then the loops one
// by one (a loop joint takes only what the forest leaves to it).
void solvePass(StepContext& ctx, JointSystem& s, double h, bool pre) {
  solveSystem(ctx, s, h, pre);
  solveLoops(ctx, s, h, pre);
}


// Before a call's sweeps: what each joint applies in the call is booked from zero.
void startCall(StepContext& ctx) {
  for (Joint& jt : ctx.joints) {
    jt.callLinear = jt.callTurnA = jt.callTurnB = glm::dvec3(0);
    jt.callStart = jt.stepImpulse;
  }
}

// The books of the joints of s (in the order of s.joints, then s.loops), and a call undone: the joined dynamic
// bodies' velocities (`saved`, in the order of s.sides) and the joints' books put back.
void saveBooks(const StepContext& ctx, const JointSystem& s, std::vector<Joint>& books) {
  books.clear();
  for (int j : s.joints) books.push_back(ctx.joints[static_cast<size_t>(j)]);
  for (int j : s.loops) books.push_back(ctx.joints[static_cast<size_t>(j)]);
}
void restoreCall(StepContext& ctx, const JointSystem& s, const std::vector<BodyState>& saved,
                 const std::vector<Joint>& books) {
  size_t n = 0;
  for (size_t k = 1; k < s.sides.size(); ++k) {
    const int i = s.sides[k].index;
    if (i < 0 || !ctx.body(i).dynamic()) continue;
    ctx.body(i).v = saved[n].v;
    ctx.body(i).w = saved[n].w;
    ++n;
  }
  size_t m = 0;
  for (int j : s.joints) ctx.joints[static_cast<size_t>(j)] = books[m++];
  for (int j : s.loops) ctx.joints[static_cast<size_t>(j)] = books[m++];
}

// After a call's sweeps: a joint whose impulse over the step now passes its
// breakImpulse breaks, at the call's start: it passes on nothing of the call
// (a weld never passes on more than it can bear), and the other joints'
// impulses, found with it holding, go too (a hinge's share of a load the weld
// carried would fling a light body; a share of the weld's own impulse, without
// the others' that balanced it, as well). The call is undone (the joined
// bodies' velocities `saved` and the joints' books at its start) for the caller
// to solve again without it. Returns whether any joint broke.
bool yieldJoints(StepContext& ctx, const JointSystem& s, double h, const std::vector<BodyState>& saved,
                 const std::vector<Joint>& books) {
  std::vector<std::pair<int, double>>& breaking = ctx.jointBreaking;
  breaking.clear();
  for (size_t i = 0; i < ctx.joints.size(); ++i) {
    const Joint& jt = ctx.joints[i];
    if (jt.removed || jt.broken) continue;
    const double demand = glm::length(jt.stepImpulse);
    if (demand > jt.def.breakImpulse) breaking.emplace_back(static_cast<int>(i), demand);
  }
  if (breaking.empty()) return false;
  restoreCall(ctx, s, saved, books);
  for (const auto& [joint, demand] : breaking) {
    ctx.joints[static_cast<size_t>(joint)].broken = true;
    ctx.jointBreaks.push_back({ctx.time + h, joint, demand});
  }
  ctx.jointExcludedDirty = true;
  return true;
}

// The kinetic energy that closing the violations the joints of s start the substep with (each row's, at most
// reach = maxCorrectionSpeed x h of it) within the substep takes: per row, (violation / h)^2 / 2 against the row's
// effective mass, twice over (the rows' coupling, and the turn a fast spin makes a holding joint's anchors drift
// through within the substep). A joint that holds has no budget: whatever its pre-stabilisation adds beyond this
// is the solver's, not the scene's.
double closingEnergy(StepContext& ctx, JointSystem& s, double h) {
  const double reach = ctx.settings.maxCorrectionSpeed * h;
  double energy = 0;
  auto add = [&](const Joint& jt, Side a, Side b) {
    a.refresh(ctx, 0, true);  // predicted = now
    b.refresh(ctx, 0, true);
    const JointRows jr = jointRows(jt, a, b, h, true, reach);
    const Mobility m = mobility(a, b, jr.ra, jr.rb);
    for (int k = 0; k < jr.n; ++k) {
      const Row& row = jr.rows[k];
      const double inverse = glm::dot(row.lin, m.K * row.lin + m.C * row.ang) +
                             glm::dot(row.ang, glm::transpose(m.C) * row.lin + m.A * row.ang);
      if (!(inverse > 0)) continue;
      const double speed = jr.err[k] / h;
      energy += speed * speed / inverse;  // 2 x (speed^2 / 2 / inverse)
    }
  };
  for (size_t k = 0; k < s.joints.size(); ++k)
    add(ctx.joints[static_cast<size_t>(s.joints[k])], s.sides[static_cast<size_t>(s.ends[k].first)],
        s.sides[static_cast<size_t>(s.ends[k].second)]);
  for (size_t k = 0; k < s.loops.size(); ++k)
    add(ctx.joints[static_cast<size_t>(s.loops[k])], s.sides[static_cast<size_t>(s.loopEnds[k].first)],
        s.sides[static_cast<size_t>(s.loopEnds[k].second)]);
  return energy;
}

// The kinetic energy of the dynamic bodies the joints of s join.
double joinedEnergy(const StepContext& ctx, const JointSystem& s) {
  double energy = 0;
  for (size_t k = 1; k < s.sides.size(); ++k) {
    const int i = s.sides[k].index;
    if (i >= 0 && ctx.body(i).dynamic()) energy += ctx.body(i).kineticEnergy();
  }
  return energy;
}

// How far from a kinematic end the joints can hold a point of a joined body: every active joint's levers and
// range laid end to end (an unlimited slider: its gap now), and the widest joined body. From the joints, not from
// where the bodies are: a body that contradicting joints tore away must not raise the ceiling below by being far.
double jointReach(const StepContext& ctx, const JointSystem& s) {
  double reach = 0, widest = 0;
  auto add = [&](int j) {
    const Joint& jt = ctx.joints[static_cast<size_t>(j)];
    const JointDef& d = jt.def;
    if (d.a >= 0) reach += glm::length(jt.rA);
    reach += glm::length(jt.rB);
    if (d.type == JointType::Distance) reach += std::max(jt.length, std::isfinite(jt.maxLength) ? jt.maxLength : 0.0);
    if (d.type == JointType::Slider) {
      if (d.limited) reach += std::max(std::abs(d.lower), std::abs(d.upper));
      else {
        const auto at = [&](int i, const glm::dvec3& r) { return i < 0 ? r : ctx.body(i).x + ctx.body(i).q * r; };
        reach += glm::length(at(d.b, jt.rB) - at(d.a, jt.rA));
      }
    }
  };
  for (int j : s.joints) add(j);
  for (int j : s.loops) add(j);
  for (size_t k = 1; k < s.sides.size(); ++k)
    if (s.sides[k].index >= 0 && ctx.body(s.sides[k].index).dynamic())
      widest = std::max(widest, ctx.body(s.sides[k].index).shape->boundingRadius);
  return reach + 2 * widest;
}

// Takes away the relative velocities the joints of s forbid. The velocity rows are linear: one direct solve
// removes them; more passes only where limit or range rows may join or leave. Removing forbidden velocity never
// raises the joined bodies' energy above what they had or, where kinematic ends drive them, above every joined
// body moving at the fastest speed a kinematic end's points have (a ceiling, not an allowance per call: calls
// that each add a little would add up without end); a direct solve that does (a system the factorisation cannot condition: a light
// body carrying a heavy one on a long lever through two joints) is undone, and the joints are taken one at a
// time instead (Gauss-Seidel: each joint's own small solve between its two bodies), which converges slower but
// never gains.
void removeForbiddenVelocity(StepContext& ctx, JointSystem& s, double h) {
  std::vector<BodyState>& saved = ctx.jointVelocitySaved;
  saved.clear();
  double before = 0, mass = 0, drive = 0;
  const double reach = jointReach(ctx, s);
  for (size_t k = 1; k < s.sides.size(); ++k) {
    const int i = s.sides[k].index;
    if (i < 0 || !ctx.body(i).movable()) continue;
    const RigidBody& b = ctx.body(i);
    if (!b.dynamic()) {
      drive = std::max(drive, glm::length(b.v) + glm::length(b.w) * reach);
      continue;
    }
    saved.push_back({b.x, b.q, b.v, b.w});
    before += b.kineticEnergy();
    mass += b.mass + b.principal.moments.z;
  }
  std::vector<Joint>& books = ctx.jointVelocityBooks;
  saveBooks(ctx, s, books);
  auto passes = [&](auto&& pass) {
    for (int p = 0; p < ctx.settings.jointPostIterations; ++p) {
      if (!(lookAtJoints(ctx, s, h, false) > 1e-3 * ctx.settings.jointTolerance)) break;
      if (!pass()) break;
    }
  };
  passes([&] {
    solvePass(ctx, s, h, false);
    return s.conditional || !s.loops.empty();
  });
  const double ceiling = std::max(before, 0.5 * mass * drive * drive) + 1e-9 * before;
  if (joinedEnergy(ctx, s) <= ceiling) return;
  restoreCall(ctx, s, saved, books);
  ++ctx.stats.jointFallbacks;
  passes([&] {
    for (size_t k = 0; k < s.joints.size(); ++k)
      solveAlone(ctx, ctx.joints[static_cast<size_t>(s.joints[k])], s.sides[static_cast<size_t>(s.ends[k].first)],
                 s.sides[static_cast<size_t>(s.ends[k].second)], h, false);
    solveLoops(ctx, s, h, false);
    return true;
  });
  // Each joint's own solve is a projection in the bodies' mass metric, which never gains when every end can move;
  // a kinematic end moves the target, and joints that contradict one it drives (a body it whirls, pinned to the
  // world) can pump without end. Such a call is undone: the joints yield for this substep (the projection still
  // pulls their anchors together, at most at the correction speed).
  if (joinedEnergy(ctx, s) <= ceiling) return;
  restoreCall(ctx, s, saved, books);
}

void wakeJoined(StepContext& ctx) {
  for (const Joint& jt : ctx.joints) {
    if (jt.removed || jt.broken || jt.def.a < 0) continue;
    const RigidBody& A = ctx.body(jt.def.a);
    const RigidBody& B = ctx.body(jt.def.b);
    if (A.asleep && B.movable()) ctx.wake(jt.def.a);
    if (B.asleep && A.movable()) ctx.wake(jt.def.b);
  }
}

}  // namespace

void preStabilize(StepContext& ctx, double h, int sweeps, bool first) {
  if (ctx.joints.empty()) return;
  if (first) {
    wakeJoined(ctx);
    for (Joint& jt : ctx.joints) jt.motorImpulse = 0;  // the motor's budget is per substep
  } else {
    // Again after the contacts: only needed when they touched a joined body.
    std::vector<char> touched(ctx.bodies.size(), 0);
    for (size_t pi = 0; pi < ctx.pairs.size() && pi < ctx.groups.size(); ++pi)
      if (!ctx.groups[pi].empty())
        touched[static_cast<size_t>(ctx.pairs[pi].a)] = touched[static_cast<size_t>(ctx.pairs[pi].b)] = 1;
    bool any = false;
    for (const Joint& jt : ctx.joints)
      any = any || (active(ctx, jt) && ((jt.def.a >= 0 && touched[static_cast<size_t>(jt.def.a)]) ||
                                        touched[static_cast<size_t>(jt.def.b)]));
    if (!any) return;
  }
  // Again without the joints that break in it (yieldJoints).
  for (bool again = true; again;) {
    startCall(ctx);
    JointSystem& s = buildSystem(ctx);
    // The joined bodies' velocities, kinetic energy and the joints' books before the sweeps, and what the sweeps may
    // add to that energy: closing the violations the joints start the substep with (at most maxCorrectionSpeed of
    // each, as speed and as turn) and the motors' work.
    const double c = ctx.settings.maxCorrectionSpeed;
    std::vector<BodyState>& saved = ctx.jointSaved;
    saved.clear();
    double before = 0, fastest = 0, moving = 0;
    for (size_t k = 1; k < s.sides.size(); ++k) {
      const int i = s.sides[k].index;
      if (i < 0 || !ctx.body(i).dynamic()) continue;
      const RigidBody& b = ctx.body(i);
      saved.push_back({b.x, b.q, b.v, b.w});
      before += b.kineticEnergy();
      moving += 0.5 * (b.mass + b.principal.moments.z) * c * c;  // every joined body at maxCorrectionSpeed
      fastest = std::max(fastest, glm::length(b.v) + glm::length(b.w) * (b.shape->boundingRadius + glm::length(b.localCom)));
    }
    double budget = std::min(closingEnergy(ctx, s, h), moving);
    for (int j : s.joints) {
      const JointDef& d = ctx.joints[static_cast<size_t>(j)].def;
      if (d.motor.enabled) budget += d.motor.maxForce * h * (std::abs(d.motor.speed) + fastest + c);
    }
    std::vector<Joint>& books = ctx.jointBooks;
    saveBooks(ctx, s, books);
    for (int sweep = 0; sweep < sweeps; ++sweep) {
      for (size_t k = 0; k < s.joints.size(); ++k) {
        Joint& jt = ctx.joints[static_cast<size_t>(s.joints[k])];
        if (jt.def.motor.enabled && (jt.def.type == JointType::Hinge || jt.def.type == JointType::Slider))
          solveMotor(ctx, jt, s.sides[static_cast<size_t>(s.ends[k].first)], s.sides[static_cast<size_t>(s.ends[k].second)],
                     h);
      }
      ++ctx.stats.jointSweeps;
      if (lookAtJoints(ctx, s, h, true) < ctx.settings.jointTolerance) break;
      solvePass(ctx, s, h, true);
    }
    // Sweeps that handed the joined bodies more energy than that (joints that contradict each other, a loop solved
    // joint by joint past its fixed point, a lever the direct solve cannot condition) are undone: the joints then
    // only take away the relative velocities they forbid, as post-stabilisation does, which never adds energy.
    const double after = joinedEnergy(ctx, s);
    if (!(after <= before + budget + 1e-9 * before)) {
      restoreCall(ctx, s, saved, books);
      ++ctx.stats.jointFallbacks;
      removeForbiddenVelocity(ctx, s, h);
    }
    again = yieldJoints(ctx, s, h, saved, books);
  }
}

void postStabilize(StepContext& ctx, double h) {
  if (ctx.joints.empty()) return;
  for (bool again = true; again;) {
    startCall(ctx);
    JointSystem& s = buildSystem(ctx);
    removeForbiddenVelocity(ctx, s, h);
    again = yieldJoints(ctx, s, h, ctx.jointVelocitySaved, ctx.jointVelocityBooks);
  }
  for (Joint& jt : ctx.joints) {
    if (jt.removed || jt.broken || jt.def.type != JointType::Hinge) continue;
    const Side a = sideAt(ctx, jt.def.a), b = sideAt(ctx, jt.def.b);
    jt.angle += wrapAngle(hingeAngle(jt, a, b, false) - wrapAngle(jt.angle));
  }
}

void projectJoints(StepContext& ctx, std::vector<glm::dvec3>& moved, double reach) {
  for (Joint& jt : ctx.joints) {
    if (!active(ctx, jt)) continue;
    const JointDef& d = jt.def;
    const double wa = d.a >= 0 && ctx.body(d.a).dynamic() ? ctx.body(d.a).invMass : 0;
    const double wb = ctx.body(d.b).dynamic() ? ctx.body(d.b).invMass : 0;
    if (wa + wb <= 0) continue;
    // Orientations stay put in the projection (translations only).
    auto dir = [&](int i, const glm::dvec3& local) { return i < 0 ? local : ctx.body(i).q * local; };
    auto point = [&](int i, const glm::dvec3& local) { return i < 0 ? local : ctx.body(i).x + ctx.body(i).q * local; };
    const glm::dvec3 shiftA = d.a >= 0 ? moved[static_cast<size_t>(d.a)] : glm::dvec3(0);
    const glm::dvec3 shiftB = moved[static_cast<size_t>(d.b)];
    // The part of the anchor gap the joint forbids, with the projection's translations so far (`shifted`) or
    // without them.
    auto forbidden = [&](bool shifted) {
      glm::dvec3 e = point(d.b, jt.rB) - point(d.a, jt.rA);
      if (!shifted) e -= shiftB - shiftA;
      if (d.type == JointType::Slider) {
        const glm::dvec3 axis = glm::normalize(dir(d.a, jt.axisA));
        e -= glm::dot(e, axis) * axis;
      } else if (d.type == JointType::Distance) {
        const double len = glm::length(e);
        if (len < 1e-9) return glm::dvec3(0);
        const double target = std::clamp(len, jt.minLength, jt.maxLength);
        e *= (len - target) / len;
      }
      return e;
    };
    glm::dvec3 e = forbidden(true);
    if (d.type == JointType::Distance && e == glm::dvec3(0)) continue;
    // A joint violated by more than the reach before the projection is being closed by pre-stabilisation at
    // maxCorrectionSpeed: here only what the projection itself opened is closed.
    const glm::dvec3 before = forbidden(false);
    if (glm::dot(before, before) > reach * reach) e -= before;
    if (wa > 0) {
      const glm::dvec3 da = withinReach(moved[static_cast<size_t>(d.a)], e * (wa / (wa + wb)), reach);
      ctx.body(d.a).x += da;
      moved[static_cast<size_t>(d.a)] += da;
    }
    if (wb > 0) {
      const glm::dvec3 db = withinReach(moved[static_cast<size_t>(d.b)], -e * (wb / (wa + wb)), reach);
      ctx.body(d.b).x += db;
      moved[static_cast<size_t>(d.b)] += db;
    }
  }
}

void findAnchored(StepContext& ctx) {
  ctx.anchored.clear();
  if (ctx.joints.empty()) return;
  const size_t n = ctx.bodies.size();
  ctx.anchored.assign(n, 0);
  // Flood from the welds to the world or to bodies that cannot move.
  std::vector<std::vector<int>> welded(n);
  std::vector<int> stack;
  for (const Joint& jt : ctx.joints) {
    if (jt.removed || jt.broken || jt.def.type != JointType::Fixed) continue;
    const int a = jt.def.a, b = jt.def.b;
    const bool fixedA = a < 0 || ctx.body(a).isStatic, fixedB = ctx.body(b).isStatic;
    if (fixedA && !fixedB) stack.push_back(b);
    if (fixedB && !fixedA) stack.push_back(a);
    if (!fixedA && !fixedB) {
      welded[static_cast<size_t>(a)].push_back(b);
      welded[static_cast<size_t>(b)].push_back(a);
    }
  }
  while (!stack.empty()) {
    const int i = stack.back();
    stack.pop_back();
    if (ctx.anchored[static_cast<size_t>(i)]) continue;
    ctx.anchored[static_cast<size_t>(i)] = 1;
    for (int k : welded[static_cast<size_t>(i)]) stack.push_back(k);
  }
}


void refreshJointExclusions(StepContext& ctx) {
  if (!ctx.jointExcludedDirty) return;
  ctx.jointExcluded.clear();
  for (const Joint& jt : ctx.joints) {
    if (jt.removed || jt.broken || jt.def.collideConnected || jt.def.a < 0) continue;
    const int lo = std::min(jt.def.a, jt.def.b), hi = std::max(jt.def.a, jt.def.b);
    ctx.jointExcluded.push_back(static_cast<uint64_t>(lo) << 32 | static_cast<uint64_t>(hi));
  }
  std::sort(ctx.jointExcluded.begin(), ctx.jointExcluded.end());
  ctx.jointExcludedDirty = false;
}

bool mayCollide(StepContext& ctx, int a, int b) {
  const RigidBody& A = ctx.body(a);
  const RigidBody& B = ctx.body(b);
  if (A.removed || B.removed) return false;
  if (!(ctx.groupMasks[static_cast<size_t>(A.group)] >> B.group & 1ull)) return false;
  refreshJointExclusions(ctx);
  if (!ctx.jointExcluded.empty()) {
    const uint64_t key = static_cast<uint64_t>(std::min(a, b)) << 32 | static_cast<uint64_t>(std::max(a, b));
    if (std::binary_search(ctx.jointExcluded.begin(), ctx.jointExcluded.end(), key)) return false;
  }
  if (ctx.filter && !ctx.filter(std::min(a, b), std::max(a, b))) return false;
  return true;
}

bool anyJointActive(const StepContext& ctx) {
  return std::any_of(ctx.joints.begin(), ctx.joints.end(), [&](const Joint& jt) { return active(ctx, jt); });
}

}  // namespace crumple::detail
