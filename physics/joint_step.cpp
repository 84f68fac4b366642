// Joints in the step (Weinstein, Teran & Fedkiw 2006, "Dynamic simulation of
// articulated rigid bodies with contact and collision"), as impulses like the
// contacts. This file drives the calls (stabilisation, breaking, projection);
// a joint's rows are in joint_rows.cpp, the direct solve in joint_solve.cpp
// (physics/joint_solver.h).
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
//   touched a joined body, jointsTouched, and again in settleJoinedContacts'
//   turns): motors first (velocity targets; the impulse over a substep is at
//   most maxForce h, over all calls of the substep), then the
//   joints' rows are solved for the impulses that make them hold at the end of
//   the substep, at the poses the position update will reach with the
//   velocities (x + h v, q integrated from omega). Each pass is a Newton step
//   on the linearisation of all joints at once: the joints that form a spanning
//   forest over the bodies (what cannot move counting as one; taken strongest
//   first: welds, hinges and sliders, balls, rods) are solved together by
//   a sparse L D L^T factorisation over the joint graph (linear in the joints
//   for chains and trees); the rows of the joints that close loops (a second
//   joint between the same bodies, a ring, a second anchor to the world) are
//   solved with them through their Schur complement, a loop row the forest
//   nearly holds already (a planar ring's turns out of its plane) dropped
//   and the loop joints then swept one by one over what is left; past 24
//   loop rows each loop joint is solved alone after the forest
//   (Gauss-Seidel). Passes go on until every joint's predicted
//   violation is under jointTolerance or `sweeps` passes are done. Limits are
//   one-sided rows at the bound, acting only where the predicted angle (hinge),
//   offset (slider) or distance would leave the range. A call that hands the
//   joined bodies more kinetic energy than closing their violations takes
//   (closingEnergy) and the motors' work is scaled back to that (where half
//   the call or more fits: scaleCall) or undone (removeForbiddenVelocity
//   instead); where no kinematic
//   end drives, closing is paid from the joints' credits (settleCredit), so the
//   joints' net work is bounded for all time.
// - postStabilize (after the positions): the relative velocity each joint
//   forbids is removed (limits and ranges: only the part that leaves the range,
//   or all of it where the substep's pre-stabilisation held the joint at a
//   bound: a violation closed there leaves no speed behind), one pass
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
//   nothing, nor does one (a weld excepted) between two bodies held to the world
//   by welds (findAnchored), or one of them and the world; a sleeping body joined
//   to an awake one is woken first.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <crumple/physics/disjoint_sets.h>
#include <crumple/physics/joint_solver.h>

