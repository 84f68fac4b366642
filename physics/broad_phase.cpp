// Broad phase: which bodies may touch during the substep, and which of their
// samples may.
//
// Guarantees, after findPairs and findCandidates:
// - ctx.pairs holds every pair of bodies (at least one dynamic, or a moving
//   kinematic body and a sleeping one) that may collide (mayCollide: groups,
//   joints, the user's filter) and whose bounds,
//   swept from the current pose to the predicted one and widened by a margin,
//   overlap; sorted by (a, b), a < b, with no duplicates. A sleeping body in
//   such a pair is woken.
// - Each pair's candidate lists (bInA, aInB) hold every sample of one body that
//   can come within the substep's margin of the other's surface, in sample
//   order (Verlet lists: kept from the last substep while the bodies have moved
//   less than the skin they were built with, rebuilt otherwise). A shape with
//   a sample tree (sample_tree.h) has only the samples in the other's bounds
//   looked at: the cost of a list is that of the samples near the other body,
//   not of all of a big mesh's. Two polytopes (boxes, convex meshes) have
//   empty lists unless the substeps are capped or a normal modifier bends
//   their normals: the narrow phase meets them by their manifold then.
// - ctx.predicted holds each body's predicted pose x + h (v + h a) (version 0),
//   for the collision step's first look.
// The order is unique whichever sort made it (ties by index): same input, same pairs.
//
// stepTravel (before the substeps): over every pair of bodies whose bounds,
// swept over the whole step, overlap, the largest ratio of their relative
// travel within the step to what a substep may take (substepFraction of the
// thinner one's half thickness), leaving out pairs that never collide (groups
// set apart, joined bodies); likewise every pair of joined bodies. Bodies
// falling side by side, or one far from everything, ask for no substeps
// however fast they move. The pairs come from the fat boxes' list where at most
// a few bodies' swept boxes left their fat boxes (those few tested against
// every body), else from a grid of their own: the same pairs either way.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>

#include <crumple/physics/sample_tree.h>
#include <crumple/physics/step_context.h>

