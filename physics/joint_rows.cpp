// A joint's rows: what it forbids, the levers and masses they act through, and the impulses that apply them
// (physics/joint_solver.h; the guarantees are joint_step.cpp's).
#include <algorithm>
#include <cmath>

#include <crumple/physics/joint_solver.h>

namespace crumple::detail::joints {

// A side now: the pose, the inverse masses, the velocities (predicted = now).
Side sideAt(const StepContext& ctx, int i) {
  Side s;
  setSide(s, ctx, i);
  return s;
}

void setSide(Side& s, const StepContext& ctx, int i) {
  if (i < 0) {
    s = Side{};
    return;
  }
  s.index = i;
  const RigidBody& b = ctx.body(i);
  s.pose = {b.x, b.q};
  s.predicted = s.pose;
  s.R = s.Rp = ctx.invInertiaNow ? ctx.rotation[static_cast<size_t>(i)] : b.rotation();
  s.invMass = 0;
  s.invInertia = glm::dmat3(0);
  s.v = s.w = glm::dvec3(0);
  if (!b.movable()) return;
  if (b.dynamic()) {
    s.invMass = b.invMass;
    // At the pose now: the substep's until the position update turns the bodies, then made again
    // (post-stabilisation runs after it).
    s.invInertia = ctx.invInertiaNow ? ctx.invInertia[static_cast<size_t>(i)] : b.invInertiaWorld();
  }
  s.v = b.v;
  s.w = b.w;
}

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
  if (!ma && !mb) return false;
  // Between two bodies the welds hold to the world (findAnchored), or one and the world, only the welds act: any
  // other joint there joins two parts of what cannot move, and one that starts violated could only fight them.
  if (jt.def.type == JointType::Fixed || ctx.anchored.empty()) return true;
  const auto held = [&](int i) { return i < 0 || !ctx.body(i).dynamic() || ctx.anchored[static_cast<size_t>(i)]; };
  return !(held(jt.def.a) && held(jt.def.b));
}

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
                    int parts) {
  JointRows out;
  fillJointRows(out, jt, a, b, h, pre, reach, parts);
  return out;
}

void fillJointRows(JointRows& out, const Joint& jt, const Side& a, const Side& b, double h, bool pre, double reach,
                   int parts) {
  const JointDef& d = jt.def;
  out.n = 0;
  out.worst = 0;
  out.limit = false;
  out.beyond = 0;
  // What a row's violation now exceeds reach by (0 within it).
  auto excess = [reach, &out](double now) {
    const double over = now > reach ? now - reach : (now < -reach ? now + reach : 0.0);
    out.beyond = std::max(out.beyond, std::abs(over));
    return over;
  };
  const bool bounded = pre && reach >= 0;
  // Errors at the poses the substep will reach, and (pre) the levers there too: the impulse stands for the
  // joint's force over the substep, and with the end's levers the Newton step's matrix is the derivative of
  // the end-of-substep gap (with the start's levers it was off by the turn over the substep, and chains of
  // light links under a heavy body diverged unless their substeps kept each turn small). Post: now.
  // The anchors' levers turned into the world (the world's anchor: itself), and the anchor gap.
  const glm::dvec3 turnedA = a.dir(jt.rA, pre), rb = b.dir(jt.rB, pre);
  const glm::dvec3 e = b.at(rb, pre) - a.at(turnedA, pre);  // anchor gap
  // A slider's B anchor runs along A's axis: its rows hold B's anchor to the point of A's axis it is at, so A's
  // side acts at that point (A's anchor + the gap), not at A's anchor. The rows' rates are then the exact
  // derivatives of their errors (A turning carries the axis, and a bead far along a turning rod with it), and the
  // impulses turn A as the bead pushes it there.
  const glm::dvec3 ra = d.a < 0 ? glm::dvec3(0) : turnedA + (d.type == JointType::Slider ? e : glm::dvec3(0));
  out.ra = ra;
  out.rb = rb;
  const glm::dvec3 eNow = bounded ? b.point(jt.rB, false) - a.point(jt.rA, false) : glm::dvec3(0);
  // The relative velocities (post's errors; pre asks none of them).
  const glm::dvec3 u = pre ? glm::dvec3(0) : (b.v + glm::cross(b.w, rb)) - (a.v + glm::cross(a.w, ra));
  const glm::dvec3 omega = pre ? glm::dvec3(0) : b.w - a.w;
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
        out.limit = true;
        const double bound = len > jt.maxLength ? jt.maxLength : jt.minLength;
        const double over = bounded ? excess(lenNow - bound) : 0.0;
        // Only what is still beyond the bound in the bound's direction is left for later.
        err[n - 1] = len - bound - ((over > 0) == (len > bound) ? over : 0.0);
      } else if (!pre) {
        // Post: only at a bound and moving out of the range, or wherever pre-stabilisation held it at a bound
        // this substep (the speed that closed a violation is no speed the bodies had: it goes too).
        const double l = glm::length(b.point(jt.rB, false) - a.point(jt.rA, false));
        const double speed = glm::dot(dir, u);
        if (jt.limitHeld || (l >= jt.maxLength - 1e-6 && speed > 0) || (l <= jt.minLength + 1e-6 && speed < 0)) {
          linear(dir);
          out.limit = true;
        }
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
      out.limit = true;
    } else if (!pre && (jt.limitHeld || (value >= d.upper - tol && rate > 0) || (value <= d.lower + tol && rate < 0))) {
      // (Held at a bound by pre-stabilisation this substep: all of the rate goes, as for a distance's range.)
      rows[n] = row;
      err[n++] = rate;
      out.limit = true;
    }
  }
  for (int k = 0; k < n; ++k) out.worst = std::max(out.worst, std::abs(err[k]) * (pre ? 1.0 : h));
}

}  // namespace crumple::detail::joints
