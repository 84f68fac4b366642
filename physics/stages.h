// The stages of a step (internal to the physics library), each reading and writing the StepContext
// (step_context.h).
//
// The stages, one file each, in the order World::step and World::substep
// (world_step.cpp) run them (docs/architecture.md has the same table):
//   World::step, once a step:
//     broad_phase.cpp        stepTravel        (substeps: only pairs that can meet count)
//   World::substep, every substep:
//     world_step.cpp         the world inverse inertias
//     broad_phase.cpp        findPairs
//     islands.cpp            findIslands       (the units the passes run in parallel)
//     broad_phase.cpp        findCandidates    (the passes skip pairs that cannot touch: mayTouch)
//     joint_step.cpp         findAnchored      (bodies welded to the world or to static bodies)
//     without joints: World::collideAndContact (world_step.cpp), island by island:
//       collision_step.cpp   CollisionRun      (narrow_phase.cpp, polytope.cpp find the contacts)
//       contact_step.cpp     integrateVelocity of the island's bodies, then ContactRun;
//     then the bodies in no island (integrateVelocity) and ContactRun::finish (resting_solve.cpp)
//     with joints: each stage over every island before the next,
//       collision_step.cpp   collide
//       contact_step.cpp     integrateVelocities
//       joint_step.cpp       preStabilize      (joints: motors, limits, end-of-step targets)
//       contact_step.cpp     contactStep       (ends with resting_solve.cpp's restingSolve)
//     shock_propagation.cpp  shockPropagation
//     joint_step.cpp         preStabilize again (what the contacts moved)
//     position_step.cpp      endOfStepDepths, integratePositions, projectPositions
//     joint_step.cpp         postStabilize
//     sleep.cpp              updateSleep
//   World::step, after the substeps: when any body's state left finite numbers, the whole
//     step is undone (world_step.cpp, checkFinite) and its StepStatus names the body.
// Each file opens with what its stage guarantees.
#pragma once
#include <algorithm>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include <crumple/physics/step_context.h>

namespace crumple::detail {

// narrow_phase.cpp: the contacts of a pair at the given poses, testing only its
// candidate samples (both directions), deepest first.
// Returns whether they came from the two convex polytopes' manifold (polytope.h) rather than the samples.
// With `clear`: how far the bodies' points may move, relative to each other, before a look can find a contact
// (< 0: no such bound; lookAtPair keeps a look that found nothing by it).
bool pairContacts(const StepContext& ctx, Pair& pair, const PoseFrame& pa, const PoseFrame& pb,
                  std::vector<Contact>& out, double* clear = nullptr);
// Whether the pair can touch at all this substep: two polytopes (their manifold needs no lists), or a candidate
// sample on either side, or a capsule segment in reach (findCandidates). Else every look finds nothing: the
// collision and contact passes do not look (pairContacts would find nothing, at the cost of its setup).
inline bool mayTouch(const StepContext& ctx, const Pair& pair) {
  return !pair.bInA.empty() || !pair.aInB.empty() || pair.bSegmentNear || pair.aSegmentNear ||
         (ctx.body(pair.a).shape->polytope && ctx.body(pair.b).shape->polytope);
}
// The same contacts, where the pair's last look (Pair::kept: a manifold, or the samples' contacts of a pair with
// no ball in it, no sweep, no bent normals and no dents) was made at poses from which the bodies have moved less
// than contactRefreshTolerance: its points carried along with the two bodies and their depths measured again
// along their normals (the incident point from the reference face's plane, as the manifold's clipping finds
// them; a sample's point from its owner's surface point; those no longer below it dropped). Resting contact
// needs no new look until it moves. Else a new look, kept.
void lookAtPair(const StepContext& ctx, Pair& pair, const PoseFrame& pa, const PoseFrame& pb,
                std::vector<Contact>& out);
// narrow_phase.cpp: forgets the kept answers at the surface samples (StepContext::sampleDents) of each body
// whose dents changed since (World::setDented, setSurfaceDepth).
void forgetSurfaceAnswers(StepContext& ctx);
// Which of a pair's two sample sets the narrow phase tests: B's samples in A's field (bInA), A's in B's (aInB).
// Both, except where one body is a sphere or a capsule and the other convex (box, sphere, capsule, cylinder, convex mesh):
// the sphere's centre against the other's field finds their one deepest point exactly, and the other's surface
// samples inside the sphere only repeat it (more contacts for the one point, more work in every pass). Likewise a
// capsule against a convex shape: its core samples (a radius apart along its axis) and its core segment's point
// deepest in the other's field (segmentA / segmentB: that body is the capsule). A rounded body whose normals a
// bump map bends keeps both sides (its own field's normals are the bent ones).
struct SampleSides {
  bool bInA = true, aInB = true;
  bool segmentA = false, segmentB = false;
};
SampleSides sampleSides(const Shape& a, bool bumpA, const Shape& b, bool bumpB);
// broad_phase.cpp
void findPairs(StepContext& ctx, double h);
void findCandidates(StepContext& ctx, double h);
// The largest ratio, over pairs whose bounds swept over a step of h overlap, of their relative travel in the
// step to what one substep may take (0: no such pair).
double stepTravel(StepContext& ctx, double h);
// islands.cpp
void findIslands(StepContext& ctx);
// collision_step.cpp: collide runs a CollisionRun over every island. True when any impulse was applied.
bool collide(StepContext& ctx, double h);
// The collision step island by island: island(k, worker) for every island (any order, any threads), then finish
// (the events in the order one sweep over all pairs makes them).
class CollisionRun {
 public:
  CollisionRun(StepContext& ctx, double h);
  void island(size_t island, int worker);
  bool finish();

