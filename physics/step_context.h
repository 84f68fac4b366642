// What the stages of a step share (internal to the physics library; Box2D's
// b2StepContext). The World is a facade over one StepContext: the bodies and
// what the API reads back live here too, beside the caches kept from one step
// to the next (pairs and their candidate lists, the broad phase's grid) and the state
// of the substep under way (world inverse inertias, frozen flags, predicted
// poses, the contact groups, the poses at the start of the position update).
//
// The stages that read and write it are declared in stages.h (included at the end), in the order they run.
#pragma once
#include <glm/glm.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include <crumple/physics/body.h>
#include <crumple/physics/contact_groups.h>
#include <crumple/physics/impulse.h>
#include <crumple/physics/joint.h>
#include <crumple/physics/thread_pool.h>
#include <crumple/physics/disjoint_sets.h>
#include <crumple/physics/types.h>

namespace crumple::detail {

// The broad phase's hashed grid (broad_phase.cpp), kept for its allocations.
struct BroadGrid {
  struct Cell {
    int64_t x = 0, y = 0, z = 0;
  };
  std::vector<double> sides;
  std::vector<Cell> lo, hi;  // per box, its cell range (lo > hi: a large box, kept aside)
  std::vector<int> large, items;
  std::vector<uint32_t> bucketCount, bucketList;  // per box: its buckets' count and (up to 8 of) them
  std::vector<uint32_t> start, fill;
  std::vector<std::vector<uint64_t>> found;  // per range (of boxes, of kept pairs): its pairs (a << 32 | b)
  std::vector<char> active;  // per body: can make a pair (findPairs)
  // findPairs' kept superset (Box2D's fat AABBs): per body a box around its bounds with a skin, and every pair
  // of those boxes that overlap with a body active then. Valid while each body's bounds stay in its fat box
  // and no body inactive then is active now (a body added into a removed one's slot is held to the same test):
  // the pairs are those of the fat list whose bounds overlap.
  // A few bodies out of their fat boxes get new ones alone, their pairs found against every fat box (the others'
  // fat boxes and pairs stay: still a superset).
  std::vector<Aabb> fat;
  std::vector<char> fatActive;
  std::vector<uint64_t> fatKeys;
  std::vector<char> rangeInside;  // per range of bodies: all still in their fat boxes
  std::vector<int> outside;       // the bodies out of their fat boxes (a few)
  std::vector<char> isOutside;    // per body
  std::vector<uint64_t> outsideKeys;
};

// A body's state (World::step keeps every body's from before the step).
struct BodyState {
  glm::dvec3 x{0};
  glm::dquat q{1, 0, 0, 0};
  glm::dvec3 v{0}, w{0};
};

// A joint in the positional projection (joint_step.cpp's projectJoints): whether it acts, its anchors' levers and
// a slider's axis in world coordinates (orientations stay put in the projection).
struct ProjectedJoint {
  bool active = false;
  glm::dvec3 rA{0}, rB{0}, axis{0};
};

// A pair of bodies whose bounds overlap (broad phase), at least one movable.
struct Pair {
  int a = -1, b = -1;
  // Samples that can reach the other body during this substep; every pass of
  // the substep tests only these. The lists are built with a skin beyond the
  // margin the substep needs, at the poses builtA/builtB, and kept from one
  // substep to the next while the bodies have moved less than the skin (a
  // Verlet list): the lists then still hold every sample that can touch.
  std::vector<uint32_t> bInA, aInB;
  Pose builtA, builtB;
  double builtMargin = -1;  // < 0: no lists yet
  // Per side, the listed samples that a look can find touching while the bodies stay within `within` of the poses
  // of the look that made it (narrow_phase.cpp nearSamples): the same contacts for a fraction of the samples, look
  // after look (the collision step's passes look at a pair after each impulse near it). Made again with the lists.
  struct NearSamples {
    std::vector<uint32_t> samples;
    Pose owner, other;
    double within = -1;  // < 0: none
    uint32_t lists = 0;  // the lists' generation they were made from (another: not these lists' near samples)
    double reachOwner = 0, reachOther = 0;  // the points' reaches about the centres of mass (nearSamples)
  };
  uint32_t listGeneration = 0;  // counts the lists' builds (findCandidates)
  NearSamples nearBInA, nearAInB;
  // Whether b's (a's) capsule segment may reach a (b) while the lists hold: a core sample came within the lists'
  // reach plus half the core samples' spacing when they were built. (Only for the side sampleSides gives one.)
  bool bSegmentNear = true, aSegmentNear = true;
  // The last full look at a pair (a manifold of two convex polytopes, or the samples' contacts: narrow_phase.cpp
  // lookAtPair), kept from one look, substep and step to the next while the bodies move less than
  // contactRefreshTolerance from where it was made (keptA, keptB): each point in the frames of the body that
  // owns its normal and of the other.
  struct KeptContact {
    bool ownerIsA = true;
    glm::dvec3 onOwner{0}, onOther{0}, normal{0};  // the reference face's point and normal; the incident point
  };
  std::vector<KeptContact> kept;
  Pose keptA, keptB;
  bool hasKept = false;
  // The last look, where it found nothing (narrow_phase.cpp lookAtPair): how far the bodies' points may move
  // relative to each other from its poses (keptA, keptB: a pair keeps contacts or a clearance, never both) before
  // a look can find a contact (< 0: none kept), and the lists' generation it holds for.
  double clearance = -1;
  uint32_t clearLists = 0;
  int looks = 0, keptLooks = 0, clearLooks = 0;  // this substep's (StepStats)
  // Whether a's (b's) dents reach b (a) this substep: set with the lists (findCandidates), used by the narrow phase.
  bool dentsA = false, dentsB = false;
};

// A joint as the solver keeps it: its definition and what it keeps in the
// bodies' frames (body axes about the centre of mass; for the world, a = -1,
// world coordinates).
struct Joint {
  JointDef def;
  bool removed = false, broken = false;
  uint32_t generation = 0;        // JointId
  glm::dvec3 rA{0}, rB{0};        // anchors
  glm::dvec3 axisA{0}, axisB{0};  // the axis (hinge, slider)
  glm::dvec3 refA{0}, refB{0};    // a direction normal to the axis: the hinge angle's zero
  glm::dquat rel0{1, 0, 0, 0};    // conj(qA) qB when added (fixed, slider)
  double angle = 0;               // hinge: unwrapped angle at the end of the last substep
  double length = 0, minLength = 0, maxLength = 0;  // distance
  glm::dvec3 stepImpulse{0};      // linear impulse at the anchor over the step so far
  // This pre- or post-stabilisation call's share: the linear impulse, and the angular impulses it gave B and
  // took from A (levers included: each pass's own levers).
  glm::dvec3 callStart{0}, callLinear{0}, callTurnA{0}, callTurnB{0};
  double motorImpulse = 0;        // this substep's motor impulse (clamped to maxForce h)
  // The kinetic energy pre-stabilisation may still hand the joined bodies to close this joint's violations (its
  // share of a call's gain is taken from here, and the joint calls' losses give it back up to `closingCap`, what
  // closing its last measured violation takes; -1: not yet measured). Only where no kinematic end drives.
  double credit = -1, closingCap = 0;
  // How far beyond the correction's reach it was at the last substep's start (-1: not measured), and whether it
  // came a quarter of a reach nearer since (its credit is then topped up to what closing it takes now).
  double lastBeyond = -1;
  bool progressed = false;
  // The last pre-stabilisation call of this substep held a limit or range row (post-stabilisation then takes away
  // the whole rate along it, the speed that closed a violation with it).
  bool limitHeld = false;
};

// The joint solver's view of the joint graph (joint_solve.cpp): which joints
// are active, the bodies they join and the elimination order, kept from one
// call to the next while the joints and their bodies' states stay the same.
// A copy is empty (it is rebuilt on use: results never depend on it).
struct JointSystem;
struct JointSolverCache {
  std::unique_ptr<JointSystem> system;
  JointSolverCache();
  JointSolverCache(const JointSolverCache&);
  JointSolverCache& operator=(const JointSolverCache&);
  ~JointSolverCache();
};

// ---- helpers the stages share ------------------------------------------------

inline bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
inline bool finite(const glm::dquat& q) {
  return std::isfinite(q.w) && std::isfinite(q.x) && std::isfinite(q.y) && std::isfinite(q.z);
}

// A pose with its rotation matrix, made once where many pairs look at the same pose (the collision and contact
// passes' predicted poses): the narrow phase turns points by the matrix, never by the quaternion again.
struct PoseFrame {
  Pose pose;
  glm::dmat3 rotation{1};
  PoseFrame() = default;
  explicit PoseFrame(const Pose& p) : pose(p), rotation(glm::mat3_cast(p.orientation)) {}
  PoseFrame(const Pose& p, const glm::dmat3& r) : pose(p), rotation(r) {}  // (r: mat3_cast(p.orientation), made)
};

// Shape::distance, a nonconvex mesh's grid asked directly (the samples' tests against a mesh's field: most of the
// lookups a pile of meshes makes).
inline double fieldDistance(const Shape& s, const glm::dvec3& p, glm::dvec3* gradient = nullptr,
                            const glm::dvec3* hint = nullptr,
                            double gradientBelow = std::numeric_limits<double>::infinity()) {
  if (s.type == ShapeType::Mesh && !s.polytope) return s.grid->distance(p, gradient, gradientBelow);
  return s.distance(p, gradient, hint, gradientBelow);
}

inline Aabb worldBounds(const Shape& s, const glm::dvec3& localCom, const glm::dvec3& position, const glm::dmat3& r) {
  const glm::dvec3 c = (s.boundsMin + s.boundsMax) * 0.5, e = (s.boundsMax - s.boundsMin) * 0.5;
  const glm::dvec3 wc = position + r * (c - localCom);
  glm::dvec3 we(0);
  for (int col = 0; col < 3; ++col) we += glm::abs(r[col]) * e[col];
  return {wc - we, wc + we};
}
inline Aabb worldBounds(const Shape& s, const glm::dvec3& localCom, const Pose& pose) {
  return worldBounds(s, localCom, pose.position, glm::mat3_cast(pose.orientation));
}

// The part of the translation `step` that keeps a body's projection so far (`moved`) within `reach` of where it
// started: step itself while moved + step stays inside, else the fraction of it that ends on the sphere.
inline glm::dvec3 withinReach(const glm::dvec3& moved, const glm::dvec3& step, double reach) {
  const glm::dvec3 end = moved + step;
  if (glm::dot(end, end) <= reach * reach) return step;
  // |moved + s step| = reach, s in [0, 1] (moved is inside: the root is the larger one).
  const double a = glm::dot(step, step), b = glm::dot(moved, step), c = glm::dot(moved, moved) - reach * reach;
  if (!(a > 0) || c >= 0) return glm::dvec3(0);
  const double s = (-b + std::sqrt(std::max(0.0, b * b - a * c))) / a;
  return step * std::clamp(s, 0.0, 1.0);
}

inline Aabb merge(const Aabb& a, const Aabb& b) { return {glm::min(a.lo, b.lo), glm::max(a.hi, b.hi)}; }

// An event (or a contact report) at contact c, at `time`, with the poses of c.a and c.b; no impulse yet. Its
// bodies in the order of their indices (the normal out of the first), whichever way the narrow phase found them:
// a pair's events name it the same way every time.
inline CollisionEvent eventAt(const Contact& c, double time, const Pose& poseA, const Pose& poseB) {
  CollisionEvent e;
  const bool swap = c.b >= 0 && c.b < c.a;
  e.time = time;
  e.a = swap ? c.b : c.a;
  e.b = swap ? c.a : c.b;
  e.point = c.point;
  e.normal = swap ? -c.normal : c.normal;
  e.penetration = -c.phi;
  e.poseA = swap ? poseB : poseA;
  e.poseB = swap ? poseA : poseB;
  return e;
}

// A movable body's turn over h from its orientation with angular velocity w: torque-free (rotation.h; the angular
// momentum and kinetic energy kept) for a dynamic body, at constant w for a kinematic one.
inline FreeRotation turn(const RigidBody& b, const glm::dvec3& w, double h) {
  if (b.kinematic) return {rotateBy(b.q, w, h), w};
  return freeRotation(b.principal, b.q, w, h);
}

// The angle of the rotation from one orientation to another.
inline double rotationAngle(const glm::dquat& from, const glm::dquat& to) {
  return 2 * std::acos(std::min(1.0, std::abs(glm::dot(from, to))));
}

// exceeds(rotationAngle(from, to)) for a predicate that is false up to some angle and true beyond it, mostly
// without the arc cosine: 2 acos(x) lies in [2 sqrt(2 (1 - x)), pi sqrt(1 - x)] for x in [0, 1], and where the
// predicate agrees at both ends (widened by far more than rounding) it is the answer. The same answer as
// exceeds(rotationAngle(from, to)) always (the contact step's refreshes and the sleep test are decided this way,
// and the results' bits do not change).
template <class Exceeds>
bool angleExceeds(const glm::dquat& from, const glm::dquat& to, Exceeds&& exceeds) {
  const double u = 1 - std::min(1.0, std::abs(glm::dot(from, to)));
  if (exceeds(2 * std::sqrt(2 * u) * (1 - 1e-9))) return true;
  if (!exceeds(3.141592653589793 * std::sqrt(u) * (1 + 1e-9))) return false;
  return exceeds(rotationAngle(from, to));
}

// The reach of a body's points about its centre of mass (the pose's position), at most: its shape's bounding
// radius about the shape's origin plus the centre of mass's offset from it.
inline double reachAboutCom(const RigidBody& b) { return b.shape->boundingRadius + glm::length(b.localCom); }

// How far B's points near A can have moved in A's frame between two pairs of
// poses: the change of B's offset from A, plus each rotation angle times the
// reach about that body's centre (A's turn moves the points near A by at most
// its angle times ra; B's turn moves its own points by its angle times rb).
inline double relativeDisplacementBound(const Pose& fromA, const Pose& toA, double ra, const Pose& fromB,
                                        const Pose& toB, double rb) {
  const glm::dvec3 offsetChange = (toB.position - toA.position) - (fromB.position - fromA.position);
  return glm::length(offsetChange) + rotationAngle(fromA.orientation, toA.orientation) * ra +
         rotationAngle(fromB.orientation, toB.orientation) * rb;
}
// exceeds(relativeDisplacementBound(...)) for a predicate false up to some value and true beyond it, as
// angleExceeds: bounds on the two angles first, the arc cosines only where the bounds leave it open.
template <class Exceeds>
bool displacementExceeds(const Pose& fromA, const Pose& toA, double ra, const Pose& fromB, const Pose& toB, double rb,
                         Exceeds&& exceeds) {
  const double offset = glm::length((toB.position - toA.position) - (fromB.position - fromA.position));
  const double ua = 1 - std::min(1.0, std::abs(glm::dot(fromA.orientation, toA.orientation)));
  const double ub = 1 - std::min(1.0, std::abs(glm::dot(fromB.orientation, toB.orientation)));
  const double sa = std::sqrt(ua), sb = std::sqrt(ub);
  if (exceeds((offset + 2 * std::sqrt(2.0) * (sa * ra + sb * rb)) * (1 - 1e-9))) return true;
  if (!exceeds((offset + 3.141592653589793 * (sa * ra + sb * rb)) * (1 + 1e-9))) return false;
  return exceeds(relativeDisplacementBound(fromA, toA, ra, fromB, toB, rb));
}

// A contact group's totals from the last island solve: the pair (key a << 32 | b), its normal from a to b,
// the impulse and torque on b.
struct RestingWarm {
  uint64_t key = 0;
  glm::dvec3 normal{0}, impulse{0}, torque{0};
};

// ---- the context ------------------------------------------------------------

struct StepContext {
  // The world's state, as the API sees it.
  WorldSettings settings;
  std::vector<RigidBody> bodies;
  std::vector<glm::dvec3> force, torque;          // per body, applied at the next step only
  std::vector<char> reportContacts, bumpNormals;  // per body flags (empty: none set)
  SurfaceDepth surfaceDepth;  // World::setSurfaceDepth
  std::vector<double> dentRise;      // per body: World::setDented (empty: none set)
  std::vector<Aabb> dentBox;         // per body: where its dents are (shape frame)
  // Per body: surfaceDepth's answer at each of its shape's surface samples (a fixed point with its outward
  // normal: the same question at every contact until the body's dents change), kept the first time a contact
  // asks it (state: 0 not yet, 1 being kept, 2 kept; the threads of a step may ask at once: one keeps, each
  // reads only what is kept). Emptied at the step's start after each setDented (forgetSurfaceAnswers).
  struct SampleDents {
    std::unique_ptr<std::atomic<uint8_t>[]> state;
    mutable std::vector<double> depth;
    mutable std::vector<glm::dvec3> bent;
    bool stale = true;
    SampleDents() = default;
    SampleDents(SampleDents&&) = default;
    SampleDents& operator=(SampleDents&&) = default;
    SampleDents(const SampleDents&) {}  // a copied world asks again
    SampleDents& operator=(const SampleDents&) { return *this = SampleDents(); }
  };
  std::vector<SampleDents> sampleDents;
  NormalModifier normalModifier;
  double minHalfThickness = 1e30;  // of every body added (substep size)
  // A dynamic body of a loadBearing shape was ever added (resting_solve.cpp has work only then).
  bool anyLoadBearing = false;
  double time = 0;
  // Joints (index = id; removed ones stay as holes), what the filter keeps apart.
  std::vector<Joint> joints;
  std::vector<uint64_t> groupMasks = std::vector<uint64_t>(64, ~0ull);  // bit g of groupMasks[f]: f and g collide
  std::vector<uint64_t> jointExcluded;  // sorted pair keys of bodies joined without collideConnected
  bool jointExcludedDirty = false;
  JointSolverCache jointSolver;
  CollisionFilter filter;
  // What the last step produced (all its substeps).
  std::vector<CollisionEvent> events, contactReports;
  std::vector<JointBreak> jointBreaks;
  // This substep, per pair: the place in `events` of the event the collision step made for it (-1: none), how
  // fast its contact groups approached when the contact step first looked at them (m/s; 0: not at all), and the
  // normal impulse shock propagation pushed it apart with (collisionsCarried); per body, the normal impulse a
  // dynamic body took while frozen in shock propagation (what it would have passed on to what holds it up).
  std::vector<int> eventOfPair;
  std::vector<double> pairApproach, shockPush, shockAbsorbed;
  // collisionsCarried's scratch.
  std::vector<size_t> carriedPairs;
  std::vector<std::vector<size_t>> carriedSupports;
  std::vector<double> carriedBlow;
  std::vector<double> carriedPush, carriedWeight;
  std::vector<int> carriedCount;
  std::vector<size_t> carriedSeen;  // per body: the island (+ 1) whose momentum last counted it
  // This step's substeps are capped (maxSubsteps): a body may move past a thin
  // one within a substep, so the narrow phase sweeps (narrow_phase.cpp).
  bool substepsCapped = false;
  // Per body, this substep (empty without joints): welded (fixed joints that
  // hold) to a static body or the world, through any chain of welds.
  std::vector<char> anchored;
  StepStats stats;

