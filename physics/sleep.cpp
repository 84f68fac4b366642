// Sleeping: islands that stayed still for `sleepTime` freeze.
//
// Guarantees:
// - Every movable body's stillTime grows by h over each substep it ends
//   within sleepLinear x sleepTime / 2 (m) of where it was when its stillness
//   began and turned less than sleepAngular x sleepTime / 2 (rad) from the
//   orientation it had then; otherwise it restarts from 0 there. A body that
//   trembles in place (a box rocking on a stack by a fraction of a millimetre)
//   is still however fast it trembles; one that drifts at half those speeds
//   or faster is not.
// - With `sleeping` on: the bodies of an island (movable bodies joined by
//   pairs not involving a static body) fall asleep together, velocities
//   zeroed, when every one has been still for sleepTime and the island rests
//   on something (a pair with a static or sleeping body). A body in free
//   flight never sleeps. Joined bodies are one island; kinematic bodies never
//   sleep and join no island (one at rest supports like a static body). Bodies wake in the broad phase (a pair with a
//   movable body) or through World::wake and the forces.
#include <algorithm>
#include <numeric>

#include <crumple/physics/step_context.h>

namespace crumple::detail {

namespace {
bool moving(const RigidBody& b) { return glm::dot(b.v, b.v) > 0 || glm::dot(b.w, b.w) > 0; }
}  // namespace

void updateSleep(StepContext& ctx, double h) {
  const WorldSettings& settings = ctx.settings;
  std::vector<RigidBody>& bodies = ctx.bodies;
  const size_t n = bodies.size();
  // Still: the body stayed near where its stillness began. Not its velocity:
  // a body resting on another ends each step still approaching it by about
  // g h (the contact step stops penetration at the predicted positions, the
  // projection the rest), which at 60 Hz is more than any sleep threshold;
  // nor its speed over one substep: a stack's boxes rock by tiny amounts at
  // speeds above any threshold long after the stack has come to rest.
  // (Per worker: whether some body has been still long enough to sleep; without one no island can.)
  const double reach = 0.5 * settings.sleepLinear * settings.sleepTime;
  const double turn = 0.5 * settings.sleepAngular * settings.sleepTime;
  std::vector<char> ready(static_cast<size_t>(ctx.workers()), 0);
  ctx.parallelRange(std::min(n, ctx.stepStart.size()), 256, [&](size_t begin, size_t end, int worker) {
    bool any = false;
    for (size_t i = begin; i < end; ++i) {
      RigidBody& b = bodies[i];
      if (!b.movable()) continue;
      if (b.stillTime == 0) {
        b.stillFromX = ctx.stepStart[i].position;
        b.stillFromQ = ctx.stepStart[i].orientation;
      }
      const glm::dvec3 d = b.x - b.stillFromX;
      const bool still = glm::dot(d, d) < reach * reach &&
                         !angleExceeds(b.stillFromQ, b.q, [&](double angle) { return !(angle < turn); });
      b.stillTime = still ? b.stillTime + h : 0;
      any = any || (!b.kinematic && b.stillTime >= settings.sleepTime);
    }
    if (any) ready[static_cast<size_t>(worker)] = 1;
  });
  if (!settings.sleeping || std::find(ready.begin(), ready.end(), 1) == ready.end()) return;
  DisjointSets sets;
  sets.reset(n);
  auto find = [&](int x) { return sets.find(x); };
  auto unite = [&](int a, int b) { sets.unite(a, b); };
  auto fixedBody = [&](int i) { return bodies[static_cast<size_t>(i)].isStatic || bodies[static_cast<size_t>(i)].kinematic; };
  for (const Pair& p : ctx.pairs) {
    if (fixedBody(p.a) || fixedBody(p.b)) continue;
    unite(p.a, p.b);
  }
  // Joined bodies sleep and wake together.
  for (const Joint& jt : ctx.joints) {
    if (jt.removed || jt.broken || jt.def.a < 0 || fixedBody(jt.def.a) || fixedBody(jt.def.b)) continue;
    unite(jt.def.a, jt.def.b);
  }
  std::vector<char> islandStill(n, 1), supported(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const RigidBody& b = bodies[i];
    if (b.isStatic || b.kinematic) continue;
    if (b.movable() && b.stillTime < settings.sleepTime)
      islandStill[static_cast<size_t>(find(static_cast<int>(i)))] = 0;
  }
  // Only an island that rests on something (a static or sleeping body near
  // one of its bodies) sleeps: a slow body in free flight (zero gravity, say)
  // keeps its momentum.
  for (const Pair& p : ctx.pairs) {
    const RigidBody& A = bodies[static_cast<size_t>(p.a)];
    const RigidBody& B = bodies[static_cast<size_t>(p.b)];
    if (!A.movable() || (A.kinematic && !moving(A))) supported[static_cast<size_t>(find(p.b))] = 1;
    if (!B.movable() || (B.kinematic && !moving(B))) supported[static_cast<size_t>(find(p.a))] = 1;
  }
  for (size_t i = 0; i < n; ++i) {
    RigidBody& b = bodies[i];
    const size_t root = static_cast<size_t>(find(static_cast<int>(i)));
    if (!b.movable() || b.kinematic || !islandStill[root] || !supported[root]) continue;
    b.asleep = true;
    b.v = glm::dvec3(0);
    b.w = glm::dvec3(0);
  }
}

}  // namespace crumple::detail
