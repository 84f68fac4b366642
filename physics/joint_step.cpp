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
//   touched a joined body): motors first (velocity targets; the impulse over a substep is
//   at most maxForce h, over both calls of the substep), then each joint's rows are solved for the impulse that
//   makes the joint hold at the end of the substep, at the poses the position
//   update will reach with the velocities (x + h v, q integrated from omega):
//   a Newton step on the linearisation per joint and sweep, Gauss-Seidel over
//   the joints in id order, until every joint's predicted violation is under
//   jointTolerance or `sweeps` sweeps are done. Limits are one-sided rows at the
//   bound, acting only where the predicted angle (hinge), offset (slider) or
//   distance would leave the range.
// - postStabilize (after the positions): the relative velocity each joint
//   forbids is removed (limits: only the part that leaves the range),
//   `jointPostIterations` sweeps; then every hinge's unwrapped angle is updated.
// - projectJoints (in the position step's projection, after each iteration over
//   the contacts): one Gauss-Seidel sweep that translates each joint's bodies,
//   split by inverse mass, to close its anchor gap (the part the joint forbids).
// - findAnchored: ctx.anchored marks the bodies welded to the world or to a
//   static body through fixed joints that hold (the collision step's elastic
//   impulse treats them as part of what they are welded to).
// - Breaking (at the end of each pre- and post-stabilisation call): a joint
//   whose linear impulse summed over the step so far passes its breakImpulse
//   yields: of that call's impulse it keeps only what takes it to its strength
//   (the rest is taken back from the bodies), breaks (one JointBreak, with the
//   impulse it was asked for) and enforces nothing from then on.
// - A joint between two bodies that cannot move (static, kinematic, asleep) does
//   nothing; a sleeping body joined to an awake one is woken first.
#include <algorithm>
#include <cmath>

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

// One body's side of a joint (the world when index < 0).
struct Side {
  int index = -1;
  double invMass = 0;
  glm::dmat3 invInertia{0};
  Pose pose;       // now
  Pose predicted;  // after h with the current velocities
  glm::dvec3 v{0}, w{0};
};

Side sideOf(const StepContext& ctx, int i, double h) {
  Side s;
  s.index = i;
  if (i < 0) return s;
  const RigidBody& b = ctx.body(i);
  s.pose = {b.x, b.q};
  s.predicted = s.pose;
  if (!b.movable()) return s;
  s.v = b.v;
  s.w = b.w;
  s.predicted = {b.x + h * b.v, integrateOrientation(b.q, b.w, h)};
  if (b.dynamic()) {
    s.invMass = b.invMass;
    s.invInertia = ctx.invInertia[static_cast<size_t>(i)];
  }
  return s;
}

glm::dvec3 pointOf(const Pose& p, const glm::dvec3& local, int index) {
  return index < 0 ? local : p.position + glm::mat3_cast(p.orientation) * local;
}
glm::dvec3 dirOf(const Pose& p, const glm::dvec3& local, int index) {
  return index < 0 ? local : glm::mat3_cast(p.orientation) * local;
}
glm::dquat rotOf(const Pose& p, int index) { return index < 0 ? glm::dquat(1, 0, 0, 0) : p.orientation; }

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
void applyImpulse(StepContext& ctx, const Mobility& m, const Side& a, const Side& b, const glm::dvec3& j,
                  const glm::dvec3& t) {
  if (a.index >= 0 && (a.invMass > 0)) {
    RigidBody& A = ctx.body(a.index);
    A.v -= j * a.invMass;
    A.w -= a.invInertia * (glm::cross(m.ra, j) + t);
  }
  if (b.index >= 0 && (b.invMass > 0)) {
    RigidBody& B = ctx.body(b.index);
    B.v += j * b.invMass;
    B.w += b.invInertia * (glm::cross(m.rb, j) + t);
  }
}