  // Broad phase, kept between substeps: bounds per body, the grid's arrays, pair
  // keys (a << 32 | b), the pairs (sorted by a, b) with their candidate lists
  // and the last substep's (whose lists the pairs found again take over).
  std::vector<Aabb> boxes;
  BroadGrid grid;
  std::vector<uint64_t> pairKeys;
  std::vector<Pair> pairs, previousPairs;

  // Threads: the World's pool (null: one thread), set at each step. Work runs
  // on it only where every item writes its own slots (results never depend on
  // the thread count; islands.cpp says why).
  ThreadPool* pool = nullptr;
  // The substep's islands (islands.cpp): island k's pairs are
  // islandPairs[islandStart[k], islandStart[k + 1]), in pair order.
  std::vector<uint32_t> islandStart, islandPairs;
  DisjointSets islandSets;                      // scratch of findIslands
  std::vector<int> islandOfBody, islandOfPair;  // scratch of findIslands
  size_t islandCount() const { return islandStart.empty() ? 0 : islandStart.size() - 1; }
  int workers() const { return pool ? pool->size() : 1; }
  // fn(item, worker) for every item in [0, count), on the pool when there is one.
  // cuts (workers() + 1 item indices, optional): the workers' first blocks (thread_pool.h).
  template <class F>
  void parallel(size_t count, F&& fn, const size_t* cuts = nullptr) {
    if (!pool || pool->size() < 2 || count < 2) {
      for (size_t i = 0; i < count; ++i) fn(i, 0);
      return;
    }
    const std::function<void(size_t, int)> f(std::ref(fn));
    pool->run(count, f, cuts);
  }
  // Cuts of `count` items whose pairs start at first(k) (k < count; first(count) is the total) into
  // workers() blocks of about equal pairs, in workCuts.
  std::vector<size_t> workCuts;
  template <class First>
  const size_t* cutsByPairs(size_t count, First&& first) {
    const size_t threads = static_cast<size_t>(workers());
    workCuts.assign(threads + 1, count);
    const uint64_t total = first(count);
    size_t k = 0;
    for (size_t w = 0; w < threads; ++w) {
      const uint64_t target = total * w / threads;
      while (k < count && first(k) < target) ++k;
      workCuts[w] = k;
    }
    return workCuts.data();
  }
  // `grain`, or less where `count` would not give every worker about 8 chunks of it (at least 128 items a
  // chunk): on many threads a few large chunks would leave most threads idle.
  size_t grainFor(size_t count, size_t grain) const {
    if (workers() < 2) return grain;
    const size_t even = (count + 8 * static_cast<size_t>(workers()) - 1) / (8 * static_cast<size_t>(workers()));
    return std::min(grain, std::max<size_t>(even, 128));
  }
  // fn(begin, end, worker) over [0, count) in chunks of about `grain` items.
  template <class F>
  void parallelRange(size_t count, size_t grain, F&& fn) {
    const size_t chunks = (count + grain - 1) / std::max<size_t>(grain, 1);
    parallel(chunks, [&](size_t k, int worker) { fn(k * grain, std::min(count, (k + 1) * grain), worker); });
  }
  // fn(island, worker) for every island, each worker starting on a block of
  // islands in island order with about equal pairs (the same block in every
  // stage of a substep: its bodies and pairs stay in that core's cache). One
  // thread while a normal modifier is set: the narrow phase calls it, and the
  // user's function need not be safe to call from several threads at once.
  template <class F>
  void forEachIsland(F&& fn) {
    const bool serial = normalModifier && !bumpNormals.empty();
    if (serial || !pool) {
      for (size_t k = 0; k < islandCount(); ++k) fn(k, 0);
      return;
    }
    const size_t* cuts = cutsByPairs(islandCount(), [&](size_t k) { return islandStart[k]; });
    parallel(islandCount(), fn, cuts);
  }

