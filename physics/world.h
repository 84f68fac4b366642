// The simulator: Guendelman, Bridson & Fedkiw 2003, stage by stage (see
// shared/design/guendelman.md). One call to step(h):
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
// Steps are split into substeps when a body would move more than a fraction of
// the thinnest body's half thickness (no tunnelling; see `maxSubsteps`).
// Everything runs single-threaded in a fixed order: the same input gives
// bit-identical states.
#pragma once
#include <glm/glm.hpp>

#include <cstdint>
#include <functional>
#include <vector>

#include "physics/body.h"
#include "physics/impulse.h"

namespace crumple {

struct WorldSettings {
  glm::dvec3 gravity{0, -9.81, 0};
  int collisionPasses = 5;
  int collisionIterations = 20;  // per pair and pass
  int contactPasses = 10;
  int contactRefresh = 5;  // passes between re-finding contact geometry
  // m: at a refresh, a pair whose predicted relative pose has moved less than
  // this since its last look keeps its geometry (resting contact); 0 re-finds all.
  double contactRefreshTolerance = 0.0005;
  // Shock propagation passes per contact-graph level (Jacobi: each body takes
  // the mean of its groups' impulses against the frozen level below, on the
  // contact step's last geometry). With it the 10-level pyramid stands with
  // 10 contact passes, sleeping or not (tests/test_physics.cpp); 0 turns it off.
  int shockPasses = 3;
  double penetrationSlop = 0.0005;      // m left alone by the positional projection
  double penetrationCorrection = 0.4;   // fraction removed per projection iteration
  int projectionIterations = 3;
  int maxSubsteps = 16;
  double substepFraction = 0.5;         // of the thinnest half thickness per substep
  // Collisions approaching slower than this still get their impulse but emit no
  // event: the micro-collisions of resting contact are not hits worth a dent or a log line.
  double eventMinApproachSpeed = 0.05;  // m/s
  bool sleeping = true;
  double sleepLinear = 0.05;   // m/s
  double sleepAngular = 0.08;  // rad/s
  double sleepTime = 0.5;      // s
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

struct StepStats {
  int substeps = 0;
  int pairs = 0;
  int collisions = 0;
  int contacts = 0;
  int awake = 0;
};

class World {
 public:
  explicit World(const WorldSettings& settings = {});
  int addBody(const BodyDef& def);  // throws std::invalid_argument on bad input (NaN, non-positive mass)
  void step(double h);

  const std::vector<RigidBody>& bodies() const { return bodies_; }
  RigidBody& body(int i) { return bodies_.at(static_cast<size_t>(i)); }
  const RigidBody& body(int i) const { return bodies_.at(static_cast<size_t>(i)); }
  size_t size() const { return bodies_.size(); }
  WorldSettings& settings() { return settings_; }
  double time() const { return time_; }
  // Events of the last step (all substeps).
  const std::vector<CollisionEvent>& events() const { return events_; }
  // Resting contacts of the last step that involve a body flagged with
  // setReportContacts (contact deformation, the paper's figure 8): one per
  // touching pair, the deepest contact group, with the normal impulse the
  // contact step applied there (elasticImpulse holds twice that: the impulse
  // the same push would have had as an elastic collision).
  const std::vector<CollisionEvent>& contactReports() const { return contactReports_; }
  void setReportContacts(int body, bool on);
  // Normal-mapped collision normals (Wrotek et al. section 5): contacts on a
  // flagged body take their normal from this function of (body, point on its
  // surface, geometric normal), both in its shape frame. Off by default: it
  // makes bodies roll down slopes that exist only in the bump map (figure 10).
  using NormalModifier = std::function<glm::dvec3(int body, const glm::dvec3& point, const glm::dvec3& normal)>;
  void setNormalModifier(NormalModifier modifier) { normalModifier_ = std::move(modifier); }
  void setBumpNormals(int body, bool on);
  const StepStats& lastStats() const { return stats_; }
  void wake(int i);
  // A hash of every body's state, for determinism checks.
  uint64_t stateHash() const;
  // Applied to body i at the next step only (vehicle forces, user pushes): force at a world point.
  void addForceAtPoint(int i, const glm::dvec3& force, const glm::dvec3& point);
  void addForce(int i, const glm::dvec3& force);
  void addTorque(int i, const glm::dvec3& torque);

  // First surface along a ray (unit direction) within maxDistance, skipping body
  // `ignore`; sphere tracing through the bodies' distance fields.
  bool raycast(const glm::dvec3& origin, const glm::dvec3& direction, double maxDistance, int ignore, RayHit& hit) const;