namespace crumple::detail {

namespace {
bool moving(const RigidBody& b) { return glm::dot(b.v, b.v) > 0 || glm::dot(b.w, b.w) > 0; }
}  // namespace

namespace {
// The grid cell of a point, per axis.
using Cell = BroadGrid::Cell;
// A coordinate's cell, within +-2^62 (a position too far or not finite is held at the edge: never an
// out-of-range conversion).
int64_t cellCoordinate(double x) {
  const double limit = 4611686018427387904.0;
  const double c = std::floor(x);
  return c > -limit ? (c < limit ? static_cast<int64_t>(c) : static_cast<int64_t>(limit)) : -static_cast<int64_t>(limit);
}
Cell cellOf(const glm::dvec3& p, const glm::dvec3& origin, double inverse) {
  return {cellCoordinate((p.x - origin.x) * inverse), cellCoordinate((p.y - origin.y) * inverse),
          cellCoordinate((p.z - origin.z) * inverse)};
}
uint32_t bucketOf(const Cell& c, uint32_t mask) {
  const uint64_t h = static_cast<uint64_t>(c.x) * 73856093ull ^ static_cast<uint64_t>(c.y) * 19349663ull ^
                     static_cast<uint64_t>(c.z) * 83492791ull;
  return static_cast<uint32_t>((h ^ (h >> 29)) & mask);
}
bool overlap(const Aabb& a, const Aabb& b) {
  return !(b.lo.x > a.hi.x || a.lo.x > b.hi.x || b.lo.y > a.hi.y || a.lo.y > b.hi.y || b.lo.z > a.hi.z ||
           a.lo.z > b.hi.z);
}

// Whether box a lies within box b (closed).
bool within(const Aabb& a, const Aabb& b) {
  return a.lo.x >= b.lo.x && a.lo.y >= b.lo.y && a.lo.z >= b.lo.z && a.hi.x <= b.hi.x && a.hi.y <= b.hi.y &&
         a.hi.z <= b.hi.z;
}
}  // namespace

// Every two boxes that overlap, once (i < j). Boxes go into the cells of a uniform grid
// (twice the median box's largest side), hashed into buckets; two boxes that overlap share the cell of their
// overlap's lowest corner, and are reported only from that cell's bucket. Boxes spanning more than
// kLargeCells cells (the ground) are tested against every box instead. Sweep and prune along one axis, as
// before, tested every box of a pile's row of columns against each other (a 10000-box pile: 1.25 million
// tests a substep); the grid tests the boxes of a few cells.
// With `active` (one flag per box), only pairs with at least one active box are reported: a world's sleeping
// and static bodies are neither tested against each other nor against the ground.
// The pairs come out as sorted keys (a << 32 | b, a < b), those `accept(a, b)` keeps: each box asks the buckets
// of its own cells for the boxes of higher index (and the large boxes for theirs), on the World's threads in
// ranges of boxes, so the ranges' lists in order are the sorted list (no sort of all pairs, no serial pass over
// them). `accept` runs on those threads unless `serialAccept`.
template <class Accept>
void gridPairs(StepContext& ctx, BroadGrid& g, const std::vector<Aabb>& boxes, const std::vector<char>* active,
               Accept&& accept, bool serialAccept, std::vector<uint64_t>& keys) {
  keys.clear();
  const char* on = active ? active->data() : nullptr;
  constexpr int64_t kLargeCells = 64;
  const size_t n = boxes.size();
  g.large.clear();
  if (n < 2) return;
  if (on && std::find(on, on + n, 1) == on + n) return;  // all asleep or still: no pair
  // Cell size: twice the median largest side.
  g.sides.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const glm::dvec3 e = boxes[i].hi - boxes[i].lo;
    g.sides[i] = std::max({e.x, e.y, e.z});
  }
  std::nth_element(g.sides.begin(), g.sides.begin() + static_cast<std::ptrdiff_t>(n / 2), g.sides.end());
  const double cell = std::max(2 * g.sides[n / 2], 1e-3);
  const double inverse = 1.0 / cell;
  glm::dvec3 origin(1e300);
  for (const Aabb& b : boxes) origin = glm::min(origin, b.lo);
  auto cells = [](const Cell& lo, const Cell& hi) { return (hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1); };
  // Each box's cell range (on the World's threads); the large ones aside.
  g.lo.resize(n);
  g.hi.resize(n);
  ctx.parallelRange(n, ctx.grainFor(n, 1024), [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      const glm::dvec3 e = boxes[i].hi - boxes[i].lo;
      const bool small = e.x < kLargeCells * cell && e.y < kLargeCells * cell && e.z < kLargeCells * cell;
      const Cell lo = cellOf(boxes[i].lo, origin, inverse), hi = cellOf(boxes[i].hi, origin, inverse);
      const int64_t count = small ? cells(lo, hi) : 0;
      if (!small || count > kLargeCells) {
        g.lo[i] = {1, 1, 1};  // no cells
        g.hi[i] = {0, 0, 0};
      } else {
        g.lo[i] = lo;
        g.hi[i] = hi;
      }
    }
  });
  size_t entries = 0;
  for (size_t i = 0; i < n; ++i) {
    if (g.lo[i].x > g.hi[i].x)
      g.large.push_back(static_cast<int>(i));
    else
      entries += static_cast<size_t>(cells(g.lo[i], g.hi[i]));
  }
  uint32_t buckets = 64;
  while (buckets < 2 * entries) buckets *= 2;
  const uint32_t mask = buckets - 1;
  auto eachBucket = [&](size_t i, auto&& fn) {
    uint32_t seen[kLargeCells];
    int count = 0;
    const Cell lo = g.lo[i], hi = g.hi[i];
    for (int64_t z = lo.z; z <= hi.z; ++z)
      for (int64_t y = lo.y; y <= hi.y; ++y)
        for (int64_t x = lo.x; x <= hi.x; ++x) {
          const uint32_t b = bucketOf({x, y, z}, mask);
          if (std::find(seen, seen + count, b) != seen + count) continue;
          seen[count++] = b;
          fn(b);
        }
  };
  // Each box's buckets, once (on the World's threads): up to kInline kept, more found again when asked.
  constexpr int kInline = 8;
  g.bucketCount.resize(n);
  g.bucketList.resize(n * kInline);
  ctx.parallelRange(n, ctx.grainFor(n, 1024), [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      uint32_t c = 0;
      eachBucket(i, [&](uint32_t b) {
        if (c < kInline) g.bucketList[i * kInline + c] = b;
        ++c;
      });
      g.bucketCount[i] = c;
    }
  });
  auto forBuckets = [&](size_t i, auto&& fn) {
    const uint32_t c = g.bucketCount[i];
    if (c > kInline) return eachBucket(i, fn);
    for (uint32_t k = 0; k < c; ++k) fn(g.bucketList[i * kInline + k]);
  };
  // Counting sort of (bucket, box), each box once per bucket (cells of one box may share a bucket).
  g.start.assign(buckets + 1, 0);
  for (size_t i = 0; i < n; ++i) forBuckets(i, [&](uint32_t b) { ++g.start[b + 1]; });
  for (uint32_t b = 0; b < buckets; ++b) g.start[b + 1] += g.start[b];
  g.items.resize(g.start[buckets]);
  g.fill.assign(g.start.begin(), g.start.end() - 1);
  for (size_t i = 0; i < n; ++i) forBuckets(i, [&](uint32_t b) { g.items[g.fill[b]++] = static_cast<int>(i); });
  // Each box's partners of higher index: a pair is reported from the bucket of its overlap's lowest corner
  // (a cell of both boxes, so among the lower box's buckets), once.
  constexpr size_t kBoxesPerRange = 256;
  const size_t ranges = (n + kBoxesPerRange - 1) / kBoxesPerRange;
  g.found.resize(ranges);
  auto range = [&](size_t r, int) {
    std::vector<uint64_t>& found = g.found[r];
    found.clear();
    thread_local std::vector<int> partnersScratch;
    std::vector<int>& partners = partnersScratch;
    const size_t end = std::min(n, (r + 1) * kBoxesPerRange);
    for (size_t i = r * kBoxesPerRange; i < end; ++i) {
      const int ii = static_cast<int>(i);
      const bool iOn = !on || on[i];
      const Aabb& bi = boxes[i];
      partners.clear();
      if (g.lo[i].x > g.hi[i].x) {
        // A large box: against every box of higher index.
        for (size_t j = i + 1; j < n; ++j)
          if ((iOn || on[j]) && overlap(bi, boxes[j])) partners.push_back(static_cast<int>(j));
      } else {
        forBuckets(i, [&](uint32_t b) {
          const int* first = g.items.data() + g.start[b];
          const int* last = g.items.data() + g.start[b + 1];
          for (const int* q = first; q != last; ++q) {
            if (*q <= ii || (!iOn && !on[*q])) continue;
            const Aabb& bq = boxes[static_cast<size_t>(*q)];
            if (!overlap(bi, bq)) continue;
            if (bucketOf(cellOf(glm::max(bi.lo, bq.lo), origin, inverse), mask) != b) continue;
            partners.push_back(*q);
          }
        });
        for (int l : g.large)
          if (l > ii && (iOn || on[l]) && overlap(bi, boxes[static_cast<size_t>(l)])) partners.push_back(l);
      }
      std::sort(partners.begin(), partners.end());
      for (int j : partners)
        if (serialAccept || accept(ii, j)) found.push_back(static_cast<uint64_t>(i) << 32 | static_cast<uint64_t>(j));
    }
  };
  ctx.parallel(ranges, range);
  size_t total = 0;
  for (const std::vector<uint64_t>& found : g.found) total += found.size();
  keys.reserve(total);
  for (const std::vector<uint64_t>& found : g.found)
    for (uint64_t key : found)
      if (!serialAccept || accept(static_cast<int>(key >> 32), static_cast<int>(key & 0xffffffffu))) keys.push_back(key);
}

