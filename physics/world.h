// The simulator: Guendelman, Bridson & Fedkiw 2003, stage by stage (see
// docs/architecture.md, "One step of the physics"). One call to step(h):
//
//   1. collide:    up to `collisionPasses` passes on predicted positions with
//                  restitution min(eps_A, eps_B); one CollisionEvent per colliding pair
//   2. velocities: v += h g
//   3. contact:    `contactPasses` passes with restitution ramped -1 -> 0; a
//                  face contact acts as a patch (patchImpulse: no tilt or twist
//                  beyond what its extent and friction can hold)
//   4. shock propagation: contact graph levels from the static bodies up, lower
//                  levels frozen (infinite mass) while a level is processed
//   5. positions:  x += h v, q integrated from omega; then a small positional
//                  projection removes what penetration is left (no velocity change)
//   6. sleeping:   islands whose bodies all stayed still for `sleepTime` freeze
//
// Joints (physics/joint.h; Weinstein, Teran & Fedkiw 2006) join the step as
// impulses: after 2, pre-stabilisation finds the joints' impulses that make
// them hold at the end of the step (motors first; Newton steps that solve all
// joints at once, a direct solve over the joint graph, until the largest
// violation is under `jointTolerance`); again
// after 4 for what the contacts moved; after 5, post-stabilisation removes the
// relative velocity each joint forbids. A joint whose linear impulse over a
// step passes its breakImpulse breaks. Kinematic bodies move with their
// velocities and weigh infinitely much in every impulse.
//
// Steps are split into substeps when a body would move more than a fraction of
// the thinnest body's half thickness (no tunnelling; see `maxSubsteps`).
// Everything runs in a fixed order: the same input gives bit-identical states
// (tests/test_physics_determinism.cpp pins one), whatever WorldSettings::threads
// is: islands of pairs (no movable body in common) and bodies run side by
// side on a pool of threads, each writing its own slots (physics/islands.cpp).
//
// One file per stage, each opening with what it guarantees; what they share is
// physics/step_context.h (internal), which lists them.
#pragma once
#include <glm/glm.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "physics/body.h"
#include "physics/impulse.h"
#include "physics/joint.h"