  // fn(first, last, run, worker) for runs of whole islands [first, last) of at least `minPairs` pairs each (the
  // last may have fewer; their pairs lie side by side in islandPairs), numbered `run` from 0, in island order:
  // for stages whose work per island is too small to hand out alone (a pile's columns). One thread while a
  // normal modifier is set, as forEachIsland.
  std::vector<size_t> islandRuns;
  template <class F>
  void forEachIslandRun(uint32_t minPairs, F&& fn) {
    std::vector<size_t>& cuts = islandRuns;
    cuts.assign(1, 0);
    const size_t islands = islandCount();
    // (Smaller runs where the threads would get few: about 8 each, at least 32 pairs a run.)
    if (workers() > 1 && islands > 0) {
      const uint64_t even = islandStart[islands] / (8 * static_cast<uint64_t>(workers()));
      minPairs = static_cast<uint32_t>(std::min<uint64_t>(minPairs, std::max<uint64_t>(even, 32)));
    }
    for (size_t k = 1; k <= islands; ++k)
      if (islandStart[k] - islandStart[cuts.back()] >= minPairs || k == islands) cuts.push_back(k);
    if (normalModifier && !bumpNormals.empty()) {
      for (size_t c = 0; c + 1 < cuts.size(); ++c) fn(cuts[c], cuts[c + 1], c, 0);
      return;
    }
    const size_t* blocks = cutsByPairs(cuts.size() - 1, [&](size_t c) { return islandStart[cuts[c]]; });
    parallel(cuts.size() - 1, [&](size_t c, int worker) { fn(cuts[c], cuts[c + 1], c, worker); }, blocks);
  }