namespace {
// Each body's bounds now and at its predicted pose (ctx.boxes, grown by a margin for what a substep can move);
// the prediction is kept for the collision step's first look (predictedVersion 0). Active: what can make a
// pair (a dynamic body, or a moving kinematic one that may wake a sleeper).
void bodyBounds(StepContext& ctx, double h) {
  const std::vector<RigidBody>& bodies = ctx.bodies;
  const size_t n = bodies.size();
  std::vector<Aabb>& boxes = ctx.boxes;
  boxes.resize(n);
  ctx.predicted.resize(n);
  ctx.predictedVersion.assign(n, 0);
  std::vector<char>& active = ctx.grid.active;
  active.resize(n);
  const double none = std::numeric_limits<double>::quiet_NaN();
  ctx.boundsAt.resize(n, Pose{glm::dvec3(none), glm::dquat(none, none, none, none)});
  ctx.parallelRange(n, 256, [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      const RigidBody& b = bodies[i];
      active[i] = b.dynamic() || (b.kinematic && moving(b));
      // A body that does not move is predicted where it is, turned as the substep's rotation has it, and keeps its
      // bounds and prediction while it stays where they were made (boundsAt: only such a body's pose is kept there;
      // StepContext::wake clears it).
      if (!b.movable()) {
        Pose& at = ctx.boundsAt[i];
        if (std::memcmp(&at.position, &b.x, sizeof b.x) == 0 && std::memcmp(&at.orientation, &b.q, sizeof b.q) == 0)
          continue;
        at = {b.x, b.q};
        ctx.predicted[i] = PoseFrame(at, ctx.rotation[i]);
      } else {
        ctx.predicted[i] = PoseFrame(ctx.predict(b, h, true));
      }
      boxes[i] = worldBounds(*b.shape, b.localCom, b.x, ctx.rotation[i]);
      if (b.movable()) {
        Aabb& box = boxes[i];
        box = merge(box, worldBounds(*b.shape, b.localCom, ctx.predicted[i].pose.position, ctx.predicted[i].rotation));
        const double margin = 0.005 + 2 * h * glm::length(b.v) + ctx.rise(static_cast<int>(i));
        box.lo -= margin;
        box.hi += margin;
      }
    }
  });
}

// Whether body i's bounds are still in its fat box and it was active when the box was made, if it is now.
bool inFatBox(const StepContext& ctx, size_t i) {
  const BroadGrid& grid = ctx.grid;
  return within(ctx.boxes[i], grid.fat[i]) && (!grid.active[i] || grid.fatActive[i]);
}

// Whether every body is still in its fat box (inFatBox): the fat boxes' pairs then still hold every pair. In
// ranges on the World's threads, each its own flag.
bool fatBoxesHold(StepContext& ctx) {
  const size_t n = ctx.bodies.size();
  BroadGrid& grid = ctx.grid;
  if (grid.fat.size() != n) return false;  // (none yet, or bodies added since)
  const size_t kBodiesPerRange = ctx.grainFor(n, 2048);
  std::vector<char>& inside = grid.rangeInside;
  inside.assign((n + kBodiesPerRange - 1) / kBodiesPerRange, 1);
  ctx.parallelRange(n, kBodiesPerRange, [&](size_t begin, size_t end, int) {
    char ok = 1;
    for (size_t i = begin; i < end && ok; ++i) ok = inFatBox(ctx, i);
    inside[begin / kBodiesPerRange] = ok;
  });
  return std::find(inside.begin(), inside.end(), 0) == inside.end();
}

