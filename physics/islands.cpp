// Islands of the substep's pairs: the units the step's passes run in parallel.
//
// Guarantees, after findIslands (called once the pairs are known):
// - Every pair is in exactly one island; two pairs share an island when they
//   share a movable body (not static, not asleep; kinematic bodies count, as
//   the impulses write their velocities too), through any chain of such pairs.
//   A static body joins nothing: pairs of different islands write disjoint
//   sets of bodies and only read the static ones.
// - ctx.islandPairs[ctx.islandStart[k], ctx.islandStart[k + 1]) are island k's
//   pairs in pair order; islands are numbered by their first pair.
// - The threads take the islands in blocks of about equal pairs
//   (StepContext::forEachIsland); results never depend on which thread ran one.
// Why it keeps results bit-identical: the collision and contact passes visit
// the pairs in a fixed order (forward, or backward), and an impulse changes
// only the two bodies of its pair. Running each island's pairs in their own
// order, island by island or side by side, applies to every body the same
// impulses in the same order as one sweep over all pairs would.
#include <algorithm>
#include <numeric>

#include <crumple/physics/step_context.h>

namespace crumple::detail {

void findIslands(StepContext& ctx) {
  const size_t n = ctx.bodies.size(), np = ctx.pairs.size();
  DisjointSets& sets = ctx.islandSets;
  sets.reset(n);
  auto movable = [&](int i) { return ctx.body(i).movable(); };
  for (const Pair& p : ctx.pairs)
    if (movable(p.a) && movable(p.b)) sets.unite(p.a, p.b);
  // Island numbers by first pair; each pair's island.
  std::vector<int>& id = ctx.islandOfBody;
  id.assign(n, -1);
  std::vector<int>& pairIsland = ctx.islandOfPair;
  pairIsland.resize(np);
  int islands = 0;
  for (size_t pi = 0; pi < np; ++pi) {
    const Pair& p = ctx.pairs[pi];
    const int r = sets.find(movable(p.a) ? p.a : p.b);
    int& k = id[static_cast<size_t>(r)];
    if (k < 0) k = islands++;
    pairIsland[pi] = k;
  }
  std::vector<uint32_t>& start = ctx.islandStart;
  start.assign(static_cast<size_t>(islands) + 1, 0);
  for (int k : pairIsland) ++start[static_cast<size_t>(k) + 1];
  for (size_t k = 0; k < static_cast<size_t>(islands); ++k) start[k + 1] += start[k];
  ctx.islandPairs.resize(np);
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (size_t pi = 0; pi < np; ++pi) ctx.islandPairs[fill[static_cast<size_t>(pairIsland[pi])]++] = static_cast<uint32_t>(pi);
  ctx.stats.islands = std::max(ctx.stats.islands, islands);
  for (size_t k = 0; k < static_cast<size_t>(islands); ++k)
    ctx.stats.largestIsland = std::max(ctx.stats.largestIsland, static_cast<int>(start[k + 1] - start[k]));
}

}  // namespace crumple::detail