// Applies sum lambda_k row_k on B (its opposite on A) and books it on the joint.
void applyRows(StepContext& ctx, Joint& jt, const Mobility& m, const Side& a, const Side& b, const Row* rows, int n,
               const double* lambda) {
  glm::dvec3 j(0), t(0);
  for (int k = 0; k < n; ++k) {
    j += lambda[k] * rows[k].lin;
    t += lambda[k] * rows[k].ang;
  }
  applyImpulse(ctx, m, a, b, j, t);
  jt.stepImpulse += j;
  jt.callLinear += j;
  jt.callAngular += t;
}

// A rotation vector of the small rotation q (angle times axis).
glm::dvec3 rotationVector(glm::dquat q) {
  if (q.w < 0) q = -q;
  const glm::dvec3 v(q.x, q.y, q.z);
  const double s = glm::length(v);
  if (s < 1e-12) return 2.0 * v;
  return v * (2 * std::atan2(s, q.w) / s);
}

// The hinge angle at poses (pa, pb): B's reference direction against A's about A's axis.
double hingeAngle(const Joint& jt, const Pose& pa, const Pose& pb) {
  const glm::dvec3 n = dirOf(pa, jt.axisA, jt.def.a), ra = dirOf(pa, jt.refA, jt.def.a),
                   rb = dirOf(pb, jt.refB, jt.def.b);
  return std::atan2(glm::dot(n, glm::cross(ra, rb)), glm::dot(ra, rb));
}

bool active(const StepContext& ctx, const Joint& jt) {
  if (jt.removed || jt.broken) return false;
  const bool ma = jt.def.a >= 0 && ctx.body(jt.def.a).dynamic(), mb = ctx.body(jt.def.b).dynamic();
  return ma || mb;
}

// One Newton step of joint jt's rows towards its end-of-substep target (pre =
// true) or its velocity target (pre = false). Returns the largest violation it saw.
double solveJoint(StepContext& ctx, Joint& jt, double h, bool pre) {
  const JointDef& d = jt.def;
  const Side a = sideOf(ctx, d.a, h), b = sideOf(ctx, d.b, h);
  const Pose& pa = pre ? a.predicted : a.pose;
  const Pose& pb = pre ? b.predicted : b.pose;
  // Levers now (the impulse acts now); errors at the poses the step will reach.
  const glm::dvec3 ra = d.a < 0 ? glm::dvec3(0) : dirOf(a.pose, jt.rA, d.a);
  const glm::dvec3 rb = dirOf(b.pose, jt.rB, d.b);
  const Mobility m = mobility(a, b, ra, rb);
  const glm::dvec3 e = pointOf(pb, jt.rB, d.b) - pointOf(pa, jt.rA, d.a);  // anchor gap
  const glm::dvec3 u = (b.v + glm::cross(b.w, rb)) - (a.v + glm::cross(a.w, ra));
  const glm::dvec3 omega = b.w - a.w;
  Row rows[6];
  double err[6];
  int n = 0;
  auto linear = [&](const glm::dvec3& dir) {
    rows[n] = {dir, glm::dvec3(0)};
    err[n++] = pre ? glm::dot(dir, e) : glm::dot(dir, u);
  };
  auto angular = [&](const glm::dvec3& dir, double angleError) {
    rows[n] = {glm::dvec3(0), dir};
    err[n++] = pre ? angleError : glm::dot(dir, omega);
  };
  const glm::dvec3 axis = d.type == JointType::Hinge || d.type == JointType::Slider
                              ? glm::normalize(dirOf(pa, jt.axisA, d.a))
                              : glm::dvec3(0, 1, 0);
  glm::dvec3 t1, t2;
  normalBasis(axis, t1, t2);
  // Relative turn of B against its target relative to A (fixed, slider).
  auto turnError = [&]() {
    return rotationVector(rotOf(pb, d.b) * glm::conjugate(rotOf(pa, d.a) * jt.rel0));
  };
  double worst = 0;
  switch (d.type) {
    case JointType::Ball:
      for (int k = 0; k < 3; ++k) linear(glm::dvec3(k == 0, k == 1, k == 2));
      break;
    case JointType::Fixed: {
      for (int k = 0; k < 3; ++k) linear(glm::dvec3(k == 0, k == 1, k == 2));
      const glm::dvec3 th = pre ? turnError() : glm::dvec3(0);
      for (int k = 0; k < 3; ++k) angular(glm::dvec3(k == 0, k == 1, k == 2), th[k]);
      break;
    }
    case JointType::Hinge: {
      for (int k = 0; k < 3; ++k) linear(glm::dvec3(k == 0, k == 1, k == 2));
      const glm::dvec3 th = pre ? glm::cross(axis, glm::normalize(dirOf(pb, jt.axisB, d.b))) : glm::dvec3(0);
      angular(t1, glm::dot(th, t1));
      angular(t2, glm::dot(th, t2));
      break;
    }
    case JointType::Slider: {
      linear(t1);
      linear(t2);
      const glm::dvec3 th = pre ? turnError() : glm::dvec3(0);
      for (int k = 0; k < 3; ++k) angular(glm::dvec3(k == 0, k == 1, k == 2), th[k]);
      break;
    }
    case JointType::Distance: {
      const double len = glm::length(e);
      if (len < 1e-9) break;
      const glm::dvec3 dir = e / len;
      if (jt.minLength == jt.maxLength) {
        linear(dir);
        if (pre) err[n - 1] = len - jt.length;
      } else if (pre && (len > jt.maxLength || len < jt.minLength)) {
        linear(dir);
        err[n - 1] = len - (len > jt.maxLength ? jt.maxLength : jt.minLength);
      } else if (!pre) {
        // Post: only at a bound and moving out of the range.
        const glm::dvec3 ep = pointOf(b.pose, jt.rB, d.b) - pointOf(a.pose, jt.rA, d.a);
        const double l = glm::length(ep);
        const double speed = glm::dot(dir, u);
        if ((l >= jt.maxLength - 1e-6 && speed > 0) || (l <= jt.minLength + 1e-6 && speed < 0)) linear(dir);
      }
      break;
    }
  }
  if (n > 0) {
    double rhs[6], lambda[6];
    for (int k = 0; k < n; ++k) {
      worst = std::max(worst, std::abs(err[k]) * (pre ? 1.0 : h));
      rhs[k] = pre ? -err[k] / h : -err[k];
    }
    solveRows(m, rows, n, rhs, lambda);
    applyRows(ctx, jt, m, a, b, rows, n, lambda);
  }
  return worst;
}

