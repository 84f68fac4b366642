// The joint solver's pieces (physics/joint_step.cpp drives them): a joint's rows and what they forbid
// (joint_rows.cpp), and the direct solve of all joints at once over the joint graph (joint_solve.cpp). Internal:
// not installed.
#pragma once
#include <array>
#include <cmath>
#include <utility>
#include <vector>

#include <crumple/physics/step_context.h>

namespace crumple::detail {

namespace joints {

constexpr double kPi = 3.14159265358979323846;

inline double wrapAngle(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a <= -kPi) a += 2 * kPi;
  return a;
}

inline glm::dmat3 skew(const glm::dvec3& r) {
  // [r]x: skew(r) * v = r x v (GLM matrices are column-major)
  return glm::dmat3(0, r.z, -r.y, -r.z, 0, r.x, r.y, -r.x, 0);
}

// Two unit directions normal to n and to each other.
inline void normalBasis(const glm::dvec3& n, glm::dvec3& t1, glm::dvec3& t2) {
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
  // point(local, pred) from dir(local, pred).
  glm::dvec3 at(const glm::dvec3& turned, bool pred) const {
    if (index < 0) return turned;
    return (pred ? predicted.position : pose.position) + turned;
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
    if (pred && h == 0) {  // predicted = now, unturned (the pose mostly stays put within a call: its rotation kept)
      predicted = {b.x, b.q};
      Rp = b.q == pose.orientation ? R : glm::mat3_cast(b.q);
    } else if (pred) {
      predicted = {b.x + h * b.v, ctx.turnOf(b, b.w, h).q};
      Rp = glm::mat3_cast(predicted.orientation);
    }
  }
};

// A side now: the pose, the inverse masses, the velocities (predicted = now); setSide makes s so in place.
Side sideAt(const StepContext& ctx, int i);
void setSide(Side& s, const StepContext& ctx, int i);

// The 6x6 map from (linear impulse at the anchors, torque impulse) on B to the
// change of (relative anchor velocity, relative angular velocity).
struct Mobility {
  glm::dmat3 K{0}, C{0}, A{0};  // [[K, C], [C^T, A]]
  glm::dvec3 ra{0}, rb{0};      // levers (now)
};

inline Mobility mobility(const Side& a, const Side& b, const glm::dvec3& ra, const glm::dvec3& rb) {
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
void solveRows(const Mobility& m, const Row* rows, int n, const double* rhs, double* lambda);

// Applies a linear impulse j at the anchors and a torque impulse t on B (their opposites on A).
void applyImpulse(StepContext& ctx, const glm::dvec3& ra, const glm::dvec3& rb, const Side& a, const Side& b,
                  const glm::dvec3& j, const glm::dvec3& t);

// Applies sum lambda_k row_k on B (its opposite on A) and books it on the joint.
void applyRows(StepContext& ctx, Joint& jt, const glm::dvec3& ra, const glm::dvec3& rb, const Side& a, const Side& b,
               const Row* rows, int n, const double* lambda);

// A rotation vector of the small rotation q (angle times axis).
glm::dvec3 rotationVector(glm::dquat q);

// The hinge angle at the sides' poses (predicted or now): B's reference direction against A's about A's axis.
double hingeAngle(const Joint& jt, const Side& a, const Side& b, bool pred);

// Whether a joint enforces anything: not removed or broken, a dynamic body at an end.
bool active(const StepContext& ctx, const Joint& jt);

// What a joint forbids in one pass: its rows (at most 6), their errors (the
// predicted violation for pre, the relative velocity for post) and the levers
// the impulses act at (pre: at the substep's end; post: now).
struct JointRows {
  int n = 0;
  Row rows[6];
  double err[6] = {};
  glm::dvec3 ra{0}, rb{0};
  double worst = 0;  // m or rad (pre); m or rad per substep (post)
  bool limit = false;  // a limit row (hinge, slider) or a range row (distance) is among the rows
  double beyond = 0;  // pre, with a reach: the most a row's violation now exceeds it by (>0: closes over substeps)
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
                    int parts = kMainRows | kLimitRow);
// The same, written into `out` (its rows past out.n are left as they were).
void fillJointRows(JointRows& out, const Joint& jt, const Side& a, const Side& b, double h, bool pre, double reach,
                   int parts = kMainRows | kLimitRow);

}  // namespace joints

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

// A loop joint's row on one of its dynamic ends (its slot): g and W g, as RowEnd's.
struct LoopRowEnd {
  int slot;
  double g[6], wg[6];
};

// The joints of a call, the bodies they join and the elimination order (kept
// in StepContext::jointSolver while `signature` stays the same), and what each
// pass fills in.
struct JointSystem {
  std::vector<int> signature;             // per active joint: id, and which of its ends are dynamic
  std::vector<int> joints;                // active joints (ids), in id order
  std::vector<int> slot;                  // per body index: its side in `sides`, or -1
  std::vector<joints::Side> sides;                // [0] is the world
  std::vector<std::pair<int, int>> ends;  // per active joint: the slots of a and b
  // Joints that close a loop (through each other or through what cannot move,
  // e.g. a second joint between the same two bodies): solved with the others,
  // which form a forest, through their Schur complement (joint_solve.cpp's
  // solveWithLoops), or one by one after them where they have too many rows.
  std::vector<int> loops;
  std::vector<std::pair<int, int>> loopEnds;
  // Per dynamic body slot: the joints (places in `joints`) on it, with +1 on B, -1 on A.
  std::vector<std::vector<std::pair<int, int>>> onBody;
  bool conditional = false;               // some rows come and go (limits, distance ranges)
  std::vector<int> order, place;          // elimination position -> joint, joint -> position
  std::vector<std::vector<int>> later;    // per position: the later positions L couples it to (sorted)
  // Per pass.
  std::vector<joints::JointRows> rows;            // per joint
  std::vector<Block> diag, inv;                   // per position (diag: its lower triangle only)
  std::vector<std::array<double, 6>> scale;  // per position: the diagonal before elimination
  std::vector<std::vector<Block>> off;    // per position, along `later`
  std::vector<std::array<double, 6>> x;   // per position
  // The loops' solve with the forest (solvePass), per pass: per loop joint its rows; per loop row its ends, the
  // forest's response to it (by position) and that solved (A^-1 B's column); the Schur complement, its diagonal
  // before elimination, the right-hand sides (then the loop rows' impulses) and the pivots.
  std::vector<joints::JointRows> loopRows;
  std::vector<std::array<LoopRowEnd, 2>> loopRowEnds;
  std::vector<int> loopRowEndCount;
  std::vector<std::vector<std::array<double, 6>>> loopResponse, loopColumns;
  std::vector<double> loopSchur, loopScale, loopRhs, loopPivots;
  std::vector<Block> scratch;
  std::vector<RowEnd> endScratch;  // per joint on the body being assembled
};

namespace joints {

// The system of this call: the cached one with the sides brought up to date
// while the active joints and which of their ends are dynamic stay the same,
// else built anew.
JointSystem& buildSystem(StepContext& ctx);

// The worst violation of the system's joints: predicted (pre, m or rad) or per substep (post); their rows filled in.
double lookAtJoints(const StepContext& ctx, JointSystem& s, double h, bool pre);

// A hinge's or slider's motor: one row along the axis towards its speed, its
// impulse over the substep clamped to maxForce h.
void solveMotor(StepContext& ctx, Joint& jt, Side& a, Side& b, double h);

// One joint alone (Gauss-Seidel): a Newton step with the velocities of the moment.
void solveAlone(StepContext& ctx, Joint& jt, Side& a, Side& b, double h, bool pre);

// The loops, one by one.
void solveLoops(StepContext& ctx, JointSystem& s, double h, bool pre);

// A pass (after a look at the joints): the forest at once, then the loops one
// by one (a loop joint takes only what the forest leaves to it).
void solvePass(StepContext& ctx, JointSystem& s, double h, bool pre);

}  // namespace joints

}  // namespace crumple::detail
