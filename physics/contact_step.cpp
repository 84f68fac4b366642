// Velocities and the contact step (Guendelman et al. 2003, section 7.2).
//
// Guarantees:
// - integrateVelocities: every movable body's v += h a, omega += h alpha
//   (gravity, applied forces and torques; the gyroscopic term is the position
//   update's torque-free turn, rotation.h).
// - contactStep: `contactPasses` passes over the pairs, alternately forward and
//   backward, with restitution ramped from -1 (exclusive) to 0. Each pair's
//   penetrating points on the poses predicted with the current velocities are
//   grouped (contact_groups.h); each group gets one impulse per pass (a patch
//   impulse where its face can hold, else a point impulse with friction) whose
//   Coulomb cone bounds the group's totals over the whole step. The geometry
//   is looked at again every `contactRefresh` passes, and then only for pairs
//   whose predicted relative pose moved more than `contactRefreshTolerance`;
//   a group found again inherits the totals of the old group it replaces.
// - The pairs run island by island (islands.cpp; in parallel on the World's
//   threads), each island's in the sweep's order: the same impulses in the
//   same order per body as one sweep over all pairs.
// - After it, ctx.groups holds each pair's groups of its last look (levers, K,
//   normal speed then, patch): shock propagation and the position step use them.
//   stats.contacts counts the points of each pair's last look.
// - For pairs involving a body flagged with setReportContacts: one contact
//   report per pair that the step pushed apart, at its deepest group.
#include <algorithm>
#include <cstring>
#include <cmath>

#include <crumple/physics/step_context.h>

namespace crumple::detail {

void integrateVelocity(StepContext& ctx, size_t i, double h) {
  RigidBody& b = ctx.bodies[i];
  if (!b.movable()) return;
  const glm::dvec3 a = ctx.acceleration(static_cast<int>(i));
  const glm::dvec3 alpha = ctx.angularAcceleration(static_cast<int>(i));
  b.v += h * a;
  b.w += h * alpha;
}

void integrateVelocities(StepContext& ctx, double h) {
  ctx.parallelRange(ctx.bodies.size(), 256, [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) integrateVelocity(ctx, i, h);
  });
}

namespace {

// A group found again inherits the totals of the old group whose normal agrees
// best (within kSameGroup; each old group passes its totals on once).
void inheritTotals(const std::vector<ContactGroup>& old, std::vector<ContactGroup>& groups,
                   std::vector<char>& inherited) {
  inherited.assign(old.size(), 0);
  for (ContactGroup& group : groups) {
    const Contact& g = group.contact;
    size_t best = old.size();
    double bestDot = kSameGroup;
    for (size_t k = 0; k < old.size(); ++k) {
      const Contact& o = old[k].contact;
      const double d = glm::dot(g.normal, o.a == g.a ? o.normal : -o.normal);
      if (!inherited[k] && d >= bestDot) {
        best = k;
        bestDot = d;
      }
    }
    if (best == old.size()) continue;
    inherited[best] = 1;
    FrictionTotals t = old[best].totals;
    if (old[best].contact.a != g.a) t.tangential = -t.tangential;  // impulses are on b
    group.totals = t;
  }
}

// A new look at pair pi's geometry at poses pa, pb: its groups (after the step's first look, inheriting the
// old groups' totals), their levers, matrices, patch matrices and normal speeds.
// `from`: the velocities the poses were predicted from (kKept: the bodies' current ones, kept for stillAtLook).
void refreshGroups(StepContext& ctx, size_t pi, const PoseFrame& frameA, const PoseFrame& frameB, bool reuse,
                   bool first, StepContext::LookVelocities::Kind from, ContactScratch& s) {
  const Pair& pair = ctx.pairs[pi];
  StepContext::LookVelocities& look = ctx.lookVelocities[pi];
  look.kind = from;
  if (from == StepContext::LookVelocities::kKept) {
    const RigidBody& A = ctx.body(pair.a);
    const RigidBody& B = ctx.body(pair.b);
    look = {A.v, A.w, B.v, B.w, from};
  }
  const Pose& pa = frameA.pose;
  const Pose& pb = frameB.pose;
  const std::vector<Contact>* contacts = &s.fresh;
  ctx.lookPoses[pi] = {pa, pb};
  if (reuse) {
    contacts = &ctx.found[pi];
  } else {
    lookAtPair(ctx, ctx.pairs[pi], frameA, frameB, s.fresh);
  }
  ctx.lookCount[pi] = static_cast<int>(contacts->size());  // this look's points (StepStats::contacts)
  std::vector<ContactGroup>& groups = ctx.groups[pi];
  if (first) {
    // The step's first look: nothing to inherit. The vector's elements (a pair's of an earlier step) are written
    // over in place: a new group is nearly a kilobyte to zero.
    groupContacts(*contacts, groups);
  } else {
    s.old.swap(groups);
    groupContacts(*contacts, groups);
    inheritTotals(s.old, groups, s.inherited);
  }
  for (ContactGroup& g : groups) {
    const Contact& c = g.contact;
    // The levers at the poses the geometry was found at: measured from the
    // current centres, a point found ahead by h v would turn sliding into
    // a spurious normal velocity (a rolling ball would brake).
    g.levers = levers(c, c.a == pair.a ? pa : pb, c.b == pair.b ? pb : pa);
    ImpulseSide sa, sb;
    ctx.sidesAt(c.a, c.b, g.levers, false, false, sa, sb);
    glm::dmat3 coupling;
    g.matrix = ImpulseMatrix(collisionMatrix(sa, sb, &coupling));
    setPatchMatrix(g.patchMatrix, sa, sb, g.matrix, coupling);
    g.speed = glm::dot(ctx.relativeVelocity(c.a, c.b, g.levers), c.normal);
  }
}

}  // namespace