// Motors and limits of hinges and sliders: one row each along the axis.
double solveAxis(StepContext& ctx, Joint& jt, double h, bool pre) {
  const JointDef& d = jt.def;
  if (d.type != JointType::Hinge && d.type != JointType::Slider) return 0;
  if (!d.limited && !(pre && d.motor.enabled)) return 0;
  const Side a = sideOf(ctx, d.a, h), b = sideOf(ctx, d.b, h);
  const glm::dvec3 ra = d.a < 0 ? glm::dvec3(0) : dirOf(a.pose, jt.rA, d.a);
  const glm::dvec3 rb = dirOf(b.pose, jt.rB, d.b);
  const Mobility m = mobility(a, b, ra, rb);
  const bool hinge = d.type == JointType::Hinge;
  const glm::dvec3 axis = glm::normalize(dirOf(pre ? a.predicted : a.pose, jt.axisA, d.a));
  const Row row = hinge ? Row{glm::dvec3(0), axis} : Row{axis, glm::dvec3(0)};
  const glm::dvec3 u = (b.v + glm::cross(b.w, rb)) - (a.v + glm::cross(a.w, ra));
  const double rate = hinge ? glm::dot(axis, b.w - a.w) : glm::dot(axis, u);
  double worst = 0;
  double lambda = 0;
  if (pre && d.motor.enabled) {
    double l;
    const double rhs = -(rate - d.motor.speed);
    solveRows(m, &row, 1, &rhs, &l);
    const double cap = d.motor.maxForce * h;
    const double total = std::clamp(jt.motorImpulse + l, -cap, cap);
    lambda = total - jt.motorImpulse;
    jt.motorImpulse = total;
    if (lambda != 0) applyRows(ctx, jt, m, a, b, &row, 1, &lambda);
  }
  if (!d.limited) return 0;
  // The angle or offset: predicted (pre) or now (post).
  const Side a2 = sideOf(ctx, d.a, h), b2 = sideOf(ctx, d.b, h);
  const Pose& pa = pre ? a2.predicted : a2.pose;
  const Pose& pb = pre ? b2.predicted : b2.pose;
  double value;
  if (hinge) {
    value = jt.angle + wrapAngle(hingeAngle(jt, pa, pb) - wrapAngle(jt.angle));
  } else {
    value = glm::dot(pointOf(pb, jt.rB, d.b) - pointOf(pa, jt.rA, d.a), axis);
  }
  const double rate2 = hinge ? glm::dot(axis, b2.w - a2.w)
                             : glm::dot(axis, (b2.v + glm::cross(b2.w, rb)) - (a2.v + glm::cross(a2.w, ra)));
  double rhs = 0;
  if (pre) {
    if (value > d.upper) {
      rhs = -(value - d.upper) / h;
      worst = value - d.upper;
    } else if (value < d.lower) {
      rhs = -(value - d.lower) / h;
      worst = d.lower - value;
    } else {
      return 0;
    }
  } else {
    const double tol = 1e-6;
    if (value >= d.upper - tol && rate2 > 0) {
      rhs = -rate2;
    } else if (value <= d.lower + tol && rate2 < 0) {
      rhs = -rate2;
    } else {
      return 0;
    }
  }
  solveRows(m, &row, 1, &rhs, &lambda);
  if (lambda != 0) applyRows(ctx, jt, m, a2, b2, &row, 1, &lambda);
  return worst;
}

