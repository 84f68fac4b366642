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

#include <crumple/physics/body.h>
#include <crumple/physics/impulse.h>
#include <crumple/physics/joint.h>
#include <crumple/physics/types.h>

namespace crumple {

namespace detail {
struct StepContext;
class ThreadPool;
}

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
  using CollisionFilter = crumple::CollisionFilter;
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
  // not zero, or a new pose, wakes the body (static bodies never wake). A new pose that opens a joint is closed
  // from the next step (at up to maxCorrectionSpeed).
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
  using NormalModifier = crumple::NormalModifier;
  void setNormalModifier(NormalModifier modifier);
  void setBumpNormals(int body, bool on);
  // Dented surfaces (the world feels its dents): contacts on a body flagged with setDented are measured against
  // its surface displaced along the normal, on either side of the pair. `depth(body, point, normal, bent)`
  // answers how far the dented surface at a point of the undented one (shape frame, with its outward normal)
  // lies below it (m; negative where it rises) and sets `bent` to the dented surface's outward normal there
  // (shape frame). The step calls it from its threads at once: it must only read. Its answers at a body's own
  // surface samples are kept until setDented is called for that body again (or setSurfaceDepth): call it
  // whenever the body's dents change.
  using SurfaceDepth = crumple::SurfaceDepth;
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