// A body's new fat box: its bounds with a skin (a tenth of the body's smallest side, at most 5 cm) and four
// substeps' travel ahead.
Aabb fatBox(const StepContext& ctx, size_t i, double h) {
  const RigidBody& b = ctx.bodies[i];
  Aabb f = ctx.boxes[i];
  if (b.movable()) {
    const glm::dvec3 e = b.shape->boundsMax - b.shape->boundsMin;
    const double skin = std::min(0.1 * std::min({e.x, e.y, e.z}), 0.05);
    const glm::dvec3 ahead = 4 * h * b.v;
    f.lo += glm::min(ahead, glm::dvec3(0)) - skin;
    f.hi += glm::max(ahead, glm::dvec3(0)) + skin;
  }
  return f;
}

// New fat boxes for every body, and their pairs, from a hashed grid (gridPairs).
void refreshFatPairs(StepContext& ctx, double h) {
  const size_t n = ctx.bodies.size();
  BroadGrid& grid = ctx.grid;
  grid.fat.resize(n);
  ctx.parallelRange(n, 256, [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) grid.fat[i] = fatBox(ctx, i, h);
  });
  grid.fatActive = grid.active;
  gridPairs(ctx, grid, grid.fat, &grid.active, [](int, int) { return true; }, false, grid.fatKeys);
}

// Where at most kFewOutside bodies left their fat boxes (or became active since): new fat boxes for those alone,
// their pairs dropped and found again against every fat box (each pair with a body active when its fat box was
// made, as gridPairs finds them). The other bodies' fat boxes still hold their bounds, so the fat pairs still hold
// every pair whose bounds overlap: the same pairs as after refreshFatPairs. False (nothing changed) where more
// left: a grid then costs less than testing each against every body.
constexpr size_t kFewOutside = 32;
bool refreshFewFatBoxes(StepContext& ctx, double h) {
  const size_t n = ctx.bodies.size();
  BroadGrid& grid = ctx.grid;
  if (grid.fat.size() != n || grid.fatActive.size() != n) return false;
  std::vector<int>& out = grid.outside;
  out.clear();
  for (size_t i = 0; i < n; ++i)
    if (!inFatBox(ctx, i)) {
      if (out.size() == kFewOutside) return false;
      out.push_back(static_cast<int>(i));
    }
  std::vector<char>& isOut = grid.isOutside;
  isOut.assign(n, 0);
  for (int i : out) {
    isOut[static_cast<size_t>(i)] = 1;
    grid.fat[static_cast<size_t>(i)] = fatBox(ctx, static_cast<size_t>(i), h);
    grid.fatActive[static_cast<size_t>(i)] = grid.active[static_cast<size_t>(i)];
  }
  std::vector<uint64_t>& keys = grid.fatKeys;
  keys.erase(std::remove_if(keys.begin(), keys.end(),
                            [&](uint64_t key) { return isOut[key >> 32] || isOut[key & 0xffffffffu]; }),
             keys.end());
  std::vector<uint64_t>& found = grid.outsideKeys;
  found.clear();
  for (int i : out) {
    const Aabb& fi = grid.fat[static_cast<size_t>(i)];
    const bool iOn = grid.fatActive[static_cast<size_t>(i)] != 0;
    for (size_t j = 0; j < n; ++j) {
      if (static_cast<int>(j) == i || (isOut[j] && static_cast<int>(j) < i)) continue;  // (a pair of two: once)
      if ((iOn || grid.fatActive[j]) && overlap(fi, grid.fat[j]))
        found.push_back(static_cast<int>(j) < i ? static_cast<uint64_t>(j) << 32 | static_cast<uint64_t>(i)
                                                : static_cast<uint64_t>(i) << 32 | static_cast<uint64_t>(j));
    }
  }
  std::sort(found.begin(), found.end());
  const size_t kept = keys.size();
  keys.insert(keys.end(), found.begin(), found.end());
  std::inplace_merge(keys.begin(), keys.begin() + static_cast<std::ptrdiff_t>(kept), keys.end());
  return true;
}