// Before a call's sweeps: what each joint applies in the call is booked from zero.
void startCall(StepContext& ctx) {
  for (Joint& jt : ctx.joints) {
    jt.callLinear = jt.callAngular = glm::dvec3(0);
    jt.callStart = jt.stepImpulse;
  }
}

// After a call's sweeps: a joint whose impulse over the step now passes its
// breakImpulse yields. It keeps only the part of this call's impulse that
// takes it to its strength (the rest is taken back) and breaks: a weld never
// passes on more than it can bear.
void yieldJoints(StepContext& ctx, double h) {
  for (size_t i = 0; i < ctx.joints.size(); ++i) {
    Joint& jt = ctx.joints[i];
    if (jt.removed || jt.broken) continue;
    const double demand = glm::length(jt.stepImpulse);
    if (!(demand > jt.def.breakImpulse)) continue;
    // f in [0, 1] with |callStart + f callLinear| = breakImpulse (|callStart| <= breakImpulse).
    const glm::dvec3 p = jt.callStart, j = jt.callLinear;
    const double jj = glm::dot(j, j), pj = glm::dot(p, j), B = jt.def.breakImpulse;
    double f = 0;
    if (jj > 0) f = std::clamp((-pj + std::sqrt(std::max(0.0, pj * pj - jj * (glm::dot(p, p) - B * B)))) / jj, 0.0, 1.0);
    const Side a = sideOf(ctx, jt.def.a, h), b = sideOf(ctx, jt.def.b, h);
    const glm::dvec3 ra = jt.def.a < 0 ? glm::dvec3(0) : dirOf(a.pose, jt.rA, jt.def.a);
    const Mobility m = mobility(a, b, ra, dirOf(b.pose, jt.rB, jt.def.b));
    applyImpulse(ctx, m, a, b, -(1 - f) * j, -(1 - f) * jt.callAngular);
    jt.stepImpulse = p + f * j;
    jt.broken = true;
    ctx.jointExcludedDirty = true;
    ctx.jointBreaks.push_back({ctx.time + h, static_cast<int>(i), demand});
  }
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
  startCall(ctx);
  for (int s = 0; s < sweeps; ++s) {
    double worst = 0;
    for (Joint& jt : ctx.joints) {
      if (!active(ctx, jt)) continue;
      worst = std::max(worst, solveAxis(ctx, jt, h, true));
      worst = std::max(worst, solveJoint(ctx, jt, h, true));
    }
    ++ctx.stats.jointSweeps;
    if (worst < ctx.settings.jointTolerance) break;
  }
  yieldJoints(ctx, h);
}