  // Per body, this substep.
  std::vector<glm::dmat3> rotation;    // R(q), at the orientations invInertia is at (while invInertiaNow)
  std::vector<glm::dmat3> invInertia;  // world inverse inertias: orientations stay put until the position update
  // The orientation (bits) a static or sleeping body's rotation and invInertia were last made at: kept while it
  // stays turned so (they depend on nothing else: a body's inertia never changes; a removed one turns static).
  // NaN: none yet.
  std::vector<glm::dquat> rotationAt;
  // The contact step's predictions (ContactRun::predict), per body: the pose its velocities last predicted and
  // those velocities; a body whose velocities no impulse changed since is not turned again (the poses stay put
  // through the passes; an island's bodies are its own). Made in this run where `run` is contactRuns (kept from
  // one run to the next: nothing is cleared per body).
  struct ContactPrediction {
    glm::dvec3 v{0}, w{0};
    PoseFrame frame;
    uint64_t run = 0;
  };
  std::vector<ContactPrediction> contactPredicted;
  uint64_t contactRuns = 0;
  // The pose (bits) a static or sleeping body's bounds (boxes) and prediction (predicted) were last made at by the
  // broad phase: kept while it stays there and does not move. NaN: none (a body that moves, or was woken since).
  std::vector<Pose> boundsAt;
  bool invInertiaNow = false;          // invInertia is at the bodies' orientations (cleared by the position update)
  std::vector<char> frozen;            // infinite mass for the impulses (shock propagation's lower levels)
  std::vector<int> level;              // contact graph level (shock propagation)
  // Impulse counts: every impulse the collision step applies bumps both bodies'.
  std::vector<uint32_t> version;
  // The collision step's predicted poses (and their rotations), valid while predictedVersion == version.
  std::vector<PoseFrame> predicted;
  std::vector<uint32_t> predictedVersion;
  std::vector<Pose> stepStart;  // poses before the position update (sleep test)
  std::vector<BodyState> stepBefore;  // every body before the step (World::step undoes a non-finite one)
  std::vector<BodyState> jointSaved;  // the joined bodies before a pre-stabilisation call (joint_step.cpp)
  std::vector<char> jointJoined;      // per body: an end of a joint that acts (settleJoinedContacts)
  std::vector<char> jointTouched;     // per body: in a pair with contact groups (jointsTouched)
  std::vector<BodyState> jointRoundsSaved;    // every body before settleJoinedContacts' turns
  std::vector<Joint> jointRoundsBooks;        // the joints at the same moment
  DisjointSets jointRoundsSets;               // the systems of bodies joined by contacts and joints to a joined body
  std::vector<int> jointRoundsSystem;         // per body: its system, -1 outside every one
  std::vector<double> jointRoundsEnergy, jointRoundsAfter;  // per system: kinetic energy (and slack) before, after
  std::vector<BodyState> jointVelocitySaved;  // ... before the joints' forbidden velocity is taken away
  std::vector<Joint> jointVelocityBooks;  // the joints' books at the same moment
  std::vector<std::pair<int, double>> jointBreaking;  // joints breaking in a call, with their demand
  std::vector<Joint> jointBooks;      // the joints before it
  std::vector<double> jointClosing;   // per joint of the system a call solves: what closing it takes (energy)
  std::vector<ProjectedJoint> jointProjection;  // per joint: its anchors turned into the world (projectJoints)
  std::vector<char> integrated;  // velocities integrated this substep (World::collideAndContact)
  std::vector<glm::dvec3> projected;  // the positional projection's translations so far
  // The positional projection's scratch (position_step.cpp, squeezedPairs): per pair, 1 where it skips the pair.
  std::vector<char> squeezed;
  std::vector<std::pair<int, glm::dvec3>> squeezeStatic;