// Whether pair pi's predicted poses are, by a bound from the velocities alone, within half the refresh tolerance
// of its last look's (the relative offset moved by h |dv_B - dv_A|, each body's points near the other by its
// turn's angle times its reach): then the exact test (displacementExceeds, at most pi/(2 sqrt 2) ~ 1.11 times
// the angle per reach) would not look either, and neither pose is predicted. Positions and orientations stay
// put through the contact step; only velocities change, and a prediction turns every body by exp(h w)
// (StepContext::predict).
bool ContactRun::stillAtLook(size_t pi) const {
  const StepContext& ctx = ctx_;
  const StepContext::LookVelocities& look = ctx.lookVelocities[pi];
  if (look.kind == StepContext::LookVelocities::kUnknown) return false;
  const bool atStart = look.kind == StepContext::LookVelocities::kAtStart;
  const Pair& pair = ctx.pairs[pi];
  glm::dvec3 offset(0);
  double swing = 0, reaches = 0;
  for (int side = 0; side < 2; ++side) {
    const int i = side ? pair.b : pair.a;
    const RigidBody& b = ctx.body(i);
    if (!b.movable()) continue;  // (its pose is where it is, both times)
    const glm::dvec3& v = atStart ? v0_[static_cast<size_t>(i)] : (side ? look.vb : look.va);
    const glm::dvec3& w = atStart ? w0_[static_cast<size_t>(i)] : (side ? look.wb : look.wa);
    const glm::dvec3 dv = b.v - v, dw = b.w - w;
    offset += side ? dv : -dv;
    const double reach = reachAboutCom(b);
    reaches += reach;
    swing += glm::length(dw) * reach;
  }
  // (The exact test's own rounding: an angle from 1 - |q1.q2| reads ~1e-8 rad where there is none.)
  const double bound = h_ * (glm::length(offset) + 1.2 * swing) + 1e-6 * (1 + reaches);
  return bound <= 0.5 * ctx.settings.contactRefreshTolerance;
}

namespace {

// One pass's impulses on pair pi's groups, with restitution eps and friction mu. Adds the
// normal impulse at the deepest group to `pushed` when asked.
void solvePair(StepContext& ctx, size_t pi, double eps, double mu, double* pushed) {
  std::vector<ContactGroup>& groups = ctx.groups[pi];
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    ContactGroup& g = groups[gi];
    const Contact& c = g.contact;
    const glm::dvec3 u = ctx.relativeVelocity(c.a, c.b, g.levers);
    glm::dvec3 j, torque;
    if (patchImpulse(g.patchMatrix, g.matrix, u, ctx.relativeSpin(c.a, c.b), c.normal, eps, mu, &g.totals, j, torque)) {
      ctx.applyImpulse(c.a, c.b, g.levers, j, torque);
    } else {
      j = frictionImpulse(g.matrix, u, c.normal, eps, mu, &g.totals);
      if (glm::dot(j, j) > 0) ctx.applyImpulse(c.a, c.b, g.levers, j);
    }
    if (pushed && gi == 0) *pushed += glm::dot(j, c.normal);
  }
}