 private:
  // An event as a worker first made it: the pass and pair it came from give its place in ctx.events.
  struct PendingEvent {
    int pass = 0;
    size_t pair = 0;
    CollisionEvent event;
  };
  StepContext& ctx_;
  double h_;
  std::vector<int> eventOfPair_;
  // Per worker, each on its own cache line (workers write theirs at every island: shared lines would bounce
  // between the cores): its events, and whether it applied an impulse.
  struct alignas(64) WorkerState {
    std::vector<PendingEvent> events;
    bool any = false;
  };
  std::vector<WorkerState> workers_;
};
// Hits the collision step's passes could not stop (a light body pinned between a heavy one and the ground: each
// pass moves the impulse through it a little), stopped by the contact step, its island solve and shock
// propagation instead: for each pair that has an event this substep or whose groups approached faster than
// eventMinApproachSpeed and 2 g h when the contact step first looked at them, in an island a blow struck (some
// pair's contacts approached that fast at the step's start), the normal impulse those stages pushed it apart
// with, at most the blow's momentum, is added to its event (made where there is none, at its deepest group, with
// the poses it was found at): to the impulse, and twice over to the elastic impulse (an elastic bounce pushes
// twice as hard). Called after shock propagation.
void collisionsCarried(StepContext& ctx, double h);
// contact_step.cpp: integrateVelocities over every body; contactStep runs a ContactRun over every island.
void integrateVelocities(StepContext& ctx, double h);
void integrateVelocity(StepContext& ctx, size_t body, double h);  // one movable body's (else nothing)
void contactStep(StepContext& ctx, double h);
// One worker's scratch over a contact step (on cache lines of its own: a worker resizes its vectors at every
// island, and a line shared with the next worker's would bounce between their cores).
struct alignas(64) ContactScratch {
  std::vector<Contact> fresh;
  std::vector<ContactGroup> old;
  std::vector<char> inherited;
  std::vector<double> mu;  // the island's pairs' friction
  std::vector<uint32_t> touching;  // the island's pairs (their places in it) with contact groups, since the last find
};
// The contact step island by island: start (with the velocities it begins from: all bodies', or each island's
// bodies through startIsland before its island), island(k, worker) for every island, then finish.
class ContactRun {
 public:
  ContactRun(StepContext& ctx, double h);
  void start();                     // every body's velocities as the step begins
  void startBody(size_t i);         // one body's (the bodies of an island before it runs)
  void island(size_t island, int worker);
  void finish();                    // the island solve, counts and reports
  // Said by a caller that integrates each island's velocities right after its collision step (startBody) and
  // changes no velocity between the two: the first pass's reused contacts were then found at the poses the
  // velocities the island starts with predict, and a refresh may judge them by velocities alone (stillAtLook).
  void reusedPosesAtVelocities() { reusedKnown_ = true; }