// The fat boxes' pairs whose bounds overlap and that the filters keep (ctx.pairKeys, in the same sorted order):
// in ranges on the World's threads, each its own list, joined in order (one thread while a user's filter is
// set: it is called as the user gave it).
void keepOverlapping(StepContext& ctx) {
  const std::vector<RigidBody>& bodies = ctx.bodies;
  const std::vector<char>& active = ctx.grid.active;
  auto accept = [&](int i, int j) {
    const RigidBody& A = bodies[static_cast<size_t>(i)];
    const RigidBody& B = bodies[static_cast<size_t>(j)];
    if (!A.dynamic() && !B.dynamic()) {
      // Neither is pushed by anything: only a moving kinematic body reaching a sleeping one makes a pair
      // (waking it).
      const bool wakes = (A.kinematic && moving(A) && B.asleep && !B.kinematic) ||
                         (B.kinematic && moving(B) && A.asleep && !A.kinematic);
      if (!wakes) return false;
    }
    return mayCollide(ctx, i, j);
  };
  auto keep = [&](uint64_t key) {
    const size_t i = key >> 32, j = key & 0xffffffffu;
    return (active[i] || active[j]) && overlap(ctx.boxes[i], ctx.boxes[j]) &&
           accept(static_cast<int>(i), static_cast<int>(j));
  };
  std::vector<uint64_t>& pairKeys = ctx.pairKeys;
  pairKeys.clear();
  BroadGrid& grid = ctx.grid;
  const std::vector<uint64_t>& fatKeys = grid.fatKeys;
  if (ctx.filter || ctx.workers() < 2) {
    for (uint64_t key : fatKeys)
      if (keep(key)) pairKeys.push_back(key);
    return;
  }
  const size_t kKeysPerRange = ctx.grainFor(fatKeys.size(), 4096);
  grid.found.resize((fatKeys.size() + kKeysPerRange - 1) / kKeysPerRange);
  ctx.parallelRange(fatKeys.size(), kKeysPerRange, [&](size_t begin, size_t end, int) {
    std::vector<uint64_t>& kept = grid.found[begin / kKeysPerRange];
    kept.clear();
    for (size_t k = begin; k < end; ++k)
      if (keep(fatKeys[k])) kept.push_back(fatKeys[k]);
  });
  for (const std::vector<uint64_t>& kept : grid.found) pairKeys.insert(pairKeys.end(), kept.begin(), kept.end());
}

// Too many pairs (thousands of bodies piled into one spot): keep maxPairs of them, those with a body that
// nothing pushes (the ground) first, then in key order; the rest pass through each other this substep
// (StepStats::droppedPairs).
void capPairs(StepContext& ctx) {
  std::vector<uint64_t>& pairKeys = ctx.pairKeys;
  const size_t maxPairs = static_cast<size_t>(std::max(0, ctx.settings.maxPairs));
  if (pairKeys.size() <= maxPairs) return;
  ctx.stats.droppedPairs += static_cast<int>(pairKeys.size() - maxPairs);
  auto anchoredPair = [&](uint64_t key) {
    return !ctx.bodies[static_cast<size_t>(key >> 32)].dynamic() ||
           !ctx.bodies[static_cast<size_t>(key & 0xffffffffu)].dynamic();
  };
  std::stable_partition(pairKeys.begin(), pairKeys.end(), anchoredPair);
  pairKeys.resize(maxPairs);
  std::sort(pairKeys.begin(), pairKeys.end());
}

// ctx.pairs from the keys: pairs that already existed keep their candidate lists (both sorted by a, b: a merge,
// in ranges on the World's threads, each range's start found by binary search).
void carryPairs(StepContext& ctx) {
  const std::vector<uint64_t>& pairKeys = ctx.pairKeys;
  std::vector<Pair>& pairs = ctx.pairs;
  std::vector<Pair>& previousPairs = ctx.previousPairs;
  // The same pairs as the last substep (a resting pile): each keeps its own lists already.
  bool same = pairs.size() == pairKeys.size();
  for (size_t pi = 0; pi < pairs.size() && same; ++pi)
    same = (static_cast<uint64_t>(pairs[pi].a) << 32 | static_cast<uint64_t>(pairs[pi].b)) == pairKeys[pi];
  if (same) return;
  std::swap(pairs, previousPairs);
  pairs.resize(pairKeys.size());
  ctx.parallelRange(pairKeys.size(), ctx.grainFor(pairKeys.size(), 1024), [&](size_t begin, size_t end, int) {
    auto before = [](const Pair& x, int a, int b) { return x.a < a || (x.a == a && x.b < b); };
    auto old = std::partition_point(previousPairs.begin(), previousPairs.end(), [&](const Pair& x) {
      return before(x, static_cast<int>(pairKeys[begin] >> 32), static_cast<int>(pairKeys[begin] & 0xffffffffu));
    });
    for (size_t pi = begin; pi < end; ++pi) {
      Pair& p = pairs[pi];
      p.a = static_cast<int>(pairKeys[pi] >> 32);
      p.b = static_cast<int>(pairKeys[pi] & 0xffffffffu);
      while (old != previousPairs.end() && before(*old, p.a, p.b)) ++old;
      if (old != previousPairs.end() && old->a == p.a && old->b == p.b) {
        std::swap(p.bInA, old->bInA);
        std::swap(p.aInB, old->aInB);
        p.builtA = old->builtA;
        p.builtB = old->builtB;
        p.builtMargin = old->builtMargin;
        p.bSegmentNear = old->bSegmentNear;
        p.aSegmentNear = old->aSegmentNear;
        p.listGeneration = old->listGeneration;
        p.dentsA = old->dentsA;
        p.dentsB = old->dentsB;
        // (Most pairs have no near samples: nothing to move then.)
        if (old->nearBInA.within > 0)
          std::swap(p.nearBInA, old->nearBInA);
        else
          p.nearBInA.within = -1;
        if (old->nearAInB.within > 0)
          std::swap(p.nearAInB, old->nearAInB);
        else
          p.nearAInB.within = -1;
        std::swap(p.kept, old->kept);
        p.keptA = old->keptA;
        p.keptB = old->keptB;
        p.hasKept = old->hasKept;
        p.clearance = old->clearance;
        p.clearLists = old->clearLists;
      } else {
        // (A slot of the vector two substeps old: nothing in it is this pair's.)
        p.bInA.clear();
        p.aInB.clear();
        p.builtMargin = -1;
        p.dentsA = p.dentsB = false;
        p.nearBInA.within = p.nearAInB.within = -1;
        p.hasKept = false;
        p.clearance = -1;
      }
    }
  });
}
}  // namespace