  // Finds the contacts between a and b at the given poses, all penetrating
  // sample points (both directions), deepest first.
  void findContacts(int a, int b, const Pose& pa, const Pose& pb, std::vector<Contact>& out) const;

 private:
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
  };
  void findCandidates(double h);
  void pairContacts(const Pair& pair, const Pose& pa, const Pose& pb, std::vector<Contact>& out) const;
  void substep(double h);
  void findPairs(double h);
  Pose predict(const RigidBody& b, double h, bool withForces) const;
  glm::dvec3 acceleration(int i) const;
  glm::dvec3 angularAcceleration(int i) const;
  bool collide(double h);
  void contact(double h);
  void shockPropagation();
  void integratePositions(double h);
  void projectPositions();
  void updateSleep(double h);
  // Groups, and with `patches` each group's extent about its point.
  static void manifolds(const std::vector<Contact>& contacts, std::vector<Contact>& out,
                        std::vector<PatchExtent>* patches = nullptr);
  // A contact point's offsets from the two centres of mass, at the poses it was found at.
  struct Levers {
    glm::dvec3 ra, rb;
  };
  static Levers levers(const Contact& c, const Pose& poseA, const Pose& poseB);
  glm::dvec3 relativeVelocity(int a, int b, const Levers& l) const;  // v_B - v_A at the point
  void applyImpulse(int a, int b, const Levers& l, const glm::dvec3& j);  // j on b, -j on a, at the levers' point
  glm::dmat3 collisionMatrixAt(int a, int b, const Levers& l, bool frozenA, bool frozenB) const;
  void sidesAt(int a, int b, const Levers& l, bool frozenA, bool frozenB, ImpulseSide& sa, ImpulseSide& sb) const;
  glm::dvec3 relativeSpin(int a, int b) const;  // omega_B - omega_A
  void applyTorqueImpulse(int a, int b, const glm::dvec3& t);  // t on b, -t on a
  glm::dvec3 contactImpulse(int a, int b, const Contact& c, const Levers& l, double eps, bool frozenA, bool frozenB,
                            double* elastic = nullptr, bool withFriction = true) const;

  WorldSettings settings_;
  std::vector<RigidBody> bodies_;
  std::vector<glm::dvec3> force_, torque_;
  std::vector<Pair> pairs_, previousPairs_;
  // Broad phase: bounds per body, the sweep order kept between substeps, pair keys (a << 32 | b).
  std::vector<Aabb> boxes_;
  std::vector<int> sweepOrder_;
  std::vector<uint64_t> pairKeys_;
  std::vector<CollisionEvent> events_, contactReports_;
  std::vector<char> reportContacts_, bumpNormals_;
  NormalModifier normalModifier_;
  std::vector<int> level_;
  std::vector<char> frozen_;
  std::vector<glm::dmat3> invInertia_;  // per body, this substep
  // The collision step's last contacts per pair, found when the two bodies'
  // impulse counts (version_) were foundVersion_; the contact step's first
  // pass reuses them while those counts have not moved.
  std::vector<std::vector<Contact>> found_;
  std::vector<std::pair<uint32_t, uint32_t>> foundVersion_;
  std::vector<uint32_t> version_;
  std::vector<Pose> predicted_;  // the collision step's predicted poses, valid while predictedVersion_ == version_
  std::vector<uint32_t> predictedVersion_;
  std::vector<Pose> stepStart_;
  // The contact step's groups per pair as last found, with their levers (shock propagation and the projection work on them).
  std::vector<std::vector<Contact>> groups_;
  std::vector<std::vector<Levers>> groupLevers_;
  std::vector<std::vector<ImpulseMatrix>> groupMatrices_;  // K and K^-1 at those levers
  std::vector<std::vector<double>> groupSpeed_;  // each group's normal relative speed when found
  std::vector<std::vector<FrictionTotals>> groupTotals_;      // each group's impulses so far this contact step
  std::vector<std::vector<PatchExtent>> groupPatches_;        // each group's patch about its point
  std::vector<std::vector<PatchMatrix>> groupPatchMatrices_;  // and its patch impulse system
  std::vector<std::pair<Pose, Pose>> lookPoses_;  // per pair, the poses of the contact step's last look
  std::vector<int> lookCount_;                    // and the points it found
  void endOfStepDepths(double h);  // poses before this substep's position update (sleep test)
  StepStats stats_;
  double time_ = 0;
  double minHalfThickness_ = 1e30;
};

}  // namespace crumple