 private:
  StepContext& ctx_;
  double h_;
  bool reusedKnown_ = false;
  bool stillAtLook(size_t pair) const;
  std::vector<ContactScratch> scratch_;  // per worker
  bool reporting_ = false, resting_ = false;
  std::vector<double> pushed_;    // per pair, when reporting
  std::vector<glm::dvec3> v0_, w0_;  // the velocities the step began with (the island solve's; stillAtLook's)
  uint64_t run_ = 0;                 // this run's StepContext::contactRuns (its ContactPrediction stamps)
  const PoseFrame& predict(size_t body);
};
// resting_solve.cpp (called by contactStep with the velocities it began with)
void restingSolve(StepContext& ctx, const std::vector<glm::dvec3>& v0, const std::vector<glm::dvec3>& w0, double h);
// Whether the resting solve takes the islands a body of this shape is in: a convex mesh block (masonry) or a
// plate (a box whose thinnest side is at most a quarter of its middle one: a card, a slab, a plank).
bool loadBearing(const Shape& shape);
// shock_propagation.cpp
// flat: every dynamic body on level 1 (only static, kinematic and sleeping bodies frozen: impulses between
// dynamic bodies push both, as in the contact step).
void shockPropagation(StepContext& ctx, double h, bool flat = false);
// joint_step.cpp
// Whether a contact group touches an end of an active joint: the second pre-stabilisation (first = false) and
// settleJoinedContacts are called only then.
bool jointsTouched(StepContext& ctx);
void preStabilize(StepContext& ctx, double h, int sweeps, bool first);
void postStabilize(StepContext& ctx, double h);
// Contacts and joints settled together after the second pre-stabilisation (WorldSettings::jointContactRounds).
void settleJoinedContacts(StepContext& ctx, double h);
void projectJoints(StepContext& ctx, std::vector<glm::dvec3>& moved, double reach, bool first);
bool anyJointActive(const StepContext& ctx);  // a joint not removed or broken with a dynamic body
void findAnchored(StepContext& ctx);
// Whether bodies a and b may collide (groups, joints, and unless askFilter is false the user's filter). Safe on
// several threads at once after refreshJointExclusions (which rebuilds the joined pairs' list when joints
// changed), unless a user's filter is asked (ctx.filter: called as the user gave it).
void refreshJointExclusions(StepContext& ctx);
// (Inline: the broad phase asks it of every overlapping pair every substep.)
inline bool mayCollide(StepContext& ctx, int a, int b, bool askFilter = true) {
  const RigidBody& A = ctx.body(a);
  const RigidBody& B = ctx.body(b);
  if (A.removed || B.removed) return false;
  if (!(ctx.groupMasks[static_cast<size_t>(A.group)] >> B.group & 1ull)) return false;
  if (ctx.jointExcludedDirty) refreshJointExclusions(ctx);
  if (!ctx.jointExcluded.empty()) {
    const uint64_t key = static_cast<uint64_t>(std::min(a, b)) << 32 | static_cast<uint64_t>(std::max(a, b));
    if (std::binary_search(ctx.jointExcluded.begin(), ctx.jointExcluded.end(), key)) return false;
  }
  if (askFilter && ctx.filter && !ctx.filter(std::min(a, b), std::max(a, b))) return false;
  return true;
}
// position_step.cpp
void endOfStepDepths(StepContext& ctx, double h);
void integratePositions(StepContext& ctx, double h);
void projectPositions(StepContext& ctx, double h);
// sleep.cpp
void updateSleep(StepContext& ctx, double h);

}  // namespace crumple::detail
