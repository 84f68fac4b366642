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
//   not of all of a big mesh's.
// - ctx.predicted holds each body's predicted pose x + h (v + h a) (version 0),
//   for the collision step's first look.
// The order is unique whichever sort made it (ties by index): same input, same pairs.
//
// stepTravel (before the substeps): over every pair of bodies whose bounds,
// swept over the whole step, overlap, the largest ratio of their relative
// travel within the step to what a substep may take (substepFraction of the
// thinner one's half thickness); likewise every pair of joined bodies. Bodies
// falling side by side, or one far from everything, ask for no substeps
// however fast they move.
#include <algorithm>
#include <numeric>

#include "physics/sample_tree.h"
#include "physics/step_context.h"

namespace crumple::detail {

namespace {
bool moving(const RigidBody& b) { return glm::dot(b.v, b.v) > 0 || glm::dot(b.w, b.w) > 0; }
}  // namespace

void findPairs(StepContext& ctx, double h) {
  const std::vector<RigidBody>& bodies = ctx.bodies;
  const size_t n = bodies.size();
  std::vector<Aabb>& boxes = ctx.boxes;
  std::vector<int>& sweepOrder = ctx.sweepOrder;
  // Each body's bounds now and at its predicted pose; the prediction is kept
  // for the collision step's first look (predictedVersion 0).
  boxes.resize(n);
  ctx.predicted.resize(n);
  ctx.predictedVersion.assign(n, 0);
  ctx.parallelRange(n, 256, [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      const RigidBody& b = bodies[i];
      ctx.predicted[i] = ctx.predict(b, h, true);
      boxes[i] = worldBounds(*b.shape, b.localCom, {b.x, b.q});
      if (b.movable()) {
        Aabb& box = boxes[i];
        box = merge(box, worldBounds(*b.shape, b.localCom, ctx.predicted[i]));
        const double margin = 0.005 + 2 * h * glm::length(b.v);
        box.lo -= margin;
        box.hi += margin;
      }
    }
  });
  // Sweep and prune along x. The order of the last substep is nearly right:
  // insertion sort, unless too much has moved (then a full sort). Ties go by
  // index, so the order is unique whichever sort made it.
  auto before = [&](int x, int y) {
    const double bx = boxes[static_cast<size_t>(x)].lo.x, by = boxes[static_cast<size_t>(y)].lo.x;
    return bx != by ? bx < by : x < y;
  };
  if (sweepOrder.size() != n) {
    sweepOrder.resize(n);
    std::iota(sweepOrder.begin(), sweepOrder.end(), 0);
    std::sort(sweepOrder.begin(), sweepOrder.end(), before);
  } else {
    size_t shifts = 0;
    for (size_t i = 1; i < n && shifts <= 8 * n; ++i) {
      const int v = sweepOrder[i];
      size_t j = i;
      for (; j > 0 && before(v, sweepOrder[j - 1]); --j) sweepOrder[j] = sweepOrder[j - 1];
      sweepOrder[j] = v;
      shifts += i - j;
    }
    if (shifts > 8 * n) std::sort(sweepOrder.begin(), sweepOrder.end(), before);
  }
  std::vector<uint64_t>& pairKeys = ctx.pairKeys;
  pairKeys.clear();
  std::vector<int> wakeList;
  for (size_t oi = 0; oi < n; ++oi) {
    const int i = sweepOrder[oi];
    const Aabb& bi = boxes[static_cast<size_t>(i)];
    const RigidBody& A = bodies[static_cast<size_t>(i)];
    for (size_t oj = oi + 1; oj < n; ++oj) {
      const int j = sweepOrder[oj];
      const Aabb& bj = boxes[static_cast<size_t>(j)];
      if (bj.lo.x > bi.hi.x) break;
      if (bj.lo.y > bi.hi.y || bi.lo.y > bj.hi.y || bj.lo.z > bi.hi.z || bi.lo.z > bj.hi.z) continue;
      const RigidBody& B = bodies[static_cast<size_t>(j)];
      if (!A.dynamic() && !B.dynamic()) {
        // Neither is pushed by anything: only a moving kinematic body reaching a sleeping one makes a pair (waking it).
        const bool wakes = (A.kinematic && moving(A) && B.asleep && !B.kinematic) ||
                           (B.kinematic && moving(B) && A.asleep && !A.kinematic);
        if (!wakes) continue;
      }
      if (!mayCollide(ctx, i, j)) continue;
      if (A.asleep) wakeList.push_back(i);
      if (B.asleep) wakeList.push_back(j);
      pairKeys.push_back(static_cast<uint64_t>(std::min(i, j)) << 32 | static_cast<uint64_t>(std::max(i, j)));
    }
  }
  for (int i : wakeList) ctx.wake(i);
  std::sort(pairKeys.begin(), pairKeys.end());
  // Too many pairs (thousands of bodies piled into one spot): keep maxPairs of
  // them, those with a body that nothing pushes (the ground) first, then in key
  // order; the rest pass through each other this substep (StepStats::droppedPairs).
  const size_t maxPairs = static_cast<size_t>(std::max(0, ctx.settings.maxPairs));
  if (pairKeys.size() > maxPairs) {
    ctx.stats.droppedPairs += static_cast<int>(pairKeys.size() - maxPairs);
    auto anchoredPair = [&](uint64_t key) {
      return !bodies[static_cast<size_t>(key >> 32)].dynamic() || !bodies[static_cast<size_t>(key & 0xffffffffu)].dynamic();
    };
    std::stable_partition(pairKeys.begin(), pairKeys.end(), anchoredPair);
    pairKeys.resize(maxPairs);
    std::sort(pairKeys.begin(), pairKeys.end());
  }
  // Pairs that already existed keep their candidate lists (both sorted by a, b).
  std::vector<Pair>& pairs = ctx.pairs;
  std::vector<Pair>& previousPairs = ctx.previousPairs;
  std::swap(pairs, previousPairs);
  pairs.resize(pairKeys.size());
  size_t k = 0;
  for (size_t pi = 0; pi < pairKeys.size(); ++pi) {
    Pair& p = pairs[pi];
    p.a = static_cast<int>(pairKeys[pi] >> 32);
    p.b = static_cast<int>(pairKeys[pi] & 0xffffffffu);
    while (k < previousPairs.size() &&
           (previousPairs[k].a < p.a || (previousPairs[k].a == p.a && previousPairs[k].b < p.b)))
      ++k;
    if (k < previousPairs.size() && previousPairs[k].a == p.a && previousPairs[k].b == p.b) {
      std::swap(p.bInA, previousPairs[k].bInA);
      std::swap(p.aInB, previousPairs[k].aInB);
      p.builtA = previousPairs[k].builtA;
      p.builtB = previousPairs[k].builtB;
      p.builtMargin = previousPairs[k].builtMargin;
    } else {
      p.bInA.clear();
      p.aInB.clear();
      p.builtMargin = -1;
    }
  }
}