  // Per pair, this substep. The collision step's last contacts, found when the
  // two bodies' impulse counts were foundVersion; the contact step's first
  // pass reuses them while those counts have not moved.
  std::vector<std::vector<Contact>> found;
  std::vector<std::pair<uint32_t, uint32_t>> foundVersion;
  // The contact step's groups as last found (shock propagation and the
  // projection work on them), the poses of its last look and the points it found.
  std::vector<std::vector<ContactGroup>> groups;
  std::vector<std::pair<Pose, Pose>> lookPoses;
  // Per pair: which velocities the poses of its last look were predicted from (contact_step.cpp, stillAtLook):
  // kUnknown, kAtStart (the contact step's first velocities: the collision step's poses, reused) or kKept (va,
  // wa, vb, wb: the bodies' velocities when the look predicted its poses).
  struct LookVelocities {
    enum Kind : uint8_t { kUnknown, kAtStart, kKept };
    glm::dvec3 va{0}, wa{0}, vb{0}, wb{0};
    Kind kind = kUnknown;
  };
  std::vector<LookVelocities> lookVelocities;
  std::vector<int> lookCount;
  // The island solve's totals per group (resting_solve.cpp), kept for the next substep's warm start.
  std::vector<RestingWarm> restingWarm;

  RigidBody& body(int i) { return bodies[static_cast<size_t>(i)]; }
  const RigidBody& body(int i) const { return bodies[static_cast<size_t>(i)]; }
  // Whether body i's normals are bent by the normal modifier (World::setBumpNormals and a modifier set).
  bool bentNormals(int i) const {
    return normalModifier && static_cast<size_t>(i) < bumpNormals.size() && bumpNormals[static_cast<size_t>(i)];
  }
  // Whether body i's contacts are measured on its dented surface (World::setDented and a depth set), and the
  // most its surface rises above the undented one (0 when it is not dented).
  bool dented(int i) const {
    return surfaceDepth && static_cast<size_t>(i) < dentRise.size() && dentRise[static_cast<size_t>(i)] >= 0;
  }
  double rise(int i) const { return dented(i) ? dentRise[static_cast<size_t>(i)] : 0.0; }
  // How fast turning at body i's angular velocity can move a point of its shape, at most: the angular speed times
  // the farthest point's distance from the turn's axis through the centre of mass. A box's farthest point is one
  // of its corners (the speed |omega x r| is convex in r), found exactly; a capsule moves only as its axis does (it
  // is the same all round that axis: a spin about it moves no point of the shape, none of its samples and not its
  // distance field), and a sphere turning about its centre not at all. Where a map on the surface turns with the
  // shape (bent normals, dents), and for every other shape: |omega| times its reach about the centre of mass (and
  // the most its dents rise).
  // The substeps ask this (a capsule rolling on its side spins fast about its axis, a tumbling box's corners move
  // slower than its half diagonal turning at right angles to the turn).
  double turnSpeed(int i) const {
    const RigidBody& b = body(i);
    const Shape& s = *b.shape;
    if (!bentNormals(i) && !dented(i)) {
      const glm::dvec3& c = b.localCom;
      if (s.type == ShapeType::Sphere && c == glm::dvec3(0)) return 0.0;
      if (s.type == ShapeType::Capsule && c.x == 0 && c.z == 0) {
        const glm::dvec3 axis = b.rotation()[1];  // (the capsule's axis is its shape's y)
        return glm::length(b.w - glm::dot(b.w, axis) * axis) * (s.halfHeight + std::abs(c.y));
      }
      if (s.type == ShapeType::Box) {
        const glm::dvec3 w = glm::conjugate(b.q) * b.w;  // (in the box's frame)
        const glm::dvec3& e = s.halfExtents;
        if (c == glm::dvec3(0)) {
          // |omega x r|^2 = |omega|^2 |e|^2 - (omega . r)^2 at every corner r: the farthest is the one whose
          // (omega . r)^2 is least, +-x +-y +-z over the signs of x = |omega_x e_x| >= 0 and the others.
          const double x = std::abs(w.x * e.x), y = std::abs(w.y * e.y), z = std::abs(w.z * e.z);
          const double least = std::min({x + y + z, std::abs(x + y - z), std::abs(x - y + z), std::abs(x - y - z)});
          return std::sqrt(std::max(glm::dot(w, w) * glm::dot(e, e) - least * least, 0.0));
        }
        double most = 0;
        for (int k = 0; k < 8; ++k) {
          const glm::dvec3 r = glm::dvec3(k & 1 ? e.x : -e.x, k & 2 ? e.y : -e.y, k & 4 ? e.z : -e.z) - c;
          const glm::dvec3 u = glm::cross(w, r);
          most = std::max(most, glm::dot(u, u));
        }
        return std::sqrt(most);
      }
    }
    return glm::length(b.w) * (reachAboutCom(b) + rise(i));
  }
  // Whether body `owner`'s dents can reach body `other` (its bounds, grown by `margin`, meet the dented part of
  // the owner's surface): pairs far from every dent keep the undented shapes' contacts, bit for bit.
  bool dentsReach(int owner, int other, double margin) const {
    if (!dented(owner)) return false;
    const RigidBody& o = body(owner);
    const RigidBody& t = body(other);
    const Aabb& box = dentBox[static_cast<size_t>(owner)];
    const glm::dvec3 c = glm::transpose(o.rotation()) * (t.x - o.x) + o.localCom;  // the other's centre, owner's frame
    const double r = t.shape->boundingRadius + glm::length(t.localCom) + margin + rise(owner);
    return c.x + r >= box.lo.x && c.y + r >= box.lo.y && c.z + r >= box.lo.z && c.x - r <= box.hi.x &&
           c.y - r <= box.hi.y && c.z - r <= box.hi.z;
  }