void postStabilize(StepContext& ctx, double h) {
  if (ctx.joints.empty()) return;
  startCall(ctx);
  for (int s = 0; s < ctx.settings.jointPostIterations; ++s)
    for (Joint& jt : ctx.joints) {
      if (!active(ctx, jt)) continue;
      solveJoint(ctx, jt, h, false);
      solveAxis(ctx, jt, h, false);
    }
  yieldJoints(ctx, h);
  for (Joint& jt : ctx.joints) {
    if (jt.removed || jt.broken || jt.def.type != JointType::Hinge) continue;
    const Side a = sideOf(ctx, jt.def.a, h), b = sideOf(ctx, jt.def.b, h);
    jt.angle += wrapAngle(hingeAngle(jt, a.pose, b.pose) - wrapAngle(jt.angle));
  }
}

void projectJoints(StepContext& ctx, std::vector<glm::dvec3>& moved) {
  for (Joint& jt : ctx.joints) {
    if (!active(ctx, jt)) continue;
    const JointDef& d = jt.def;
    const double wa = d.a >= 0 && ctx.body(d.a).dynamic() ? ctx.body(d.a).invMass : 0;
    const double wb = ctx.body(d.b).dynamic() ? ctx.body(d.b).invMass : 0;
    if (wa + wb <= 0) continue;
    const Side a = sideOf(ctx, d.a, 0), b = sideOf(ctx, d.b, 0);
    glm::dvec3 e = pointOf(b.pose, jt.rB, d.b) - pointOf(a.pose, jt.rA, d.a);
    if (d.type == JointType::Slider) {
      const glm::dvec3 axis = glm::normalize(dirOf(a.pose, jt.axisA, d.a));
      e -= glm::dot(e, axis) * axis;
    } else if (d.type == JointType::Distance) {
      const double len = glm::length(e);
      if (len < 1e-9) continue;
      const double target = std::clamp(len, jt.minLength, jt.maxLength);
      e *= (len - target) / len;
    }
    const glm::dvec3 da = e * (wa / (wa + wb)), db = -e * (wb / (wa + wb));
    if (wa > 0) {
      ctx.body(d.a).x += da;
      moved[static_cast<size_t>(d.a)] += da;
    }
    if (wb > 0) {
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


bool mayCollide(StepContext& ctx, int a, int b) {
  const RigidBody& A = ctx.body(a);
  const RigidBody& B = ctx.body(b);
  if (A.removed || B.removed) return false;
  if (!(ctx.groupMasks[static_cast<size_t>(A.group)] >> B.group & 1ull)) return false;
  if (ctx.jointExcludedDirty) {
    ctx.jointExcluded.clear();
    for (const Joint& jt : ctx.joints) {
      if (jt.removed || jt.broken || jt.def.collideConnected || jt.def.a < 0) continue;
      const int lo = std::min(jt.def.a, jt.def.b), hi = std::max(jt.def.a, jt.def.b);
      ctx.jointExcluded.push_back(static_cast<uint64_t>(lo) << 32 | static_cast<uint64_t>(hi));
    }
    std::sort(ctx.jointExcluded.begin(), ctx.jointExcluded.end());
    ctx.jointExcludedDirty = false;
  }
  if (!ctx.jointExcluded.empty()) {
    const uint64_t key = static_cast<uint64_t>(std::min(a, b)) << 32 | static_cast<uint64_t>(std::max(a, b));
    if (std::binary_search(ctx.jointExcluded.begin(), ctx.jointExcluded.end(), key)) return false;
  }
  if (ctx.filter && !ctx.filter(std::min(a, b), std::max(a, b))) return false;
  return true;
}

}  // namespace crumple::detail