// Every two bodies' boxes that overlap (closed intervals on all three axes) and that the bodies' filters keep.
// The fat boxes' pairs are kept while they still hold every pair (a resting pile builds no grid); the pairs are
// then those of the kept list whose bounds overlap, in the same (sorted) order: the same pairs either way.
void findPairs(StepContext& ctx, double h) {
  bodyBounds(ctx, h);
  refreshJointExclusions(ctx);
  if (!fatBoxesHold(ctx) && !refreshFewFatBoxes(ctx, h)) refreshFatPairs(ctx, h);
  keepOverlapping(ctx);
  // Sleepers in a pair wake (after every pair is known: the filter above saw the bodies as they were).
  for (uint64_t key : ctx.pairKeys) {
    const int i = static_cast<int>(key >> 32), j = static_cast<int>(key & 0xffffffffu);
    if (ctx.bodies[static_cast<size_t>(i)].asleep) ctx.wake(i);
    if (ctx.bodies[static_cast<size_t>(j)].asleep) ctx.wake(j);
  }
  capPairs(ctx);
  carryPairs(ctx);
}

double stepTravel(StepContext& ctx, double h) {
  const std::vector<RigidBody>& bodies = ctx.bodies;
  const size_t n = bodies.size();
  // Per body: bounds swept over the step (the pose now and moved by h v + h^2 a, widened by how far its turn
  // moves its shape's points: StepContext::turnSpeed) and the bound of its own travel's parts.
  struct Swept {
    glm::dvec3 v{0}, a{0};
    double turn = 0;  // turnSpeed h: how far the turn moves the shape
  };
  std::vector<Swept> swept(n);
  std::vector<Aabb>& boxes = ctx.boxes;  // (findPairs makes them again for the substeps)
  boxes.resize(n);
  ctx.boundsAt.clear();  // (every box made here is the step's swept one)
  for (size_t i = 0; i < n; ++i) {
    const RigidBody& b = bodies[i];
    Swept& s = swept[i];
    boxes[i] = worldBounds(*b.shape, b.localCom, {b.x, b.q});
    if (b.movable()) {
      s.v = b.v;
      s.a = ctx.acceleration(static_cast<int>(i));
      s.turn = ctx.turnSpeed(static_cast<int>(i)) * h;
      const glm::dvec3 d = h * s.v + h * h * s.a;
      boxes[i].lo = glm::min(boxes[i].lo, boxes[i].lo + d) - s.turn - 0.005;
      boxes[i].hi = glm::max(boxes[i].hi, boxes[i].hi + d) + s.turn + 0.005;
    }
  }
  double worst = 0;
  const double fraction = ctx.settings.substepFraction;
  std::vector<uint64_t>& keys = ctx.pairKeys;  // (findPairs makes them again for the substeps)
  refreshJointExclusions(ctx);
  auto accept = [&](int ia, int ib) {
    const RigidBody& A = bodies[static_cast<size_t>(ia)];
    const RigidBody& B = bodies[static_cast<size_t>(ib)];
    // Pairs that never collide (groups set apart, joined bodies) need no substeps; the user's filter is not
    // asked here (it is called once a substep, in findPairs).
    return (A.movable() || B.movable()) && mayCollide(ctx, ia, ib, false);
  };
  // A body's reach about its centre of mass, a dented one's with its dents' rise.
  auto reachOf = [&](int i) { return reachAboutCom(bodies[static_cast<size_t>(i)]) + ctx.rise(i); };
  auto pairTravel = [&](int ia, int ib) {
    const RigidBody& A = bodies[static_cast<size_t>(ia)];
    const RigidBody& B = bodies[static_cast<size_t>(ib)];
    const Swept& si = swept[static_cast<size_t>(ia)];
    const Swept& sj = swept[static_cast<size_t>(ib)];
    const double moved = h * glm::length(sj.v - si.v) + h * h * glm::length(sj.a - si.a);
    const double travel = moved + si.turn + sj.turn;
    const double allowed = fraction * std::max(std::min(A.shape->halfThickness(), B.shape->halfThickness()), 1e-4);
    if (!(travel / allowed > worst)) return;  // (asks no more than the worst so far)
    // Bodies whose spheres about their centres of mass (each turn keeps its own) stay apart over the step by
    // their centres' relative travel cannot meet in it.
    if (glm::length(B.x - A.x) - reachOf(ia) - reachOf(ib) > moved) return;
    worst = travel / allowed;
  };
  // The fat boxes' pairs (findPairs) hold every pair whose swept boxes overlap among bodies whose swept box lies
  // in their fat box and which were active when the fat boxes were made (a pair of bodies neither of which moves
  // travels nothing); the few others (at most kFewOutside) are tested against every body. The largest ratio is the
  // same whatever the order: only where more left their fat boxes is a grid built.
  const BroadGrid& grid = ctx.grid;
  std::vector<char> out;
  size_t outside = SIZE_MAX;  // (no fat boxes yet: a grid)
  if (grid.fat.size() == n && grid.fatActive.size() == n) {
    out.assign(n, 0);
    outside = 0;
    for (size_t i = 0; i < n; ++i) {
      const Aabb& box = boxes[i];
      const Aabb& f = grid.fat[i];
      const bool in = within(box, f) && (!bodies[i].movable() || grid.fatActive[i]);
      out[i] = !in;
      outside += !in;
    }
  }
  if (outside <= kFewOutside) {
    for (uint64_t key : grid.fatKeys) {
      const int ia = static_cast<int>(key >> 32), ib = static_cast<int>(key & 0xffffffffu);
      if (!out[static_cast<size_t>(ia)] && !out[static_cast<size_t>(ib)] &&
          overlap(boxes[static_cast<size_t>(ia)], boxes[static_cast<size_t>(ib)]) && accept(ia, ib))
        pairTravel(ia, ib);
    }
    for (size_t i = 0; i < n; ++i) {
      if (!out[i]) continue;
      for (size_t j = 0; j < n; ++j)
        if (j != i && !(out[j] && j < i) && overlap(boxes[i], boxes[j]) &&
            accept(static_cast<int>(std::min(i, j)), static_cast<int>(std::max(i, j))))
          pairTravel(static_cast<int>(std::min(i, j)), static_cast<int>(std::max(i, j)));
    }
  } else {
    gridPairs(ctx, ctx.grid, boxes, nullptr, accept, false, keys);
    for (uint64_t key : keys) pairTravel(static_cast<int>(key >> 32), static_cast<int>(key & 0xffffffffu));
  }
  // Joined bodies, wherever they are, by how far each one's turn moves any of its points (an anchor may lie
  // anywhere on it): the joint solve's Newton passes are linearised in the turn over the substep (a translation
  // is linear in the impulse; joint_step.cpp takes the levers at the substep's end, and a 100 kg body on 1 kg
  // links holds even in one substep a step).
  auto own = [&](int i) {
    const RigidBody& b = bodies[static_cast<size_t>(i)];
    return b.movable() ? glm::length(b.w) * reachAboutCom(b) * h : 0.0;
  };
  for (const Joint& jt : ctx.joints) {
    if (jt.removed || jt.broken || jt.def.b < 0) continue;
    const RigidBody& B = bodies[static_cast<size_t>(jt.def.b)];
    double travel = own(jt.def.b), thinner = B.shape->halfThickness();
    if (jt.def.a >= 0) {
      travel = std::max(travel, own(jt.def.a));
      thinner = std::min(thinner, bodies[static_cast<size_t>(jt.def.a)].shape->halfThickness());
    }
    worst = std::max(worst, travel / (fraction * std::max(thinner, 1e-4)));
  }
  return worst;
}