  void wake(int i) {
    RigidBody& b = bodies.at(static_cast<size_t>(i));
    if (b.isStatic) return;
    b.asleep = false;
    b.stillTime = 0;
    if (static_cast<size_t>(i) < boundsAt.size())
      boundsAt[static_cast<size_t>(i)].position.x = std::numeric_limits<double>::quiet_NaN();
  }

  glm::dvec3 acceleration(int i) const {
    const RigidBody& b = bodies[static_cast<size_t>(i)];
    if (b.kinematic) return glm::dvec3(0);
    return settings.gravity + force[static_cast<size_t>(i)] * b.invMass;
  }
  // Within a substep: the world inverse inertia is invInertia (orientations
  // stay put until the position update). Torques only: the gyroscopic part of
  // Euler's equations is the torque-free turn of the position update (turn).
  glm::dvec3 angularAcceleration(int i) const {
    const RigidBody& b = bodies[static_cast<size_t>(i)];
    if (b.kinematic) return glm::dvec3(0);
    return invInertia[static_cast<size_t>(i)] * torque[static_cast<size_t>(i)];
  }
  // turn(b, w, h), kept per dynamic body for the last (orientation, w, h) it was asked with within this step
  // (the same bits in, the same bits out): the joint passes' predicted poses and the position update ask the same
  // turn again where no impulse changed w between them (kept only in a world with joints: elsewhere the position
  // update alone asks). A dynamic body is in one island, so one thread asks for it at a time; a kinematic one (in
  // several islands) turns at constant w: not kept.
  struct TurnMemo {
    glm::dquat q{1, 0, 0, 0};
    glm::dvec3 w{0};
    double h = 0;
    uint64_t step = 0;  // turnStep when made (0: never)
    FreeRotation turned;
  };
  mutable std::vector<TurnMemo> turnMemo;
  uint64_t turnStep = 0;  // World::step's count: a memo of an earlier step is stale (the body's inertia may have changed)
  FreeRotation turnOf(const RigidBody& b, const glm::dvec3& w, double h) const {
    const size_t i = static_cast<size_t>(&b - bodies.data());
    if (b.kinematic || i >= turnMemo.size()) return turn(b, w, h);  // (outside a step: nothing kept)
    TurnMemo& m = turnMemo[i];
    if (m.step == turnStep && m.h == h && std::memcmp(&m.w, &w, sizeof w) == 0 &&
        std::memcmp(&m.q, &b.q, sizeof b.q) == 0)
      return m.turned;
    m = {b.q, w, h, turnStep, turn(b, w, h)};
    return m.turned;
  }
  // The pose after h at the current velocities (with this step's accelerations when asked): where the bounds, the
  // collision passes and the contact step look ahead. The orientation turns by exp(h w) at the angular velocity
  // (rotateBy): first order, as the method predicts. The position update alone integrates the torque-free turn
  // (turnOf: angular momentum and energy kept); a body of unequal moments precesses away from the prediction by
  // about h^2 |w|^2 (I_max - I_min) / (4 I_min) in angle over a substep (0.43 mrad at 10 rad/s and 240 Hz where
  // I_max = 2 I_min: 0.13 mm at 0.3 m), inside the 5 mm the bounds are grown by. Two predictions from the same
  // pose are at most h |v1 - v2| apart in offset and h |w1 - w2| in angle (rotateBy is 1-Lipschitz in w),
  // whatever the body's moments: the contact step's refresh reads this from the velocities alone
  // (ContactRun::stillAtLook).
  Pose predict(const RigidBody& b, double h, bool withForces) const {
    if (!b.movable()) return {b.x, b.q};
    const int i = static_cast<int>(&b - bodies.data());
    glm::dvec3 v = b.v, w = b.w;
    if (withForces) {
      v += h * acceleration(i);
      w += h * angularAcceleration(i);
    }
    return {b.x + h * v, rotateBy(b.q, w, h)};
  }

