// The order of the stages in a step and a substep (World::step, World::substep, World::collideAndContact), with
// the step's refusal of a non-finite state. The stages themselves live one per file (physics/stages.h lists
// them); the World's API is in world.cpp.
#include <crumple/physics/world.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include <crumple/physics/step_context.h>
#include <crumple/physics/thread_pool.h>

namespace crumple {

using detail::finite;

namespace {
// Bodies per item of the per-body loops that run on the pool.
constexpr size_t kBodyGrain = 256;

// Adds the milliseconds since `since` to `ms` and restarts the clock.
class StageClock {
 public:
  void lap(double& ms) {
    const auto now = std::chrono::steady_clock::now();
    ms += std::chrono::duration<double, std::milli>(now - since_).count();
    since_ = now;
  }

 private:
  std::chrono::steady_clock::time_point since_ = std::chrono::steady_clock::now();
};
}  // namespace

namespace {
// Whether no body can move (each static or asleep: kinematic bodies move, and one at rest still makes pairs with
// what is awake), no joint is left (a joint's stabilisation reads its bodies every substep) and the last step
// ended with no pair (its Verlet lists and kept contacts wait in ctx.previousPairs for the bodies to wake).
bool stillWorld(const detail::StepContext& ctx) {
  if (!ctx.pairs.empty() || !ctx.joints.empty()) return false;
  return std::none_of(ctx.bodies.begin(), ctx.bodies.end(), [](const RigidBody& b) { return b.movable(); });
}

bool finiteState(const RigidBody& b) {
  return finite(b.x) && finite(b.v) && finite(b.w) && finite(b.q);
}

// After the substeps: every body's state finite, or the step undone (StepStatus).
StepStatus checkFinite(detail::StepContext& ctx, const std::vector<detail::BodyState>& before, double timeBefore) {
  std::vector<int> first(static_cast<size_t>(ctx.workers()), -1);  // per worker: its lowest non-finite body
  ctx.parallelRange(ctx.bodies.size(), kBodyGrain, [&](size_t begin, size_t end, int worker) {
    int& f = first[static_cast<size_t>(worker)];
    // (A static or sleeping body did not move: it is as finite as it was at the last step's end.)
    for (size_t i = begin; i < end; ++i)
      if (ctx.bodies[i].movable() && !finiteState(ctx.bodies[i]) && (f < 0 || static_cast<int>(i) < f))
        f = static_cast<int>(i);
  });
  int bad = -1;
  for (int f : first)
    if (f >= 0 && (bad < 0 || f < bad)) bad = f;
  StepStatus status;
  if (bad < 0) return status;
  for (size_t i = 0; i < ctx.bodies.size(); ++i) {
    RigidBody& b = ctx.bodies[i];
    b.x = before[i].x;
    b.q = before[i].q;
    b.v = before[i].v;
    b.w = before[i].w;
  }
  // What the step found and kept is dropped with it: pairs, manifolds, events, reports, breaks.
  ctx.pairs.clear();
  ctx.previousPairs.clear();
  ctx.events.clear();
  ctx.contactReports.clear();
  ctx.jointBreaks.clear();
  ctx.time = timeBefore;
  const detail::BodyState& last = before[static_cast<size_t>(bad)];
  status.ok = false;
  status.body = bad;
  status.lastPose = {last.x, last.q};
  status.lastVelocity = last.v;
  status.lastAngularVelocity = last.w;
  return status;
}
}  // namespace

void World::collideAndContact(double h) {
  detail::StepContext& ctx = *ctx_;
  const auto start = std::chrono::steady_clock::now();
  detail::CollisionRun collision(ctx, h);
  detail::ContactRun contact(ctx, h);
  contact.reusedPosesAtVelocities();  // (each island's velocities are integrated between its two steps, below)
  // A movable body is in one island at most (islands.cpp): its velocities are integrated there, once.
  std::vector<char>& done = ctx.integrated;
  done.assign(ctx.bodies.size(), 0);
  // Per worker (a cache line each): seconds in the collision step and in all, for the stage profile.
  struct alignas(64) Seconds {
    double collide = 0, all = 0;
  };
  std::vector<Seconds> seconds(static_cast<size_t>(ctx.workers()));
  ctx.forEachIsland([&](size_t island, int worker) {
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    collision.island(island, worker);
    const auto t1 = Clock::now();
    for (uint32_t k = ctx.islandStart[island]; k < ctx.islandStart[island + 1]; ++k) {
      const detail::Pair& p = ctx.pairs[ctx.islandPairs[k]];
      for (int i : {p.a, p.b}) {
        const size_t b = static_cast<size_t>(i);
        if (done[b] || !ctx.bodies[b].movable()) continue;
        done[b] = 1;
        detail::integrateVelocity(ctx, b, h);
        contact.startBody(b);
      }
    }
    contact.island(island, worker);
    Seconds& t = seconds[static_cast<size_t>(worker)];
    t.collide += std::chrono::duration<double>(t1 - t0).count();
    t.all += std::chrono::duration<double>(Clock::now() - t0).count();
  });
  collision.finish();
  ctx.parallelRange(ctx.bodies.size(), kBodyGrain, [&](size_t begin, size_t end, int) {
    for (size_t b = begin; b < end; ++b) {
      if (done[b]) continue;
      detail::integrateVelocity(ctx, b, h);
      contact.startBody(b);
    }
  });
  contact.finish();
  // The stage profile: the wall time split as the workers' time was.
  const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  double collideTime = 0, islandTime = 0;
  for (const Seconds& t : seconds) {
    collideTime += t.collide;
    islandTime += t.all;
  }
  const double share = islandTime > 0 ? collideTime / islandTime : 0.0;
  ctx.stats.ms.collide += wall * share;
  ctx.stats.ms.contact -= wall * share;  // the caller laps the whole as the contact step's
}

void World::substep(double h) {
  detail::StepContext& ctx = *ctx_;
  StepProfile& ms = ctx.stats.ms;
  StageClock clock;
  // Rotations and world inverse inertias: orientations stay fixed until the position update.
  // A static or sleeping body keeps those it has while its orientation stays the same bits (it moves only once it
  // wakes, in a later substep's position update).
  const double none = std::numeric_limits<double>::quiet_NaN();
  ctx.rotation.resize(ctx.bodies.size());
  ctx.invInertia.resize(ctx.bodies.size());
  ctx.rotationAt.resize(ctx.bodies.size(), glm::dquat(none, none, none, none));
  ctx.parallelRange(ctx.bodies.size(), kBodyGrain, [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      const RigidBody& b = ctx.bodies[i];
      if (!b.movable() && std::memcmp(&ctx.rotationAt[i], &b.q, sizeof b.q) == 0) continue;
      const glm::dmat3 r = b.rotation();
      ctx.rotation[i] = r;
      ctx.invInertia[i] = b.invInertiaAt(r);
      if (!b.movable()) ctx.rotationAt[i] = b.q;  // (a body that moves turns: no key kept)
    }
  });
  ctx.invInertiaNow = true;
  detail::findPairs(ctx, h);
  ctx.stats.pairs += static_cast<int>(ctx.pairs.size());
  for (detail::Pair& p : ctx.pairs) p.looks = p.keptLooks = p.clearLooks = 0;
  detail::findIslands(ctx);
  clock.lap(ms.broadPhase);
  detail::findCandidates(ctx, h);
  clock.lap(ms.candidates);
  detail::findAnchored(ctx);
  if (ctx.joints.empty()) {
    // 1-3 island by island, each island's data still in the cache from one stage to the next: the same
    // impulses in the same order as the stages one after the other (no joints to stabilise between them).
    collideAndContact(h);
    clock.lap(ms.contact);
  } else {
    // 1. collision with restitution on predicted positions (emits events)
    detail::collide(ctx, h);
    clock.lap(ms.collide);
    // 2. velocities, 3. contact with the restitution ramp
    detail::integrateVelocities(ctx, h);
    clock.lap(ms.contact);
    detail::preStabilize(ctx, h, ctx.settings.jointIterations, true);
    clock.lap(ms.joints);
    detail::contactStep(ctx, h);
    clock.lap(ms.contact);
  }
  for (const detail::Pair& p : ctx.pairs) {
    ctx.stats.looks += p.looks;
    ctx.stats.keptLooks += p.keptLooks;
    ctx.stats.clearLooks += p.clearLooks;
  }
  // 4. shock propagation
  detail::shockPropagation(ctx, h);
  detail::collisionsCarried(ctx, h);
  clock.lap(ms.shockPropagation);
  // Joints again where the contacts and shock propagation touched a joined body (they moved its velocities).
  if (detail::jointsTouched(ctx)) {
    detail::preStabilize(ctx, h, ctx.settings.jointIterations, false);
    detail::settleJoinedContacts(ctx, h);
  }
  clock.lap(ms.joints);
  // 5. positions, then the positional projection
  ctx.stepStart.resize(ctx.bodies.size());
  ctx.parallelRange(ctx.bodies.size(), kBodyGrain, [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) ctx.stepStart[i] = {ctx.bodies[i].x, ctx.bodies[i].q};
  });
  detail::endOfStepDepths(ctx, h);
  detail::integratePositions(ctx, h);
  ctx.invInertiaNow = false;
  detail::projectPositions(ctx, h);
  clock.lap(ms.positions);
  detail::postStabilize(ctx, h);
  clock.lap(ms.joints);
  // 6. sleeping
  detail::updateSleep(ctx, h);
  clock.lap(ms.sleep);
  ctx.time += h;
}