// One report per pair the step pushed apart, at its deepest group.
void reportContacts(StepContext& ctx, const std::vector<double>& pushed) {
  for (size_t pi = 0; pi < ctx.pairs.size(); ++pi) {
    const std::vector<ContactGroup>& groups = ctx.groups[pi];
    if (groups.empty() || !(pushed[pi] > 0)) continue;
    const Contact& c = groups.front().contact;
    const RigidBody& A = ctx.body(c.a);
    const RigidBody& B = ctx.body(c.b);
    CollisionEvent e = eventAt(c, ctx.time, {A.x, A.q}, {B.x, B.q});
    e.impulse = pushed[pi];
    e.impulseVector = e.normal * pushed[pi];
    e.elasticImpulse = 2 * pushed[pi];
    ctx.contactReports.push_back(e);
  }
}

}  // namespace

ContactRun::ContactRun(StepContext& ctx, double h) : ctx_(ctx), h_(h), scratch_(static_cast<size_t>(ctx.workers())) {
  // Contact geometry on the positions predicted with the current velocities.
  // Re-finding it costs most of the step; it changes little from one pass to
  // the next, so it is refreshed every `contactRefresh` passes, and then only
  // for pairs whose predicted poses moved (impulses always use the current
  // velocities).
  const size_t pairs = ctx.pairs.size();
  ctx.pairApproach.assign(pairs, 0.0);
  // Every pair is in one island, and an island's first pass looks at each of its pairs (or clears its groups):
  // the groups of an earlier step are not read, only their storage reused.
  ctx.groups.resize(pairs);
  ctx.lookPoses.resize(pairs);
  ctx.lookVelocities.resize(pairs);
  ctx.lookCount.assign(pairs, 0);
  reporting_ = !ctx.reportContacts.empty();
  pushed_.assign(reporting_ ? pairs : 0, 0.0);
  run_ = ++ctx.contactRuns;
  ctx.contactPredicted.resize(ctx.bodies.size());
  resting_ = ctx.settings.restingSolveRows > 0;
  v0_.resize(ctx.bodies.size());
  w0_.resize(ctx.bodies.size());
}

// ctx.predict(body, h, false), kept while the body's velocities stay the same bits.
const PoseFrame& ContactRun::predict(size_t i) {
  const RigidBody& b = ctx_.bodies[i];
  // (A static body is in many islands: nothing is kept for it here. findPairs' prediction of this substep is
  // where it is, {x, q}.)
  if (!b.movable()) return ctx_.predicted[i];
  StepContext::ContactPrediction& p = ctx_.contactPredicted[i];
  if (p.run == run_ && std::memcmp(&p.v, &b.v, sizeof p.v) == 0 && std::memcmp(&p.w, &b.w, sizeof p.w) == 0)
    return p.frame;
  p = {b.v, b.w, PoseFrame(ctx_.predict(b, h_, false)), run_};
  return p.frame;
}

void ContactRun::start() {
  for (size_t i = 0; i < ctx_.bodies.size(); ++i) startBody(i);
}

void ContactRun::startBody(size_t i) {
  v0_[i] = ctx_.bodies[i].v;
  w0_[i] = ctx_.bodies[i].w;
}