void findCandidates(StepContext& ctx, double h) {
  const double g = glm::length(ctx.settings.gravity);
  // Each pair writes only its own lists: in parallel on the World's threads.
  ctx.parallelRange(ctx.pairs.size(), 64, [&](size_t begin, size_t end, int) {
  for (size_t pi = begin; pi < end; ++pi) {
    Pair& pair = ctx.pairs[pi];
    const RigidBody& A = ctx.body(pair.a);
    const RigidBody& B = ctx.body(pair.b);
    // Two polytopes meet by their manifold (narrow_phase.cpp) unless the step sweeps or a normal modifier
    // bends their normals: no samples are looked at, no lists needed.
    // Dents that can reach the other body within the lists' reach (a change remakes the lists).
    bool dentsA = false, dentsB = false;
    if (ctx.dented(pair.a) || ctx.dented(pair.b)) {
      const double reachDents = 2 * h *
                                    (glm::length(B.v - A.v) + glm::length(A.w) * A.shape->boundingRadius +
                                     glm::length(B.w) * B.shape->boundingRadius + 2 * g * h) +
                                0.005 + 0.2 * std::min(A.shape->halfThickness(), B.shape->halfThickness());
      dentsA = ctx.dentsReach(pair.a, pair.b, reachDents);
      dentsB = ctx.dentsReach(pair.b, pair.a, reachDents);
    }
    if (dentsA != pair.dentsA || dentsB != pair.dentsB) pair.builtMargin = -1;
    pair.dentsA = dentsA;
    pair.dentsB = dentsB;
    const bool bumpA = ctx.bentNormals(pair.a), bumpB = ctx.bentNormals(pair.b);
    if (A.shape->polytope && B.shape->polytope && !ctx.substepsCapped && !bumpA && !bumpB) {
      pair.bInA.clear();
      pair.aInB.clear();
      pair.builtMargin = -1;
      continue;
    }
    // What matters is B's motion relative to A: two bodies falling side by
    // side do not approach each other however fast they fall.
    auto spin = [&](const RigidBody& b) {
      return b.movable() ? glm::length(b.w) * b.shape->boundingRadius + 2 * g * h : 0.0;
    };
    const glm::dvec3 va = A.movable() ? A.v : glm::dvec3(0), vb = B.movable() ? B.v : glm::dvec3(0);
    // Twice the bound on the relative motion this step, plus a little.
    const double margin = 2 * h * (glm::length(vb - va) + spin(A) + spin(B)) + 0.005 + (dentsA ? ctx.rise(pair.a) : 0.0) +
                          (dentsB ? ctx.rise(pair.b) : 0.0);
    // The skin: 0.3 of the smaller body's thinnest half thickness (a tenth rebuilt a tumbling heap's lists
    // nearly every substep; 0.6 made the first look of a substep test too many samples: the looks after it test
    // the near samples only, narrow_phase.cpp).
    const double skin = 0.3 * std::min(A.shape->halfThickness(), B.shape->halfThickness());
    if (pair.builtMargin >= 0) {
      const double ra = reachAboutCom(A) + pair.builtMargin;
      const double rb = reachAboutCom(B) + pair.builtMargin;
      // (the lists still hold every sample that can touch while moved + margin <= builtMargin)
      const bool stale = displacementExceeds(pair.builtA, {A.x, A.q}, ra, pair.builtB, {B.x, B.q}, rb,
                                             [&](double moved) { return !(moved + margin <= pair.builtMargin); });
      if (!stale) continue;
    }
    const double built = margin + skin;
    // A capsule's segment (its deepest point between two core samples) can reach only where a core sample comes
    // within half their spacing of reaching: `near` tells whether one does, at the lists' reach plus that.
    auto collect = [&](int iOwner, int iOther, std::vector<uint32_t>& list, bool segment, bool& near) {
      const RigidBody& owner = ctx.body(iOwner);
      const RigidBody& other = ctx.body(iOther);
      list.clear();
      const Shape& so = *owner.shape;
      const Shape& st = *other.shape;
      const double r = st.sampleRadius;
      const double reach =
          built + (segment && st.samples.size() > 1 ? st.halfHeight / static_cast<double>(st.samples.size() - 1) : 0.0);
      near = false;
      const glm::dvec3 lo = so.boundsMin - r - reach, hi = so.boundsMax + r + reach;
      const glm::dmat3 rot = glm::transpose(ctx.rotation[static_cast<size_t>(iOwner)]);
      const glm::dmat3& rt = ctx.rotation[static_cast<size_t>(iOther)];
      const glm::dmat3 m = rot * rt;
      const glm::dvec3 offset = rot * (other.x - owner.x - rt * other.localCom) + owner.localCom;
      auto test = [&](uint32_t k) {
        // (m * s + offset, a coordinate at a time: most samples the box leaves out are out by the first one)
        const glm::dvec3& sample = st.samples[k];
        glm::dvec3 local;
        local.x = m[0][0] * sample.x + m[1][0] * sample.y + m[2][0] * sample.z + offset.x;
        if (local.x < lo.x || local.x > hi.x) return;
        local.y = m[0][1] * sample.x + m[1][1] * sample.y + m[2][1] * sample.z + offset.y;
        if (local.y < lo.y || local.y > hi.y) return;
        local.z = m[0][2] * sample.x + m[1][2] * sample.y + m[2][2] * sample.z + offset.z;
        if (local.z < lo.z || local.z > hi.z) return;
        const double d = fieldDistance(so, local) - r;
        if (d > reach) return;
        near = true;
        if (d <= built) list.push_back(k);
      };
      const SampleTree* tree = st.sampleTree.get();
      if (!tree || tree->size() != st.samples.size()) {
        for (size_t k = 0; k < st.samples.size(); ++k) test(static_cast<uint32_t>(k));
        return;
      }
      // Only the samples whose place in the owner's frame lies in the box: the
      // box as the other's frame sees it (a little wider: the test decides).
      const glm::dmat3 mt = glm::transpose(m);
      const glm::dvec3 centre = mt * ((lo + hi) * 0.5 - offset);
      const glm::dvec3 half = (hi - lo) * 0.5;
      tree->query(centre, mt, half + 1e-9 * (1 + glm::length(centre) + glm::length(half)), test);
      std::sort(list.begin(), list.end());  // in sample order, as a whole scan finds them
    };
    const SampleSides sides = sampleSides(*A.shape, bumpA || dentsA, *B.shape, bumpB || dentsB);
    pair.bSegmentNear = pair.aSegmentNear = false;
    if (sides.bInA)
      collect(pair.a, pair.b, pair.bInA, sides.segmentB, pair.bSegmentNear);
    else
      pair.bInA.clear();
    if (sides.aInB)
      collect(pair.b, pair.a, pair.aInB, sides.segmentA, pair.aSegmentNear);
    else
      pair.aInB.clear();
    pair.builtA = {A.x, A.q};
    pair.builtB = {B.x, B.q};
    pair.builtMargin = built;
    ++pair.listGeneration;  // (the near samples of the old lists are not the new ones')
  }
  });
}

}  // namespace crumple::detail