StepStatus World::step(double h) {
  if (!(h > 0) || !std::isfinite(h)) throw std::invalid_argument("time step must be positive and finite");
  const auto start = std::chrono::steady_clock::now();
  detail::StepContext& ctx = *ctx_;
  // The pool: WorldSettings::threads in all (0: the hardware's), made again when the count changes.
  int threads = ctx.settings.threads > 0 ? ctx.settings.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, 256);
  if (threads == 1) {
    pool_.reset();
  } else if (!pool_ || pool_->size() != threads) {
    pool_.reset();
    pool_ = std::make_unique<detail::ThreadPool>(threads);
  }
  ctx.pool = pool_.get();
  ctx.events.clear();
  ctx.contactReports.clear();
  ctx.jointBreaks.clear();
  for (detail::Joint& jt : ctx.joints) jt.stepImpulse = glm::dvec3(0);
  if (!ctx.reportContacts.empty()) ctx.reportContacts.resize(ctx.bodies.size(), 0);
  if (!ctx.bumpNormals.empty()) ctx.bumpNormals.resize(ctx.bodies.size(), 0);
  if (!ctx.dentRise.empty()) ctx.dentRise.resize(ctx.bodies.size(), -1.0);
  if (!ctx.dentBox.empty()) ctx.dentBox.resize(ctx.bodies.size(), Aabb{glm::dvec3(0), glm::dvec3(-1)});
  detail::forgetSurfaceAnswers(ctx);
  ++ctx.turnStep;
  ctx.turnMemo.resize(ctx.joints.empty() ? 0 : ctx.bodies.size());  // (only the joint passes ask a turn twice)
  ctx.stats = {};
  ctx.frozen.assign(ctx.bodies.size(), 0);
  // Nothing can move, and the last step left no pair: a substep would find none and move no body (it would make
  // again the same bounds, fat boxes and predictions of bodies that stay where they are). Only the time passes; the
  // forces are dropped below, as after any step (an asleep body's are not applied: it does not move).
  StepStatus status;
  if (stillWorld(ctx)) {
    ctx.substepsCapped = false;
    ctx.stats.substeps = 1;
    ctx.time += h;
  } else {
    // Substeps: no body may move more than a fraction of the thinnest half thickness. Where that asks for
    // more than one, only pairs of bodies that can meet within the step count, by their relative travel and
    // the thinner one's half thickness (stepTravel).
    // A body's travel is first bounded by its turn at its reach about its centre of mass (and its dents' rise),
    // never less than its shape's own bound; only a body that this bound would let move too far asks its shape
    // how fast its turn moves it (StepContext::turnSpeed). With joints the first bound stands: stepTravel holds
    // joined bodies to their turn at their reach.
    const double allowed = ctx.settings.substepFraction * std::max(ctx.minHalfThickness, 1e-4);
    std::vector<double> travel(static_cast<size_t>(ctx.workers()), 0.0);  // the largest per worker
    ctx.parallelRange(ctx.bodies.size(), kBodyGrain, [&](size_t begin, size_t end, int worker) {
      double most = 0;
      for (size_t i = begin; i < end; ++i) {
        const RigidBody& b = ctx.bodies[i];
        if (!b.movable()) continue;
        const double fast = glm::length(b.v) + glm::length(ctx.settings.gravity) * h;
        double moved = (fast + glm::length(b.w) * (detail::reachAboutCom(b) + ctx.rise(static_cast<int>(i)))) * h;
        if (moved > allowed && ctx.joints.empty()) moved = (fast + ctx.turnSpeed(static_cast<int>(i))) * h;
        most = std::max(most, moved);
      }
      travel[static_cast<size_t>(worker)] = std::max(travel[static_cast<size_t>(worker)], most);
    });
    const double maxTravel = *std::max_element(travel.begin(), travel.end());
    double ratio = maxTravel / allowed;
    if (ratio > 1) ratio = detail::stepTravel(ctx, h);
    const int n = std::clamp(static_cast<int>(std::ceil(ratio)), 1, std::max(1, ctx.settings.maxSubsteps));
    ctx.substepsCapped = ratio > n;
    // Each body's state before the step: what a step that goes non-finite is undone to.
    std::vector<detail::BodyState>& before = ctx.stepBefore;
    before.resize(ctx.bodies.size());
    ctx.parallelRange(ctx.bodies.size(), kBodyGrain, [&](size_t begin, size_t end, int) {
      for (size_t i = begin; i < end; ++i)
        before[i] = {ctx.bodies[i].x, ctx.bodies[i].q, ctx.bodies[i].v, ctx.bodies[i].w};
    });
    const double timeBefore = ctx.time;
    for (int s = 0; s < n; ++s) substep(h / n);
    ctx.stats.substeps = n;
    status = checkFinite(ctx, before, timeBefore);
  }
  std::vector<int> awake(static_cast<size_t>(ctx.workers()), 0);
  ctx.parallelRange(ctx.bodies.size(), kBodyGrain, [&](size_t begin, size_t end, int worker) {
    int count = 0;
    for (size_t i = begin; i < end; ++i) {
      ctx.force[i] = glm::dvec3(0);
      ctx.torque[i] = glm::dvec3(0);
      count += ctx.bodies[i].movable();
    }
    awake[static_cast<size_t>(worker)] += count;
  });
  for (int a : awake) ctx.stats.awake += a;
  ctx.stats.ms.total = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return status;
}

}  // namespace crumple