namespace crumple {

struct WorldSettings {
  glm::dvec3 gravity{0, -9.81, 0};
  int collisionPasses = 5;
  int collisionIterations = 20;  // per pair and pass
  int contactPasses = 10;
  int contactRefresh = 5;  // passes between re-finding contact geometry
  // m: at a refresh, a pair whose predicted relative pose has moved less than
  // this since its last look keeps its geometry (resting contact); 0 re-finds all.
  // Two convex polytopes (boxes, convex meshes) keep their manifold from one step
  // to the next on the same terms: its points move with the bodies and their
  // depths are measured again (StepStats::keptLooks), until the bodies have moved
  // this much from where it was found.
  double contactRefreshTolerance = 0.0005;
  // Shock propagation passes per contact-graph level at most (Jacobi: each body
  // takes the mean of its groups' impulses against the frozen level below, on
  // the contact step's last geometry), each island's level until a pass changes
  // no group's relative velocity by more than shockTolerance (m/s). With it the
  // 10-level pyramid stands with 10 contact passes, sleeping or not, and an
  // A-frame of cards on a light card (tests/test_physics_stacks.cpp); 0 turns it off.
  int shockPasses = 12;
  double shockTolerance = 3e-4;
  // Islands of at most this many contact rows (3 to 6 per contact group; no
  // joints) holding a convex mesh block (masonry) or a plate (a box whose thinnest
  // side is at most a quarter of its middle one: cards) are solved to convergence at
  // the end of the contact step (projected Gauss-Seidel over accumulated
  // impulses, warm-started, resting_solve.cpp): the contact passes alone carry
  // a load one contact a pass, and a ring of blocks (an arch) would sag a
  // little every step. 0 turns it off.
  int restingSolveRows = 192;
  int restingSolveIterations = 1000;
  double restingSolveTolerance = 1e-5;  // m/s: a sweep changing no row's velocity more ends it
  // m/s: an island is solved when the contact step left one of its groups approaching faster than this (or
  // when it was solved the substep before: its totals warm-start the next solve).
  double restingSolveTrigger = 1e-3;
  double penetrationSlop = 0.0005;     // m left alone by the positional projection
  double penetrationCorrection = 0.4;  // fraction removed per projection iteration
  int projectionIterations = 3;
  // m/s: the fastest that corrections move bodies apart. The positional projection translates no body further
  // than this times the substep (deep overlaps part over several steps instead of in one jump), and joint
  // stabilisation closes a joint that starts violated (an anchor gap, a turn, a limit or distance range left)
  // at most this fast (rad/s for turns) beyond what its bodies' velocities already do.
  double maxCorrectionSpeed = 4;
  int maxSubsteps = 16;
  // At most this many pairs of bodies per substep (Jolt's maxBodyPairs): pairs
  // with a static or kinematic body are kept first. Only a pathological pile
  // (thousands of bodies in one spot) reaches it; StepStats::droppedPairs says so.
  int maxPairs = 65536;
  double substepFraction = 0.5;  // of the thinnest half thickness per substep
  // Collisions approaching slower than this still get their impulse but emit no
  // event: the micro-collisions of resting contact are not hits worth a dent or a log line.
  double eventMinApproachSpeed = 0.05;  // m/s
  // A body is still while it stays within sleepLinear x sleepTime / 2 of where its stillness began and turns
  // less than sleepAngular x sleepTime / 2 (1.25 cm, 0.02 rad by default: drifting slower than these speeds
  // half the time, or trembling in place, as a stack's boxes do long after it came to rest); an island whose
  // bodies have all been still for sleepTime, resting on something, sleeps.
  bool sleeping = true;
  double sleepLinear = 0.05;   // m/s
  double sleepAngular = 0.08;  // rad/s
  double sleepTime = 0.5;      // s
  // Joints: pre-stabilisation passes at most (each a Newton step for all
  // joints at once), until every joint's predicted violation is under the
  // tolerance; then post-stabilisation passes over the velocities (one
  // suffices unless limits, distance ranges or joints that close loops take part).
  int jointIterations = 10;
  double jointTolerance = 1e-5;  // m, and rad for the angular parts
  int jointPostIterations = 4;
  // Threads the step runs on (the caller's included; 0: the machine's hardware
  // threads). The results are the same bits for every count: work is split by
  // island and by body, each writing its own slots, merged in a fixed order.
  // With more than one, a NormalModifier is still called from one thread at a time.
  int threads = 1;
};

struct CollisionEvent {
  double time = 0;
  int a = -1, b = -1;           // body indices; a owns the normal
  glm::dvec3 point{0};          // P_C, world
  glm::dvec3 normal{0};         // N_C, unit, out of A
  double penetration = 0;       // d_C >= 0
  double elasticImpulse = 0;    // |j_eps=1|
  double impulse = 0;           // |applied impulse| summed over the pair's iterations
  glm::dvec3 impulseVector{0};  // applied impulse on B
  Pose poseA, poseB;            // poses at collision time (predicted positions)
};

struct Contact {
  int a = -1, b = -1;
  glm::dvec3 point{0}, normal{0};  // normal out of a
  double phi = 0;                  // < 0: penetrating
};

struct Aabb {
  glm::dvec3 lo, hi;
};

struct RayHit {
  int body = -1;
  double distance = 0;
  glm::dvec3 point{0}, normal{0};
};

// Wall milliseconds of each stage of the last step, summed over its substeps
// (Box2D's b2Profile). Timing never changes what a step computes.
struct StepProfile {
  double broadPhase = 0;        // pairs: sweep and prune on bounds
  double candidates = 0;        // the pairs' candidate sample lists (distance queries; most of it for meshes)
  double collide = 0;           // the collision step: narrow phase on predicted poses, restitution impulses
  double contact = 0;           // velocities (v += h g) and the contact step
  double shockPropagation = 0;  // levels from the static bodies up
  double positions = 0;         // position update and positional projection
  double sleep = 0;             // stillness and islands
  double joints = 0;            // pre- and post-stabilisation
  double total = 0;             // the whole step
};

struct StepStats {
  int substeps = 0;
  int pairs = 0;
  int collisions = 0;
  int contacts = 0;
  int awake = 0;
  int jointSweeps = 0;  // pre-stabilisation sweeps, summed over the substeps
  // Joint solves undone for handing the joined bodies more energy than they may: pre-stabilisation calls past
  // what closing the violations they started with (at most maxCorrectionSpeed) and the motors' work allow (their
  // joints then only removed forbidden relative velocity), and direct velocity solves past what kinematic ends
  // drive (their joints then solved one at a time).
  int jointFallbacks = 0;
  int droppedPairs = 0;  // pairs over WorldSettings::maxPairs, summed over the substeps
  int restingSolves = 0;  // islands the contact step solved at once (WorldSettings::restingSolveRows)
  // Narrow-phase looks at pairs (collision and contact steps), and those a kept manifold of two convex
  // polytopes answered: its points carried along, the pair having moved less than contactRefreshTolerance.
  int looks = 0, keptLooks = 0;
  // Islands of pairs (no movable body in common: the units the threads share out), most in a substep,
  // and the pairs of the largest (a step cannot go faster than that island alone).
  int islands = 0, largestIsland = 0;
  StepProfile ms;
};

namespace detail {
struct StepContext;
class ThreadPool;
}

// What World::step reports. A step that would leave a body's state not finite
// (a NaN or an infinity: a force, a joint or a contact driven past what doubles
// hold) is not taken: every body is put back as it was before the step, the
// step's events and reports are dropped, the time does not advance, and the
// status names the first such body with its state before the step (the last
// finite one).
struct StepStatus {
  bool ok = true;
  int body = -1;                 // the first body whose state stopped being finite
  Pose lastPose;                 // its state before the step
  glm::dvec3 lastVelocity{0}, lastAngularVelocity{0};
  explicit operator bool() const { return ok; }
};

// The whole state of a World (bodies, joints, filters, the caches kept between
// steps): World::restore(snapshot) and the same steps give bit-identical states.
class WorldSnapshot {
 public:
  WorldSnapshot();
  ~WorldSnapshot();
  WorldSnapshot(const WorldSnapshot&);
  WorldSnapshot& operator=(const WorldSnapshot&);