double stepTravel(StepContext& ctx, double h) {
  const std::vector<RigidBody>& bodies = ctx.bodies;
  const size_t n = bodies.size();
  // Per body: bounds swept over the step (the pose now and moved by h v + h^2 a, widened by how far a turn at
  // |omega| moves its points) and the bound of its own travel's parts.
  struct Swept {
    Aabb box;
    glm::dvec3 v{0}, a{0};
    double turn = 0;  // |omega| R h
  };
  std::vector<Swept> swept(n);
  std::vector<int> order;
  order.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const RigidBody& b = bodies[i];
    if (b.removed) continue;
    Swept& s = swept[i];
    s.box = worldBounds(*b.shape, b.localCom, {b.x, b.q});
    if (b.movable()) {
      s.v = b.v;
      s.a = ctx.acceleration(static_cast<int>(i));
      s.turn = glm::length(b.w) * b.shape->boundingRadius * h;
      const glm::dvec3 d = h * s.v + h * h * s.a;
      s.box.lo = glm::min(s.box.lo, s.box.lo + d) - s.turn - 0.005;
      s.box.hi = glm::max(s.box.hi, s.box.hi + d) + s.turn + 0.005;
    }
    order.push_back(static_cast<int>(i));
  }
  std::sort(order.begin(), order.end(), [&](int x, int y) {
    const double bx = swept[static_cast<size_t>(x)].box.lo.x, by = swept[static_cast<size_t>(y)].box.lo.x;
    return bx != by ? bx < by : x < y;
  });
  double worst = 0;
  const double fraction = ctx.settings.substepFraction;
  for (size_t oi = 0; oi < order.size(); ++oi) {
    const size_t i = static_cast<size_t>(order[oi]);
    const Swept& si = swept[i];
    const RigidBody& A = bodies[i];
    for (size_t oj = oi + 1; oj < order.size(); ++oj) {
      const size_t j = static_cast<size_t>(order[oj]);
      const Swept& sj = swept[j];
      if (sj.box.lo.x > si.box.hi.x) break;
      if (sj.box.lo.y > si.box.hi.y || si.box.lo.y > sj.box.hi.y || sj.box.lo.z > si.box.hi.z ||
          si.box.lo.z > sj.box.hi.z)
        continue;
      const RigidBody& B = bodies[j];
      if (!A.movable() && !B.movable()) continue;
      const double travel = h * glm::length(sj.v - si.v) + h * h * glm::length(sj.a - si.a) + si.turn + sj.turn;
      const double allowed =
          fraction * std::max(std::min(A.shape->halfThickness(), B.shape->halfThickness()), 1e-4);
      worst = std::max(worst, travel / allowed);
    }
  }
  // Joined bodies, wherever they are, by each one's own travel (not the relative one): the joint solve is
  // linearised about the substep's start, and a swinging chain's links move together but turn (a 100 kg body
  // on 1 kg links tore the chain apart when its substeps went by relative travel).
  const double g = glm::length(ctx.settings.gravity);
  auto own = [&](int i) {
    const Swept& s = swept[static_cast<size_t>(i)];
    return bodies[static_cast<size_t>(i)].movable() ? h * (glm::length(s.v) + g * h) + s.turn : 0.0;
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
    // What matters is B's motion relative to A: two bodies falling side by
    // side do not approach each other however fast they fall.
    auto spin = [&](const RigidBody& b) {
      return b.movable() ? glm::length(b.w) * b.shape->boundingRadius + 2 * g * h : 0.0;
    };
    const glm::dvec3 va = A.movable() ? A.v : glm::dvec3(0), vb = B.movable() ? B.v : glm::dvec3(0);
    // Twice the bound on the relative motion this step, plus a little.
    const double margin = 2 * h * (glm::length(vb - va) + spin(A) + spin(B)) + 0.005;
    // The skin: a tenth of the smaller body's thinnest half thickness.
    const double skin = 0.1 * std::min(A.shape->halfThickness(), B.shape->halfThickness());
    if (pair.builtMargin >= 0) {
      const double ra = A.shape->boundingRadius + glm::length(A.localCom) + pair.builtMargin;
      const double rb = B.shape->boundingRadius + glm::length(B.localCom) + pair.builtMargin;
      const double moved = relativeDisplacementBound(pair.builtA, {A.x, A.q}, ra, pair.builtB, {B.x, B.q}, rb);
      if (moved + margin <= pair.builtMargin) continue;  // the lists still hold every sample that can touch
    }
    const double built = margin + skin;
    auto collect = [&](const RigidBody& owner, const RigidBody& other, std::vector<uint32_t>& list) {
      list.clear();
      const Shape& so = *owner.shape;
      const Shape& st = *other.shape;
      const double r = st.sampleRadius;
      const glm::dvec3 lo = so.boundsMin - r - built, hi = so.boundsMax + r + built;
      const glm::dmat3 rot = glm::transpose(owner.rotation());
      const glm::dmat3 rt = other.rotation();
      const glm::dmat3 m = rot * rt;
      const glm::dvec3 offset = rot * (other.x - owner.x - rt * other.localCom) + owner.localCom;
      auto test = [&](uint32_t k) {
        const glm::dvec3 local = m * st.samples[k] + offset;
        if (local.x < lo.x || local.y < lo.y || local.z < lo.z || local.x > hi.x || local.y > hi.y || local.z > hi.z)
          return;
        if (so.distance(local) - r > built) return;
        list.push_back(k);
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
    collect(A, B, pair.bInA);
    collect(B, A, pair.aInB);
    pair.builtA = {A.x, A.q};
    pair.builtB = {B.x, B.q};
    pair.builtMargin = built;
  }
  });
}

}  // namespace crumple::detail