  // RigidBody::kineticEnergy, with the substep's rotation while it holds.
  double kineticEnergy(int i) const {
    const RigidBody& b = body(i);
    return invInertiaNow ? b.kineticEnergyAt(rotation[static_cast<size_t>(i)]) : b.kineticEnergy();
  }
  // Resting contact's own energy scale for a body: its kinetic energy at the speed gravity (at least 1 m/s^2) adds
  // in a substep of h. The energy guards (shock propagation, the resting solve, the joined contacts' turns) allow
  // this much per body: their passes move resting bodies by that speed either way.
  double restingSlack(const RigidBody& b, double h) const {
    const double speed = std::max(glm::length(settings.gravity), 1.0) * h;
    return 0.5 * b.mass * speed * speed;
  }
  // v_B - v_A at the levers' point.
  glm::dvec3 relativeVelocity(int a, int b, const Levers& l) const {
    const RigidBody& A = bodies[static_cast<size_t>(a)];
    const RigidBody& B = bodies[static_cast<size_t>(b)];
    return (B.v + glm::cross(B.w, l.rb)) - (A.v + glm::cross(A.w, l.ra));
  }
  // omega_B - omega_A
  glm::dvec3 relativeSpin(int a, int b) const {
    return bodies[static_cast<size_t>(b)].w - bodies[static_cast<size_t>(a)].w;
  }
  // j on b, -j on a, at the levers' point (frozen bodies do not move).
  void applyImpulse(int a, int b, const Levers& l, const glm::dvec3& j) {
    RigidBody& A = bodies[static_cast<size_t>(a)];
    RigidBody& B = bodies[static_cast<size_t>(b)];
    if (A.movable() && !frozen[static_cast<size_t>(a)]) {
      A.v -= j * A.invMass;
      A.w -= invInertia[static_cast<size_t>(a)] * glm::cross(l.ra, j);
    }
    if (B.movable() && !frozen[static_cast<size_t>(b)]) {
      B.v += j * B.invMass;
      B.w += invInertia[static_cast<size_t>(b)] * glm::cross(l.rb, j);
    }
  }
  // The same with a torque impulse t on b (-t on a) as well: each angular velocity changed once.
  void applyImpulse(int a, int b, const Levers& l, const glm::dvec3& j, const glm::dvec3& t) {
    RigidBody& A = bodies[static_cast<size_t>(a)];
    RigidBody& B = bodies[static_cast<size_t>(b)];
    if (A.movable() && !frozen[static_cast<size_t>(a)]) {
      A.v -= j * A.invMass;
      A.w -= invInertia[static_cast<size_t>(a)] * (glm::cross(l.ra, j) + t);
    }
    if (B.movable() && !frozen[static_cast<size_t>(b)]) {
      B.v += j * B.invMass;
      B.w += invInertia[static_cast<size_t>(b)] * (glm::cross(l.rb, j) + t);
    }
  }
  // t on b, -t on a
  void applyTorqueImpulse(int a, int b, const glm::dvec3& t) {
    RigidBody& A = bodies[static_cast<size_t>(a)];
    RigidBody& B = bodies[static_cast<size_t>(b)];
    if (A.movable() && !frozen[static_cast<size_t>(a)]) A.w -= invInertia[static_cast<size_t>(a)] * t;
    if (B.movable() && !frozen[static_cast<size_t>(b)]) B.w += invInertia[static_cast<size_t>(b)] * t;
  }
  // The two sides of an impulse at the levers' point; a frozen or immovable side has no mass terms.
  void sidesAt(int a, int b, const Levers& l, bool frozenA, bool frozenB, ImpulseSide& sa, ImpulseSide& sb) const {
    const RigidBody& A = bodies[static_cast<size_t>(a)];
    const RigidBody& B = bodies[static_cast<size_t>(b)];
    sa = {};
    sb = {};
    if (A.movable() && !frozenA) {
      sa.invMass = A.invMass;
      sa.invInertia = invInertia[static_cast<size_t>(a)];
    }
    if (B.movable() && !frozenB) {
      sb.invMass = B.invMass;
      sb.invInertia = invInertia[static_cast<size_t>(b)];
    }
    sa.r = l.ra;
    sb.r = l.rb;
  }
  glm::dmat3 collisionMatrixAt(int a, int b, const Levers& l, bool frozenA, bool frozenB) const {
    ImpulseSide sa, sb;
    sidesAt(a, b, l, frozenA, frozenB, sa, sb);
    return collisionMatrix(sa, sb);
  }
  // The impulse with restitution eps (and friction) at contact c; with `elastic`
  // also the size of the frictionless impulse at eps = 1.
  glm::dvec3 contactImpulse(int a, int b, const Contact& c, const Levers& l, double eps, bool frozenA, bool frozenB,
                            double* elastic = nullptr, bool withFriction = true) const {
    const RigidBody& A = bodies[static_cast<size_t>(a)];
    const RigidBody& B = bodies[static_cast<size_t>(b)];
    const glm::dmat3 K = collisionMatrixAt(a, b, l, frozenA, frozenB);
    const glm::dvec3 u = relativeVelocity(a, b, l);
    if (elastic) *elastic = glm::length(frictionlessImpulse(K, u, c.normal, 1.0));
    const double mu = withFriction ? std::sqrt(A.friction * B.friction) : 0.0;
    return frictionImpulse(K, u, c.normal, eps, mu);
  }
};

}  // namespace crumple::detail

#include <crumple/physics/stages.h>