// Island by island (islands.cpp; in parallel on the World's threads): each
// island's pairs in the order of the sweep over all pairs.
void ContactRun::island(size_t island, int worker) {
  StepContext& ctx = ctx_;
  const std::vector<Pair>& pairs = ctx.pairs;
  const int n = std::max(1, ctx.settings.contactPasses);
  const int refresh = std::max(1, ctx.settings.contactRefresh);
  ContactScratch& s = scratch_[static_cast<size_t>(worker)];
  const uint32_t* first = ctx.islandPairs.data() + ctx.islandStart[island];
  const size_t count = ctx.islandStart[island + 1] - ctx.islandStart[island];
  // Each pair's friction, once for all passes.
  s.mu.resize(count);
  for (size_t k = 0; k < count; ++k) {
    const Pair& pair = pairs[first[k]];
    s.mu[k] = std::sqrt(ctx.body(pair.a).friction * ctx.body(pair.b).friction);
  }
  for (int pass = 1; pass <= n; ++pass) {
    const double eps = -1.0 + static_cast<double>(pass) / n;
    const bool find = (pass - 1) % refresh == 0;
    // Alternate sweeps (forward, then backward): a one-way order pushes every
    // stack the same way, a little each pass. Between finds only the pairs with
    // contact groups are visited (the others have nothing to solve), in the same order.
    if (find) s.touching.clear();
    const size_t visits = find ? count : s.touching.size();
    for (size_t k = 0; k < visits; ++k) {
      const size_t at = find ? (pass % 2 ? k : count - 1 - k) : s.touching[pass % 2 ? k : visits - 1 - k];
      const size_t pi = first[at];
      const Pair& pair = pairs[pi];
      if (find && !mayTouch(ctx, pair)) {  // (nothing to find: no groups, no pose predicted)
        ctx.groups[pi].clear();
        ctx.lookCount[pi] = 0;
        continue;
      }
      if (find) {
        // The collision step's last look at this pair was at the poses the
        // first pass predicts now (x + h (v + h a) either way) if no impulse
        // has touched either body since: its contacts are reused, with the
        // poses they were found at (levers must match the geometry). Fresh
        // contacts are found at the poses the current velocities predict.
        const std::pair<uint32_t, uint32_t> now{ctx.version[static_cast<size_t>(pair.a)],
                                                ctx.version[static_cast<size_t>(pair.b)]};
        const bool reuse = pass == 1 && pi < ctx.foundVersion.size() && ctx.foundVersion[pi] == now;
        // A refresh re-finds the geometry only where the predicted poses have moved since the last look;
        // resting contact keeps its groups (their depths follow to first order, endOfStepDepths). Most pairs
        // are told so by their velocities (stillAtLook) before any pose is predicted.
        if (pass == 1 || !stillAtLook(pi)) {
          const PoseFrame& frameA =
              reuse ? ctx.predicted[static_cast<size_t>(pair.a)] : predict(static_cast<size_t>(pair.a));
          const PoseFrame& frameB =
              reuse ? ctx.predicted[static_cast<size_t>(pair.b)] : predict(static_cast<size_t>(pair.b));
          bool look = true;
          if (pass > 1) {
            const double tolerance = ctx.settings.contactRefreshTolerance;
            look = displacementExceeds(ctx.lookPoses[pi].first, frameA.pose, reachAboutCom(ctx.body(pair.a)),
                                       ctx.lookPoses[pi].second, frameB.pose, reachAboutCom(ctx.body(pair.b)),
                                       [&](double moved) { return moved > tolerance; });
          }
          if (look) {
            using Velocities = StepContext::LookVelocities;
            const Velocities::Kind from = !reuse         ? Velocities::kKept
                                          : reusedKnown_ ? Velocities::kAtStart
                                                         : Velocities::kUnknown;
            refreshGroups(ctx, pi, frameA, frameB, reuse, pass == 1, from, s);
          }
        }
        if (ctx.groups[pi].empty()) continue;
        if (pass == 1)
          for (const ContactGroup& g : ctx.groups[pi]) ctx.pairApproach[pi] = std::max(ctx.pairApproach[pi], -g.speed);
        s.touching.push_back(static_cast<uint32_t>(at));
      }
      const bool report = reporting_ && (ctx.reportContacts[static_cast<size_t>(pair.a)] ||
                                         ctx.reportContacts[static_cast<size_t>(pair.b)]);
      solvePair(ctx, pi, eps, s.mu[at], report ? &pushed_[pi] : nullptr);
    }
    if (find && pass % 2 == 0) std::reverse(s.touching.begin(), s.touching.end());  // (in island order)
  }
}

void ContactRun::finish() {
  if (resting_) restingSolve(ctx_, v0_, w0_, h_);
  for (int c : ctx_.lookCount) ctx_.stats.contacts += c;  // each pair's last look
  if (reporting_) reportContacts(ctx_, pushed_);
}

void contactStep(StepContext& ctx, double h) {
  ContactRun run(ctx, h);
  run.start();
  ctx.forEachIsland([&](size_t island, int worker) { run.island(island, worker); });
  run.finish();
}

}  // namespace crumple::detail