 private:
  friend class World;
  std::shared_ptr<const detail::StepContext> state_;
};

class World {
 public:
  explicit World(const WorldSettings& settings = {});
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  int addBody(const BodyDef& def);  // throws std::invalid_argument on bad input (NaN, non-positive mass)
  // The body stops taking part in anything (no motion, no collisions) and its
  // joints are removed. Its index stays taken (other indices do not move) and
  // bodies()[i].removed says so; body setters on it throw std::invalid_argument.
  void removeBody(int i);

  // Handles (BodyId, JointId): add() may reuse a removed body's or joint's slot
  // (a game that spawns and removes debris keeps its arrays small) and bumps the
  // slot's generation, so a handle to what was removed stays stale: index()
  // throws std::invalid_argument for it and valid() is false. addBody and
  // addJoint never reuse a slot: their plain indices stay unique forever.
  BodyId add(const BodyDef& def);
  void remove(BodyId body);
  bool valid(BodyId body) const;
  int index(BodyId body) const;
  BodyId bodyId(int index) const;  // the handle of the body now in slot `index`
  JointId add(const JointDef& def);
  void remove(JointId joint);
  bool valid(JointId joint) const;
  int index(JointId joint) const;
  JointId jointId(int index) const;  // the handle of the joint now in slot `index`
  // Advances the world by h seconds (std::invalid_argument unless h is positive and finite). A step that would
  // make any body's state non-finite is refused and undone (StepStatus): the world never holds a NaN.
  StepStatus step(double h);

  // Joints (physics/joint.h). addJoint throws std::invalid_argument on bad
  // input (an unknown body, a = b, a zero axis, lower > upper, a negative
  // breakImpulse or minLength > maxLength, a motor with negative maxForce) and
  // returns the joint's id. removeJoint frees it for good (ids are not reused).
  int addJoint(const JointDef& def);
  void removeJoint(int joint);
  size_t jointCount() const;  // ids handed out, removed ones included
  bool jointRemoved(int joint) const;
  const JointDef& jointDef(int joint) const;  // as added (axis normalised; a distance joint's length filled in)
  JointState jointState(int joint) const;
  void setJointMotor(int joint, const JointMotor& motor);
  // Joints that broke in the last step.
  const std::vector<JointBreak>& jointBreaks() const;

  // Kinematic bodies (BodyDef::kinematic): sets the velocities that take body i
  // to `target` (centre of mass) over the next step of h; keyframed paths call
  // it every step.
  void setKinematicTarget(int i, const Pose& target, double h);

  // Collision filtering: two bodies collide unless their groups (0..63) are
  // set apart, a joint without collideConnected joins them, or the filter
  // (when set) returns false for them. The filter is asked once per pair whose
  // bounds overlap in a substep; it must be a pure function of (a, b).
  void setGroup(int i, int group);
  void setGroupsCollide(int groupA, int groupB, bool collide);
  using CollisionFilter = std::function<bool(int a, int b)>;
  void setCollisionFilter(CollisionFilter filter);

