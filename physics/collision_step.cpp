// Collision step (Guendelman et al. 2003, section 7.1): restitution impulses on
// the positions predicted with this substep's forces.
//
// Guarantees:
// - Up to `collisionPasses` passes over the pairs (in pair order), each pair up
//   to `collisionIterations` times: while some contact at the predicted poses
//   approaches faster than gravity adds in one substep (g h), an impulse with
//   restitution min(eps_A, eps_B) and friction acts at the centre of its group.
//   Slower approaches are resting contact, left to the contact step. Stops
//   early after a pass that applied nothing.
// - At most one CollisionEvent per pair and substep, for a hit approaching at
//   eventMinApproachSpeed or faster, carrying the first hit's geometry, the
//   elastic impulses of its hits from that one on and the sum of the pair's
//   impulses; stats.collisions counts them.
//   The elastic impulse treats a body welded to the world (ctx.anchored) as
//   immovable: while its welds hold it is part of what it is welded to.
// - The pairs run island by island (islands.cpp; in parallel on the World's
//   threads): the same impulses, in the same order per body, and the same
//   events in the same order as one sweep over all pairs.
// - collisionsCarried (after shock propagation): a hit the passes could not
//   stop (stages.h) gets, in its pair's event, what the contact step and shock
//   propagation pushed the pair apart with; a body held still by shock
//   propagation passes what it took on to its supports, level by level down.
// - ctx.found / ctx.foundVersion: each pair's last contacts and the impulse
//   counts they were found at; ctx.predicted stays valid for bodies whose
//   version has not moved (the contact step's first pass reuses both).
#include <algorithm>
#include <limits>

#include <crumple/physics/step_context.h>