namespace crumple::detail {

using namespace joints;

namespace {

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
// is the solver's, not the scene's. Per joint of s (its joints, then its loops) in `each`; returns the sum.
// Called right after buildSystem: the sides hold the bodies as they are (predicted = now).
double closingEnergy(StepContext& ctx, JointSystem& s, double h, bool first, std::vector<double>& each) {
  const double reach = ctx.settings.maxCorrectionSpeed * h;
  each.clear();
  double sum = 0;
  auto add = [&](Joint& jt, const Side& a, const Side& b) {
    double energy = 0, largest = 0;
    const JointRows jr = jointRows(jt, a, b, h, true, reach);
    if (first) {
      // Closing: still beyond reach, and a quarter of a reach nearer than at the last substep's start.
      jt.progressed = jr.beyond > 0 && jt.lastBeyond >= 0 && jr.beyond < jt.lastBeyond - 0.25 * reach;
      jt.lastBeyond = jr.beyond;
    }
    for (int k = 0; k < jr.n; ++k) {
      largest = std::max(largest, std::abs(jr.err[k]));
      const Row& row = jr.rows[k];
      // The row's inverse effective mass, row^T M row (joint_solver.h's Mobility) side by side: each body moves
      // its anchor along the row by its inverse mass and turns by (r x lin + ang) through its inverse inertia.
      const glm::dvec3 ta = glm::cross(jr.ra, row.lin) + row.ang, tb = glm::cross(jr.rb, row.lin) + row.ang;
      const double inverse = (a.invMass + b.invMass) * glm::dot(row.lin, row.lin) + glm::dot(ta, a.invInertia * ta) +
                             glm::dot(tb, b.invInertia * tb);
      if (!(inverse > 0)) continue;
      const double speed = jr.err[k] / h;
      energy += speed * speed / inverse;  // 2 x (speed^2 / 2 / inverse)
    }
    if ((jr.limit || jr.beyond > 0) && largest > 1e-3 * reach) {
      // A limit or range that closes, or a joint violated beyond reach: its rows together (a limit on a plate
      // turning about an end hinge turns it about the hinge, not about its centre, and takes twice the rows'
      // energies side by side; a small box closing a gap at the end of a 1 m lever, more): twice (speed . lambda)
      // / 2, lambda the impulses of the joint's own Newton step.
      double rhs[6], lambda[6];
      for (int k = 0; k < jr.n; ++k) rhs[k] = jr.err[k] / h;
      solveRows(mobility(a, b, jr.ra, jr.rb), jr.rows, jr.n, rhs, lambda);
      double together = 0;
      for (int k = 0; k < jr.n; ++k) together += rhs[k] * lambda[k];
      energy = std::max(energy, together);
    }
    each.push_back(energy);
    sum += energy;
  };
  for (size_t k = 0; k < s.joints.size(); ++k)
    add(ctx.joints[static_cast<size_t>(s.joints[k])], s.sides[static_cast<size_t>(s.ends[k].first)],
        s.sides[static_cast<size_t>(s.ends[k].second)]);
  for (size_t k = 0; k < s.loops.size(); ++k)
    add(ctx.joints[static_cast<size_t>(s.loops[k])], s.sides[static_cast<size_t>(s.loopEnds[k].first)],
        s.sides[static_cast<size_t>(s.loopEnds[k].second)]);
  return sum;
}

// The joints of s in closingEnergy's order.
template <typename F>
void forSystemJoints(StepContext& ctx, const JointSystem& s, F&& f) {
  size_t k = 0;
  for (int j : s.joints) f(ctx.joints[static_cast<size_t>(j)], k++);
  for (int j : s.loops) f(ctx.joints[static_cast<size_t>(j)], k++);
}

// Settles a call's change of the joined bodies' kinetic energy with the joints' credits: a gain is taken from
// them in proportion to what each holds, a loss given back to those below their cap in proportion to the
// shortfall. So whatever the calls do, the energy the joints hand out, less what they take away, never exceeds
// what closing their largest violation takes: a joint held open by something it cannot move (contradicting
// joints, a static body, a contact that pushes back) spends its credit once and then only holds.
void settleCredit(StepContext& ctx, const JointSystem& s, double gain) {
  if (gain > 0) {
    double held = 0;
    forSystemJoints(ctx, s, [&](Joint& jt, size_t) { held += std::max(jt.credit, 0.0); });
    if (!(held > 0)) return;
    const double share = std::min(gain / held, 1.0);
    forSystemJoints(ctx, s, [&](Joint& jt, size_t) { jt.credit = std::max(jt.credit, 0.0) * (1 - share); });
  } else if (gain < 0) {
    double shortfall = 0;
    auto lacks = [](const Joint& jt) { return std::max(jt.closingCap - std::max(jt.credit, 0.0), 0.0); };
    forSystemJoints(ctx, s, [&](Joint& jt, size_t) { shortfall += lacks(jt); });
    if (!(shortfall > 0)) return;
    const double share = std::min(-gain / shortfall, 1.0);
    forSystemJoints(ctx, s, [&](Joint& jt, size_t) { jt.credit = std::max(jt.credit, 0.0) + lacks(jt) * share; });
  }
}

// Whether a kinematic end of s moves (it drives the joined bodies: a source the credits do not cover).
bool kinematicDrive(const StepContext& ctx, const JointSystem& s) {
  for (size_t k = 1; k < s.sides.size(); ++k) {
    const int i = s.sides[k].index;
    if (i >= 0 && ctx.body(i).movable() && !ctx.body(i).dynamic()) return true;
  }
  return false;
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
  double before = 0, mass = 0, drive = 0, reach = -1;  // reach: only where a kinematic end drives
  for (size_t k = 1; k < s.sides.size(); ++k) {
    const int i = s.sides[k].index;
    if (i < 0 || !ctx.body(i).movable()) continue;
    const RigidBody& b = ctx.body(i);
    if (!b.dynamic()) {
      if (reach < 0) reach = jointReach(ctx, s);
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
  double after = joinedEnergy(ctx, s);
  if (after <= ceiling) {
    if (reach < 0) settleCredit(ctx, s, after - before);
    return;
  }
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
  after = joinedEnergy(ctx, s);
  if (after <= ceiling) {
    if (reach < 0) settleCredit(ctx, s, after - before);
    return;
  }
  restoreCall(ctx, s, saved, books);
}

// A call whose sweeps handed the joined bodies more than `budget` over their energy at its start (velocities `saved`,
// the joints' `books`) scaled back along its change of the velocities and of the joints' impulses to the
// largest share s in [0, 1] that keeps within it (the energy is quadratic in s). Returns s (0: the call undone).
double scaleCall(StepContext& ctx, const JointSystem& s, const std::vector<BodyState>& saved,
                 const std::vector<Joint>& books, double budget) {
  // E(s) = E(0) + B s + A s^2 over the velocities v0 + s dv: B = sum of (m v0 . dv + w0 . I dw), A = sum of
  // (m dv . dv + dw . I dw) / 2, I the world inertia.
  double A = 0, B = 0;
  size_t n = 0;
  for (size_t k = 1; k < s.sides.size(); ++k) {
    const int i = s.sides[k].index;
    if (i < 0 || !ctx.body(i).dynamic()) continue;
    const RigidBody& b = ctx.body(i);
    const glm::dvec3 dv = b.v - saved[n].v, dw = b.w - saved[n].w, turn = b.angularMomentumOf(dw);
    A += 0.5 * (b.mass * glm::dot(dv, dv) + glm::dot(dw, turn));
    B += b.mass * glm::dot(saved[n].v, dv) + glm::dot(saved[n].w, turn);
    ++n;
  }
  double share = 0;
  if (A > 0 && budget >= 0) share = std::clamp((-B + std::sqrt(std::max(0.0, B * B + 4 * A * budget))) / (2 * A), 0.0, 1.0);
  n = 0;
  for (size_t k = 1; k < s.sides.size(); ++k) {
    const int i = s.sides[k].index;
    if (i < 0 || !ctx.body(i).dynamic()) continue;
    RigidBody& b = ctx.body(i);
    b.v = saved[n].v + share * (b.v - saved[n].v);
    b.w = saved[n].w + share * (b.w - saved[n].w);
    ++n;
  }
  size_t m = 0;
  auto scaleBooks = [&](Joint& jt) {
    const Joint& was = books[m++];
    jt.stepImpulse = was.stepImpulse + share * (jt.stepImpulse - was.stepImpulse);
    jt.callLinear = was.callLinear + share * (jt.callLinear - was.callLinear);
    jt.callTurnA = was.callTurnA + share * (jt.callTurnA - was.callTurnA);
    jt.callTurnB = was.callTurnB + share * (jt.callTurnB - was.callTurnB);
    jt.motorImpulse = was.motorImpulse + share * (jt.motorImpulse - was.motorImpulse);
  };
  for (int j : s.joints) scaleBooks(ctx.joints[static_cast<size_t>(j)]);
  for (int j : s.loops) scaleBooks(ctx.joints[static_cast<size_t>(j)]);
  return share;
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

bool jointsTouched(StepContext& ctx) {
  if (ctx.joints.empty()) return false;
  std::vector<char>& touched = ctx.jointTouched;
  touched.assign(ctx.bodies.size(), 0);
  for (size_t pi = 0; pi < ctx.pairs.size() && pi < ctx.groups.size(); ++pi)
    if (!ctx.groups[pi].empty())
      touched[static_cast<size_t>(ctx.pairs[pi].a)] = touched[static_cast<size_t>(ctx.pairs[pi].b)] = 1;
  for (const Joint& jt : ctx.joints)
    if (active(ctx, jt) &&
        ((jt.def.a >= 0 && touched[static_cast<size_t>(jt.def.a)]) || touched[static_cast<size_t>(jt.def.b)]))
      return true;
  return false;
}

void preStabilize(StepContext& ctx, double h, int sweeps, bool first) {
  if (ctx.joints.empty()) return;
  if (first) {
    wakeJoined(ctx);
    for (Joint& jt : ctx.joints) jt.motorImpulse = 0;  // the motor's budget is per substep
  }
  // Again without the joints that break in it (yieldJoints).
  for (bool again = true; again;) {
    startCall(ctx);
    for (Joint& jt : ctx.joints) jt.limitHeld = false;
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
    // Where no kinematic end drives, closing is paid from the joints' credits (settleCredit), measured now for a
    // joint met for the first time.
    std::vector<double>& closing = ctx.jointClosing;
    double budget = std::min(closingEnergy(ctx, s, h, first, closing), moving);
    const bool driven = kinematicDrive(ctx, s);
    if (!driven) {
      double credit = 0;
      forSystemJoints(ctx, s, [&](Joint& jt, size_t k) {
        jt.closingCap = closing[k];
        // (Met for the first time or moved from outside: its closing measured now. A joint that closes is topped up
        // to what closing it takes now: its levers turn as it closes, and what post-stabilisation takes away gives
        // back only what the last call spent.)
        if (jt.credit < 0 || jt.progressed) jt.credit = std::max(jt.credit, closing[k]);
        jt.progressed = false;
        credit += jt.credit;
      });
      budget = std::min(budget, credit);
    }
    double motors = 0;  // the motors' work: a source the credits do not pay for
    for (int j : s.joints) {
      const JointDef& d = ctx.joints[static_cast<size_t>(j)].def;
      if (d.motor.enabled) motors += d.motor.maxForce * h * (std::abs(d.motor.speed) + fastest + c);
    }
    budget += motors;
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
    // Sweeps that handed the joined bodies more energy than that are scaled back to it if half of them or more
    // fits: a closing whose levers turn the body past the estimate still closes, a little slower, and so does a
    // joint whose bodies move (holding a moving chain at its predicted poses hands it energy to first order in the
    // correction: a bridge swinging with 70 J gained 1.2 J closing a 0.05 mm gap, and where such calls were undone
    // the gaps grew until closing them meant lifting the whole bridge). Else (joints that contradict each other, a
    // lever the direct solve cannot condition) they are undone: the joints then only take away the relative
    // velocities they forbid, as post-stabilisation does, which never adds energy.
    double after = joinedEnergy(ctx, s);
    if (!(after <= before + budget + 1e-9 * before)) {
      ++ctx.stats.jointFallbacks;
      if (scaleCall(ctx, s, saved, books, budget) >= 0.5) {
        after = joinedEnergy(ctx, s);
        if (!driven) settleCredit(ctx, s, after > before ? std::max(after - before - motors, 0.0) : after - before);
      } else {
        restoreCall(ctx, s, saved, books);
        removeForbiddenVelocity(ctx, s, h);
      }
    } else if (!driven) {
      settleCredit(ctx, s, after > before ? std::max(after - before - motors, 0.0) : after - before);
    }
    again = yieldJoints(ctx, s, h, saved, books);
  }
}

// The contact step and shock propagation stop a joined body at its contacts, and pre-stabilisation then hands
// it what the joints carry (a limb hanging from a torso that lies on the ground: the limb's weight reaches the
// torso only through the joint, after its contact stopped it), so a joined body's contact can be left
// approaching. Contact impulses (shock propagation's passes with every dynamic body on one level: nothing but
// static, kinematic and sleeping bodies frozen, so a blow pushes both bodies and the joints feel it) and
// pre-stabilisation take turns until no contact of a joined body approaches faster than jointContactTolerance, at
// most jointContactRounds turns: projections onto the contacts' and the joints' constraints in turn. A ragdoll
// lying flat settles in a few turns; one tangled after a fall converges slower (a few percent a turn). Without
// them a ragdoll lying still pressed into the ground at 5 cm/s each substep, the projection pushed it out, it hit
// the ground again each step (a thousand collision events a second) and crept along the ground. A contact
// approaching faster than jointContactBlow is a blow: then no turns at all (they would take its approach away as
// resting contact, inelastically and with no event: the highway's car, scraping along the rail it tore loose,
// stopped hitting it and no longer dragged it along).
void settleJoinedContacts(StepContext& ctx, double h) {
  const int rounds = ctx.settings.jointContactRounds;
  if (rounds <= 0 || ctx.joints.empty()) return;
  std::vector<char>& joined = ctx.jointJoined;
  joined.assign(ctx.bodies.size(), 0);
  bool any = false;
  for (const Joint& jt : ctx.joints) {
    if (!active(ctx, jt)) continue;
    for (int b : {jt.def.a, jt.def.b})
      if (b >= 0 && ctx.body(b).dynamic()) joined[static_cast<size_t>(b)] = any = 1;
  }
  if (!any) return;
  // The fastest approach of a joined body's contact (m/s, >= 0).
  auto fastest = [&] {
    double worst = 0;
    for (size_t pi = 0; pi < ctx.pairs.size() && pi < ctx.groups.size(); ++pi) {
      const Pair& p = ctx.pairs[pi];
      if (!joined[static_cast<size_t>(p.a)] && !joined[static_cast<size_t>(p.b)]) continue;
      for (const ContactGroup& g : ctx.groups[pi])
        worst = std::max(worst, -glm::dot(ctx.relativeVelocity(g.contact.a, g.contact.b, g.levers), g.contact.normal));
    }
    return worst;
  };
  const double tolerance = ctx.settings.jointContactTolerance;
  const double start = fastest();
  if (!(start > tolerance) || start > ctx.settings.jointContactBlow) return;
  // Turns that stop contacts take energy away, and they act only on the bodies joined, through contacts and joints,
  // to a joined body (the systems the turns are for). Where they handed such a system more kinetic energy than it
  // began with (beyond resting contact's scale, every body at the speed gravity adds in the substep), a joint
  // violated beyond what one call closes was paid its closing again each turn (a rope pulled taut under a slab:
  // 76 m/s), and all the velocities are put back as the second pre-stabilisation left them; a body of another
  // system (a crate landing on the ground beside a bridge, in no system with it) keeps what it had before the turns.
  const size_t n = ctx.bodies.size();
  DisjointSets& sets = ctx.jointRoundsSets;
  sets.reset(n);
  for (size_t pi = 0; pi < ctx.pairs.size() && pi < ctx.groups.size(); ++pi)
    if (!ctx.groups[pi].empty() && ctx.body(ctx.pairs[pi].a).dynamic() && ctx.body(ctx.pairs[pi].b).dynamic())
      sets.unite(ctx.pairs[pi].a, ctx.pairs[pi].b);
  for (const Joint& jt : ctx.joints)
    if (active(ctx, jt) && jt.def.a >= 0 && ctx.body(jt.def.a).dynamic() && ctx.body(jt.def.b).dynamic())
      sets.unite(jt.def.a, jt.def.b);
  std::vector<int>& bySet = ctx.jointRoundsSystem;  // per set's root: its system's index, -1 for no system
  bySet.assign(n, -1);
  int systems = 0;
  for (size_t i = 0; i < n; ++i)
    if (joined[i]) {
      int& r = bySet[static_cast<size_t>(sets.find(static_cast<int>(i)))];
      if (r < 0) r = systems++;
    }
  auto systemOf = [&](size_t i) {
    return ctx.bodies[i].dynamic() ? bySet[static_cast<size_t>(sets.find(static_cast<int>(i)))] : -1;
  };
  std::vector<BodyState>& saved = ctx.jointRoundsSaved;
  saved.resize(n);
  std::vector<double>& before = ctx.jointRoundsEnergy;
  before.assign(2 * static_cast<size_t>(systems), 0.0);  // per system: energy before, then its slack
  for (size_t i = 0; i < n; ++i) {
    const RigidBody& b = ctx.bodies[i];
    saved[i] = {b.x, b.q, b.v, b.w};
    const int k = systemOf(i);
    if (k < 0) continue;
    before[2 * static_cast<size_t>(k)] += b.kineticEnergy();
    before[2 * static_cast<size_t>(k) + 1] += ctx.restingSlack(b, h);
  }
  std::vector<Joint>& books = ctx.jointRoundsBooks;  // the joints' books too (credits, impulses, breaks)
  books = ctx.joints;
  const size_t breaks = ctx.jointBreaks.size();
  // Each turn must take at least a hundredth off the fastest approach: a swinging bridge's planks, their crates
  // bouncing on them, stall at an approach the joints hand back whole each turn (it is no resting contact), and the
  // turns stop there; turns that leave an approach faster than they began with are undone too.
  double now = start;
  for (int round = 0; round < rounds; ++round) {
    shockPropagation(ctx, h, true);
    // One Newton pass a turn: the turns themselves iterate (ten passes a turn gave the same events on the shipped
    // scenes: chain bridge 745 against 740, ragdoll 388 against 387, for ten times the passes).
    preStabilize(ctx, h, 1, false);
    const double last = now;
    now = fastest();
    if (!(now > tolerance) || !(now < 0.99 * last)) break;
  }
  std::vector<double>& after = ctx.jointRoundsAfter;
  after.assign(static_cast<size_t>(systems), 0.0);
  for (size_t i = 0; i < n; ++i) {
    RigidBody& b = ctx.bodies[i];
    const int k = systemOf(i);
    if (k >= 0) {
      after[static_cast<size_t>(k)] += b.kineticEnergy();
    } else if (b.dynamic()) {
      b.v = saved[i].v;
      b.w = saved[i].w;
    }
  }
  bool gained = now > start;
  for (size_t k = 0; k < static_cast<size_t>(systems); ++k)
    gained = gained || after[k] > before[2 * k] + before[2 * k + 1];
  if (!gained) return;
  for (size_t i = 0; i < n; ++i) {
    ctx.bodies[i].v = saved[i].v;
    ctx.bodies[i].w = saved[i].w;
  }
  ctx.joints.swap(books);
  ctx.jointBreaks.resize(breaks);
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

void projectJoints(StepContext& ctx, std::vector<glm::dvec3>& moved, double reach, bool first) {
  // Orientations stay put in the projection (translations only): each joint's anchors and slider axis turned
  // into the world once, at its first iteration.
  std::vector<ProjectedJoint>& turned = ctx.jointProjection;
  if (first) {
    turned.resize(ctx.joints.size());
    for (size_t k = 0; k < ctx.joints.size(); ++k) {
      const Joint& jt = ctx.joints[k];
      ProjectedJoint& t = turned[k];
      t.active = active(ctx, jt);
      if (!t.active) continue;
      const JointDef& d = jt.def;
      auto dir = [&](int i, const glm::dvec3& local) { return i < 0 ? local : ctx.body(i).q * local; };
      t.rA = dir(d.a, jt.rA);
      t.rB = dir(d.b, jt.rB);
      if (d.type == JointType::Slider) t.axis = glm::normalize(dir(d.a, jt.axisA));
    }
  }
  for (size_t k = 0; k < ctx.joints.size(); ++k) {
    const ProjectedJoint& t = turned[k];
    if (!t.active) continue;
    const Joint& jt = ctx.joints[k];
    const JointDef& d = jt.def;
    const double wa = d.a >= 0 && ctx.body(d.a).dynamic() ? ctx.body(d.a).invMass : 0;
    const double wb = ctx.body(d.b).dynamic() ? ctx.body(d.b).invMass : 0;
    if (wa + wb <= 0) continue;
    const glm::dvec3 shiftA = d.a >= 0 ? moved[static_cast<size_t>(d.a)] : glm::dvec3(0);
    const glm::dvec3 shiftB = moved[static_cast<size_t>(d.b)];
    // The anchor gap with the projection's translations so far.
    const glm::dvec3 gap = (ctx.body(d.b).x + t.rB) - (d.a < 0 ? t.rA : ctx.body(d.a).x + t.rA);
    // The part of the anchor gap the joint forbids, with the projection's translations so far (`shifted`) or
    // without them.
    auto forbidden = [&](bool shifted) {
      glm::dvec3 e = gap;
      if (!shifted) e -= shiftB - shiftA;
      if (d.type == JointType::Slider) {
        e -= glm::dot(e, t.axis) * t.axis;
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

bool anyJointActive(const StepContext& ctx) {
  return std::any_of(ctx.joints.begin(), ctx.joints.end(), [&](const Joint& jt) { return active(ctx, jt); });
}

}  // namespace crumple::detail