  // Save and restore everything (WorldSnapshot).
  WorldSnapshot snapshot() const;
  void restore(const WorldSnapshot& snapshot);

  const std::vector<RigidBody>& bodies() const;
  const RigidBody& body(int i) const;  // throws std::out_of_range for a bad index
  size_t size() const;
  WorldSettings& settings();
  const WorldSettings& settings() const;
  double time() const;
  // Setters of a body's state; each throws std::invalid_argument on a value
  // that is not finite (std::out_of_range for a bad index). A velocity that is
  // not zero, or a new pose, wakes the body (static bodies never wake).
  void setVelocity(int i, const glm::dvec3& v);         // of the centre of mass
  void setAngularVelocity(int i, const glm::dvec3& w);  // rad/s, world
  void setPose(int i, const Pose& pose);                // centre of mass and orientation (normalised)
  void setRestitution(int i, double restitution);       // in [0, 1]
  void setFriction(int i, double friction);             // >= 0
  // Events of the last step (all substeps).
  const std::vector<CollisionEvent>& events() const;
  // Resting contacts of the last step that involve a body flagged with
  // setReportContacts (contact deformation, the paper's figure 8): one per
  // touching pair, the deepest contact group, with the normal impulse the
  // contact step applied there (elasticImpulse holds twice that: the impulse
  // the same push would have had as an elastic collision).
  const std::vector<CollisionEvent>& contactReports() const;
  void setReportContacts(int body, bool on);
  // Normal-mapped collision normals (Wrotek et al. section 5): contacts on a
  // flagged body take their normal from this function of (body, point on its
  // surface, geometric normal), both in its shape frame. Off by default: it
  // makes bodies roll down slopes that exist only in the bump map (figure 10).
  using NormalModifier = std::function<glm::dvec3(int body, const glm::dvec3& point, const glm::dvec3& normal)>;
  void setNormalModifier(NormalModifier modifier);
  void setBumpNormals(int body, bool on);
  // Dented surfaces (the world feels its dents): contacts on a body flagged with setDented are measured against
  // its surface displaced along the normal, on either side of the pair. `depth(body, point, normal, bent)`
  // answers how far the dented surface at a point of the undented one (shape frame, with its outward normal)
  // lies below it (m; negative where it rises) and sets `bent` to the dented surface's outward normal there
  // (shape frame). The step calls it from its threads at once: it must only read.
  using SurfaceDepth = std::function<double(int body, const glm::dvec3& point, const glm::dvec3& normal,
                                            glm::dvec3& bent)>;
  void setSurfaceDepth(SurfaceDepth depth);
  // maxRise >= 0: body i is dented within `region` (shape frame: the undented surface over its dented texels),
  // its surface rising at most maxRise (m) above the undented one anywhere (a crater's rim; 0 where dents only
  // lower it); < 0: not (the default). Pairs whose bounds do not meet the region keep the undented shapes'
  // contacts, bit for bit.
  void setDented(int body, double maxRise, const Aabb& region = {glm::dvec3(-1e300), glm::dvec3(1e300)});
  const StepStats& lastStats() const;
  void wake(int i);
  // A hash of every body's state, for determinism checks.
  uint64_t stateHash() const;
  // Applied to body i at the next step only (vehicle forces, user pushes): force at a world point.
  // Each throws std::invalid_argument on a value that is not finite.
  void addForceAtPoint(int i, const glm::dvec3& force, const glm::dvec3& point);
  void addForce(int i, const glm::dvec3& force);
  void addTorque(int i, const glm::dvec3& torque);

  // First surface along a ray (unit direction) within maxDistance, skipping body
  // `ignore`; sphere tracing through the bodies' distance fields. On a dented body
  // (setDented), the dented surface and its normal (a vehicle's wheel drops into a rut).
  bool raycast(const glm::dvec3& origin, const glm::dvec3& direction, double maxDistance, int ignore,
               RayHit& hit) const;

  // Finds the contacts between a and b at the given poses, all penetrating
  // sample points (both directions), deepest first.
  void findContacts(int a, int b, const Pose& pa, const Pose& pb, std::vector<Contact>& out) const;

 private:
  void substep(double h);
  void collideAndContact(double h);  // the collision and contact steps island by island (no joints)
  // Everything else: the bodies, the caches kept between steps and the state
  // the stages share (physics/step_context.h).
  std::unique_ptr<detail::StepContext> ctx_;
  // The threads of WorldSettings::threads beyond the caller's (made at the first step that asks for them).
  std::unique_ptr<detail::ThreadPool> pool_;
};

}  // namespace crumple