namespace crumple::detail {

CollisionRun::CollisionRun(StepContext& ctx, double h)
    : ctx_(ctx), h_(h), eventOfPair_(ctx.pairs.size(), -1), workers_(static_cast<size_t>(ctx.workers())) {
  // A pair whose two bodies kept their velocities since it was last checked
  // would find the same (no) collision again: skip it. Exact, so runs stay
  // bit-identical; it saves the repeated passes most of their work. Only
  // movable bodies count their impulses (a static one's velocity never
  // changes), so islands never write a shared counter.
  ctx.version.assign(ctx.bodies.size(), 0);
  ctx.foundVersion.assign(ctx.pairs.size(), {UINT32_MAX, UINT32_MAX});
  ctx.found.resize(ctx.pairs.size());
}

// Each island on its own (islands.cpp): a pass over all pairs that applied
// nothing in an island left every pair of it seen at its bodies' versions,
// so the island's later passes would skip every pair; the island stops.
void CollisionRun::island(size_t island, int worker) {
  StepContext& ctx = ctx_;
  const double h = h_;
  const WorldSettings& settings = ctx.settings;
  const std::vector<Pair>& pairs = ctx.pairs;
  const double restingSpeed = glm::length(settings.gravity) * h;
  std::vector<uint32_t>& version = ctx.version;
  std::vector<std::pair<uint32_t, uint32_t>>& seen = ctx.foundVersion;
  // Each body's predicted pose (findPairs made the first), kept while no
  // impulse has changed its velocity.
  auto predicted = [&](int i) -> const PoseFrame& {
    const size_t k = static_cast<size_t>(i);
    if (ctx.predictedVersion[k] != version[k]) {
      ctx.predicted[k] = PoseFrame(ctx.predict(ctx.bodies[k], h, true));
      ctx.predictedVersion[k] = version[k];
    }
    return ctx.predicted[k];
  };
  std::vector<PendingEvent>& events = workers_[static_cast<size_t>(worker)].events;
  const uint32_t* first = ctx.islandPairs.data() + ctx.islandStart[island];
  const uint32_t* last = ctx.islandPairs.data() + ctx.islandStart[island + 1];
  for (int pass = 0; pass < settings.collisionPasses; ++pass) {
    bool passAny = false;
    for (const uint32_t* p = first; p != last; ++p) {
      const size_t pi = *p;
      const int ia = pairs[pi].a, ib = pairs[pi].b;
      const std::pair<uint32_t, uint32_t> now{version[static_cast<size_t>(ia)], version[static_cast<size_t>(ib)]};
      if (seen[pi] == now) continue;
      if (!mayTouch(ctx, pairs[pi])) {  // (nothing to find: no look, no pose predicted)
        ctx.found[pi].clear();
        seen[pi] = now;
        continue;
      }
      for (int it = 0; it < settings.collisionIterations; ++it) {
        const RigidBody& A = ctx.body(ia);
        const RigidBody& B = ctx.body(ib);
        const PoseFrame& frameA = predicted(ia);
        const PoseFrame& frameB = predicted(ib);
        const Pose& pa = frameA.pose;
        const Pose& pb = frameB.pose;
        std::vector<Contact>& contacts = ctx.found[pi];
        lookAtPair(ctx, ctx.pairs[pi], frameA, frameB, contacts);
        seen[pi] = {version[static_cast<size_t>(ia)], version[static_cast<size_t>(ib)]};
        const Contact* hit = nullptr;
        double approach = 0;
        // Levers from the centres of mass at the poses the contacts were found at.
        auto leversOf = [&](const Contact& c) { return levers(c, c.a == ia ? pa : pb, c.b == ib ? pb : pa); };
        for (const Contact& c : contacts) {
          const glm::dvec3 u = ctx.relativeVelocity(c.a, c.b, leversOf(c));
          // Approaches slower than gravity adds in one step are resting contact:
          // the contact step handles them (no restitution, no event).
          if (glm::dot(u, c.normal) < -restingSpeed) {
            hit = &c;
            approach = -glm::dot(u, c.normal);
            break;
          }
        }
        if (!hit) break;
        // The impulse acts at the centre of the hit's group: the approaching
        // points whose normals agree with the hit's, weighted by depth (as the
        // contact step's groups). A box landing flat on another presses with
        // its whole face; an impulse at whichever equally deep corner sorts
        // first would spin it, and a tower of such landings leans and falls.
        Contact at = *hit;
        {
          GroupSum group{*hit};
          for (const Contact& c : contacts)
            if (group.agrees(c) && glm::dot(ctx.relativeVelocity(c.a, c.b, leversOf(c)), c.normal) < 0) group.add(c);
          if (group.weight > 0) {
            at = group.result();
            if (glm::dot(ctx.relativeVelocity(at.a, at.b, leversOf(at)), at.normal) >= 0) at = *hit;
          }
        }
        const double eps = std::min(A.restitution, B.restitution);
        double elastic = 0;
        const Levers hitLevers = leversOf(at);
        const glm::dvec3 j = ctx.contactImpulse(at.a, at.b, at, hitLevers, eps, false, false, &elastic);
        if (!ctx.anchored.empty()) {
          // A body welded to the world is, while its welds hold, part of it: the
          // elastic impulse (the deformation's |j_eps=1|) sees it as immovable.
          const bool fa = ctx.anchored[static_cast<size_t>(at.a)] != 0, fb = ctx.anchored[static_cast<size_t>(at.b)] != 0;
          // (Only against a body that impulses move: a kinematic hammer meeting a welded block keeps its own.)
          const bool otherMoves = fa ? ctx.body(at.b).dynamic() : ctx.body(at.a).dynamic();
          if (fa != fb && otherMoves) {
            const glm::dmat3 K = ctx.collisionMatrixAt(at.a, at.b, hitLevers, fa, fb);
            elastic = glm::length(frictionlessImpulse(K, ctx.relativeVelocity(at.a, at.b, hitLevers), at.normal, 1.0));
          }
        }
        if (glm::dot(j, j) == 0) break;
        ctx.applyImpulse(at.a, at.b, hitLevers, j);
        if (A.movable()) ++version[static_cast<size_t>(ia)];
        if (B.movable()) ++version[static_cast<size_t>(ib)];
        passAny = true;
        int& ev = eventOfPair_[pi];
        const bool later = ev >= 0;
        if (ev < 0 && approach >= settings.eventMinApproachSpeed) {
          PendingEvent& pe = events.emplace_back();
          pe.pass = pass;
          pe.pair = pi;
          pe.event = eventAt(*hit, ctx.time, hit->a == ia ? pa : pb, hit->a == ia ? pb : pa);
          pe.event.elasticImpulse = elastic;
          ev = static_cast<int>(events.size() - 1);
        }
        if (ev < 0) continue;
        CollisionEvent& e = events[static_cast<size_t>(ev)].event;
        e.impulseVector += hit->a == e.a ? j : -j;
        e.impulse = glm::length(e.impulseVector);
        // A pair hit again in the substep (a light body pinned between two, struck back and forth) adds each hit's
        // |j_eps=1|: the elastic impulse is never less than what the hits applied.
        if (later) e.elasticImpulse += elastic;
      }
    }
    if (passAny) workers_[static_cast<size_t>(worker)].any = true;
    if (!passAny) break;
  }
}

bool CollisionRun::finish() {
  // The events in the order one sweep over all pairs makes them: by pass, then pair.
  std::vector<PendingEvent> merged;
  for (WorkerState& w : workers_)
    for (PendingEvent& e : w.events) merged.push_back(std::move(e));
  std::sort(merged.begin(), merged.end(),
            [](const PendingEvent& x, const PendingEvent& y) { return x.pass != y.pass ? x.pass < y.pass : x.pair < y.pair; });
  ctx_.eventOfPair.assign(ctx_.pairs.size(), -1);
  for (const PendingEvent& e : merged) {
    ctx_.eventOfPair[e.pair] = static_cast<int>(ctx_.events.size());
    ctx_.events.push_back(e.event);
  }
  for (int ev : eventOfPair_) ctx_.stats.collisions += ev >= 0;
  return std::any_of(workers_.begin(), workers_.end(), [](const WorkerState& w) { return w.any; });
}

void collisionsCarried(StepContext& ctx, double h) {
  const size_t np = ctx.pairs.size();
  if (ctx.pairApproach.size() != np || ctx.eventOfPair.size() != np || ctx.shockPush.size() != np) return;
  const double fast = std::max(ctx.settings.eventMinApproachSpeed, 2 * glm::length(ctx.settings.gravity) * h);
  std::vector<size_t>& hit = ctx.carriedPairs;
  hit.clear();
  for (size_t pi = 0; pi < np; ++pi)
    if (!ctx.groups[pi].empty() && (ctx.eventOfPair[pi] >= 0 || ctx.pairApproach[pi] >= fast)) hit.push_back(pi);
  if (hit.empty()) return;
  // Only in an island that a blow struck, and no more than its momentum. Struck: some pair's contacts approached
  // faster than that at the step's start (the velocities then, at the contacts' points). Its momentum: the largest,
  // over those pairs, of the speed times the heavier dynamic body's mass, or, where more, what the island's dynamic
  // bodies that moved that fast carried together (a ball and the crate under it landing together: the crate's
  // landing carries the ball's momentum); without bound where a kinematic body drives (moves at its contact that
  // fast: a parked one is as static). A heavy body resting on a light one has the collision passes kick the light
  // one into the ground at every substep; its weight is no blow.
  std::vector<double>& blow = ctx.carriedBlow;
  blow.assign(ctx.islandCount(), -1.0);  // -1: not yet looked at
  std::vector<size_t>& seen = ctx.carriedSeen;
  seen.assign(ctx.bodies.size(), 0);
  auto momentum = [&](const Contact& c) {
    const BodyState& A = ctx.stepBefore[static_cast<size_t>(c.a)];
    const BodyState& B = ctx.stepBefore[static_cast<size_t>(c.b)];
    const glm::dvec3 va = A.v + glm::cross(A.w, c.point - A.x), vb = B.v + glm::cross(B.w, c.point - B.x);
    const double speed = -glm::dot(vb - va, c.normal);
    if (!(speed >= fast)) return 0.0;
    double mass = 0;
    for (int i : {c.a, c.b}) {
      const RigidBody& b = ctx.body(i);
      if (b.kinematic && glm::length(i == c.a ? va : vb) >= fast) return std::numeric_limits<double>::infinity();
      if (b.dynamic()) mass = std::max(mass, b.mass);
    }
    return speed * mass;
  };
  auto moving = [&](size_t island) {  // the island's dynamic bodies' momentum, of those moving `fast` or faster
    double sum = 0;
    for (uint32_t k = ctx.islandStart[island]; k < ctx.islandStart[island + 1]; ++k)
      for (int i : {ctx.pairs[ctx.islandPairs[k]].a, ctx.pairs[ctx.islandPairs[k]].b}) {
        const RigidBody& b = ctx.body(i);
        if (!b.dynamic() || seen[static_cast<size_t>(i)] == island + 1) continue;
        seen[static_cast<size_t>(i)] = island + 1;
        const double speed = glm::length(ctx.stepBefore[static_cast<size_t>(i)].v);
        if (speed >= fast) sum += speed * b.mass;
      }
    return sum;
  };
  auto blowOf = [&](size_t pi) {  // at the contact step's groups and the collision step's last contacts
    double most = 0;
    for (const ContactGroup& g : ctx.groups[pi]) most = std::max(most, momentum(g.contact));
    for (const Contact& c : ctx.found[pi]) most = std::max(most, momentum(c));
    return most;
  };
  bool absorbed = false;
  size_t kept = 0;
  for (size_t pi : hit) {
    const size_t island = static_cast<size_t>(ctx.islandOfPair[pi]);
    if (blow[island] < 0) {
      blow[island] = 0;
      for (uint32_t k = ctx.islandStart[island]; k < ctx.islandStart[island + 1]; ++k)
        blow[island] = std::max(blow[island], blowOf(ctx.islandPairs[k]));
      if (blow[island] > 0) blow[island] = std::max(blow[island], moving(island));
    }
    if (!(blow[island] > 0)) continue;
    hit[kept++] = pi;
    for (int b : {ctx.pairs[pi].a, ctx.pairs[pi].b})
      absorbed = absorbed || ctx.shockAbsorbed[static_cast<size_t>(b)] > 0;
  }
  hit.resize(kept);
  if (hit.empty()) return;
  // Each pair's push: the contact step's and its island solve's totals, and shock propagation's.
  auto pushOf = [&](size_t pi) {
    double push = ctx.shockPush[pi];
    for (const ContactGroup& g : ctx.groups[pi]) push += g.totals.normal;
    return push;
  };
  // What a body took while frozen in shock propagation it passes on to what holds it up (its pairs with bodies of
  // lower levels, by their pushes; evenly where none pushed), level by level from the top: a crate crushed between a
  // heavy ball and the ground stops the ball frozen, and the ground is what takes the blow.
  std::vector<double>& carried = ctx.carriedPush;
  carried.assign(absorbed ? np : 0, 0.0);
  if (absorbed) {
    const std::vector<int>& level = ctx.level;
    int top = 0;
    for (size_t i = 0; i < ctx.bodies.size(); ++i)
      if (ctx.shockAbsorbed[i] > 0) top = std::max(top, level[i]);
    std::vector<std::vector<size_t>>& supports = ctx.carriedSupports;  // by the upper body's level
    supports.resize(static_cast<size_t>(top) + 1);
    for (std::vector<size_t>& s : supports) s.clear();
    for (size_t pi = 0; pi < np; ++pi) {
      if (ctx.groups[pi].empty()) continue;
      const int la = level[static_cast<size_t>(ctx.pairs[pi].a)], lb = level[static_cast<size_t>(ctx.pairs[pi].b)];
      if (la < 0 || lb < 0 || la == lb || std::max(la, lb) > top) continue;
      supports[static_cast<size_t>(std::max(la, lb))].push_back(pi);
    }
    std::vector<double>& take = ctx.shockAbsorbed;
    // Per upper body of a level: the sum of its supports' weights and their count (zero again after each level).
    std::vector<double>& weight = ctx.carriedWeight;
    weight.assign(ctx.bodies.size(), 0.0);
    std::vector<int>& count = ctx.carriedCount;
    count.assign(ctx.bodies.size(), 0);
    auto upper = [&](size_t pi) {
      const int a = ctx.pairs[pi].a, b = ctx.pairs[pi].b;
      return level[static_cast<size_t>(a)] > level[static_cast<size_t>(b)] ? a : b;
    };
    for (int l = top; l >= 1; --l) {
      const std::vector<size_t>& below = supports[static_cast<size_t>(l)];
      for (size_t pi : below) {
        const size_t u = static_cast<size_t>(upper(pi));
        if (!(take[u] > 0)) continue;
        weight[u] += std::max(pushOf(pi), 0.0);
        ++count[u];
      }
      for (size_t pi : below) {
        const size_t u = static_cast<size_t>(upper(pi));
        if (!(take[u] > 0)) continue;
        const double share = weight[u] > 0 ? std::max(pushOf(pi), 0.0) / weight[u] : 1.0 / count[u];
        const double pass = take[u] * share;
        carried[pi] += pass;
        const size_t other = static_cast<size_t>(ctx.pairs[pi].a) == u ? static_cast<size_t>(ctx.pairs[pi].b)
                                                                       : static_cast<size_t>(ctx.pairs[pi].a);
        if (level[other] >= 1) take[other] += pass;
      }
      for (size_t pi : below) {
        const size_t u = static_cast<size_t>(upper(pi));
        weight[u] = 0;
        count[u] = 0;
      }
    }
  }
  for (size_t pi : hit) {
    const double push = std::min(pushOf(pi) + (absorbed ? carried[pi] : 0.0),
                                 blow[static_cast<size_t>(ctx.islandOfPair[pi])]);
    if (!(push > 0)) continue;
    const Contact& c = ctx.groups[pi].front().contact;
    if (ctx.eventOfPair[pi] < 0) {
      // At the poses the contact was found at (its depth is theirs).
      const bool same = c.a == ctx.pairs[pi].a;
      ctx.eventOfPair[pi] = static_cast<int>(ctx.events.size());
      ctx.events.push_back(eventAt(c, ctx.time, same ? ctx.lookPoses[pi].first : ctx.lookPoses[pi].second,
                                   same ? ctx.lookPoses[pi].second : ctx.lookPoses[pi].first));
      ++ctx.stats.collisions;
    }
    CollisionEvent& e = ctx.events[static_cast<size_t>(ctx.eventOfPair[pi])];
    e.impulseVector += (c.a == e.a ? push : -push) * c.normal;
    e.impulse = glm::length(e.impulseVector);
    e.elasticImpulse += 2 * push;
  }
}

bool collide(StepContext& ctx, double h) {
  CollisionRun run(ctx, h);
  ctx.forEachIsland([&](size_t island, int worker) { run.island(island, worker); });
  return run.finish();
}

}  // namespace crumple::detail
