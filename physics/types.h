// The physics' plain types, apart from the World that uses them (the step's stages, physics/step_context.h,
// include this, not world.h): settings, what a step reports (events, contacts, statistics, status), boxes and
// ray hits, and the callbacks a World takes (World's members of the same names are these).
#pragma once
#include <glm/glm.hpp>

#include <cstdint>
#include <functional>

#include <crumple/physics/body.h>

namespace crumple {

struct WorldSettings {
  glm::dvec3 gravity{0, -9.81, 0};
  int collisionPasses = 5;
  int collisionIterations = 20;  // per pair and pass
  int contactPasses = 10;
  int contactRefresh = 5;  // passes between re-finding contact geometry
  // m: at a refresh, a pair whose predicted relative pose has moved less than
  // this since its last look keeps its geometry (resting contact); 0 re-finds all.
  // A look's contacts are kept from one look (and step) to the next on the same
  // terms: two convex polytopes' manifold, and the samples' contacts of a pair
  // with no ball in it that neither sweeps, bends its normals nor feels dents.
  // The points move with the bodies and their depths are measured again
  // (StepStats::keptLooks), until the bodies have moved this much from where
  // they were found.
  double contactRefreshTolerance = 0.0005;
  // A look at a pair that found nothing (where nothing sweeps, bends normals or feels dents) answers the pair's
  // next looks while the bodies' points move less than its clearance: how far they could move before a contact
  // (two boxes: their gap along the axis that separates them; the least distance of the samples it tested, over
  // the field's slope, where each side tests a short list or its near samples; StepStats::clearLooks). Exact:
  // the same bits as looking again. false: every such look is made again.
  bool keepClearLooks = true;
  // Shock propagation passes per contact-graph level at most (Jacobi: each body
  // takes the mean of its groups' impulses against the frozen level below, on
  // the contact step's last geometry), each part of a level (its groups joined
  // through the bodies they move) until a pass changes no group's relative
  // velocity by more than shockTolerance (m/s). With it the
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
  // Turns of (contact impulses, then pre-stabilisation again) after the second pre-stabilisation while a contact
  // of a joined body still approaches faster than jointContactTolerance (m/s) and each turn takes a hundredth off
  // that approach: the joints carry a limb's weight to the body that rests on the ground only after the contacts
  // stopped it (a ragdoll lying still crept and hit the ground every step). None where some such contact
  // approaches faster than jointContactBlow (m/s): a blow (a car into a rail on breakable posts), left to the next
  // collision step, its restitution and its event (the joints hand on up to ~0.8 m/s to a ragdoll's resting
  // contacts through its limbs' levers). 0 rounds turns it off.
  int jointContactRounds = 32;
  double jointContactTolerance = 1e-4;
  double jointContactBlow = 1.0;
  // Threads the step runs on (the caller's included; 0: the machine's hardware
  // threads). The results are the same bits for every count: work is split by
  // island and by body, each writing its own slots, merged in a fixed order.
  // With more than one, a NormalModifier is still called from one thread at a time.
  int threads = 1;
};

struct CollisionEvent {
  double time = 0;
  int a = -1, b = -1;           // body indices, a < b (or b < 0); a owns the normal
  glm::dvec3 point{0};          // P_C, world
  glm::dvec3 normal{0};         // N_C, unit, out of A
  double penetration = 0;       // d_C >= 0
  double elasticImpulse = 0;    // |j_eps=1| of each hit (plus twice what the later stages pushed, collisionsCarried)
  double impulse = 0;           // |applied impulse| summed over the pair's iterations and the later stages
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
  // Joint solves that handed the joined bodies more energy than they may: pre-stabilisation calls past what
  // closing the violations they started with (at most maxCorrectionSpeed) and the motors' work allow (scaled back
  // to that where half of the call or more fits, else undone: their joints then only removed forbidden relative
  // velocity), and direct velocity solves past what kinematic ends drive (their joints then solved one at a time).
  int jointFallbacks = 0;
  int droppedPairs = 0;  // pairs over WorldSettings::maxPairs, summed over the substeps
  int restingSolves = 0;  // islands the contact step solved at once (WorldSettings::restingSolveRows)
  // Narrow-phase looks at pairs (collision and contact steps), and those a kept look answered (a manifold, or
  // the samples' contacts: WorldSettings::contactRefreshTolerance): its points carried along, the pair having
  // moved less than contactRefreshTolerance. clearLooks: those a look that found nothing answered, the bodies'
  // points having moved less than its clearance (how far they could move before a look finds a contact): nothing
  // again (WorldSettings::keepClearLooks).
  int looks = 0, keptLooks = 0, clearLooks = 0;
  // Islands of pairs (no movable body in common: the units the threads share out), most in a substep,
  // and the pairs of the largest (a step cannot go faster than that island alone).
  int islands = 0, largestIsland = 0;
  StepProfile ms;
};

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

// World::setCollisionFilter: whether bodies a and b may collide (a pure function of them).
using CollisionFilter = std::function<bool(int a, int b)>;
// World::setNormalModifier: a contact's normal on a flagged body from (body, surface point, geometric normal).
using NormalModifier = std::function<glm::dvec3(int body, const glm::dvec3& point, const glm::dvec3& normal)>;
// World::setSurfaceDepth: how far below a point of a body's undented surface its dented surface lies, and its
// normal there (`bent`).
using SurfaceDepth =
    std::function<double(int body, const glm::dvec3& point, const glm::dvec3& normal, glm::dvec3& bent)>;

}  // namespace crumple
