// The World's API: bodies, joints and their settings, snapshots, forces. The order of the stages (step,
// substep) is in world_step.cpp; the stages themselves live one per file (physics/stages.h lists them).
#include <crumple/physics/world.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <thread>

#include <crumple/physics/step_context.h>
#include <crumple/physics/thread_pool.h>

namespace crumple {

using detail::finite;

World::World(const WorldSettings& settings) : ctx_(std::make_unique<detail::StepContext>()) {
  ctx_->settings = settings;
}
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

namespace {
// The body that `def` describes, checked (std::invalid_argument on bad input).
RigidBody makeBody(const BodyDef& def) {
  if (!def.shape) throw std::invalid_argument("body has no shape");
  if (!finite(def.origin) || !finite(def.linearVelocity) || !finite(def.angularVelocity) || !finite(def.orientation)) {
    throw std::invalid_argument("body state is not finite");
  }
  if (!(def.restitution >= 0 && def.restitution <= 1)) throw std::invalid_argument("restitution outside [0, 1]");
  if (!(def.friction >= 0) || !std::isfinite(def.friction)) throw std::invalid_argument("friction must be >= 0");
  RigidBody b;
  b.shape = def.shape;
  b.restitution = def.restitution;
  b.friction = def.friction;
  b.isStatic = def.isStatic;
  b.kinematic = def.kinematic && !def.isStatic;
  if (def.group < 0 || def.group > 63) throw std::invalid_argument("collision group outside 0..63");
  b.group = def.group;
  b.q = glm::normalize(def.orientation);
  const MassProperties& mp = def.shape->unitMass;
  b.localCom = mp.centerOfMass;
  b.x = def.origin + glm::mat3_cast(b.q) * b.localCom;
  if (!def.isStatic) {
    if (def.mass > 0) {
      b.mass = def.mass;
    } else {
      if (!(def.density > 0)) throw std::invalid_argument("density must be positive");
      b.mass = def.density * mp.volume;
    }
    if (!(b.mass > 0) || !std::isfinite(b.mass)) throw std::invalid_argument("mass must be positive and finite");
    b.invMass = 1.0 / b.mass;
    b.inertiaBody = mp.inertia * (b.mass / mp.volume);
    b.invInertiaBody = glm::inverse(b.inertiaBody);
    for (int c = 0; c < 3; ++c)
      if (!finite(b.invInertiaBody[c]) || !finite(b.inertiaBody[c]) || !(b.inertiaBody[c][c] > 0))
        throw std::invalid_argument("inertia is degenerate (a body too thin or too light)");
    b.principal = principalInertia(b.inertiaBody);
    b.v = def.linearVelocity;
    b.w = def.angularVelocity;
    if (b.kinematic) {
      // Infinite mass in every impulse; the mass stays for what reads it (reports).
      b.invMass = 0;
      b.invInertiaBody = glm::dmat3(0);
    }
  }
  return b;
}
}  // namespace

namespace {
// What the step keeps of every body ever added: the thinnest half thickness (substeps), any block or plate
// that impulses move (a static or kinematic body never becomes dynamic; grounds are often plates).
void noteShape(detail::StepContext& ctx, const BodyDef& def) {
  ctx.minHalfThickness = std::min(ctx.minHalfThickness, def.shape->halfThickness());
  ctx.anyLoadBearing = ctx.anyLoadBearing || (!def.isStatic && !def.kinematic && detail::loadBearing(*def.shape));
}
}  // namespace

int World::addBody(const BodyDef& def) {
  RigidBody b = makeBody(def);
  detail::StepContext& ctx = *ctx_;
  ctx.bodies.push_back(b);
  ctx.force.emplace_back(0);
  ctx.torque.emplace_back(0);
  noteShape(ctx, def);
  return static_cast<int>(ctx.bodies.size() - 1);
}

BodyId World::add(const BodyDef& def) {
  detail::StepContext& ctx = *ctx_;
  size_t slot = 0;
  while (slot < ctx.bodies.size() && !ctx.bodies[slot].removed) ++slot;
  if (slot == ctx.bodies.size()) return bodyId(addBody(def));
  RigidBody b = makeBody(def);
  b.generation = ctx.bodies[slot].generation + 1;
  ctx.bodies[slot] = b;
  ctx.force[slot] = ctx.torque[slot] = glm::dvec3(0);
  if (slot < ctx.reportContacts.size()) ctx.reportContacts[slot] = 0;
  if (slot < ctx.bumpNormals.size()) ctx.bumpNormals[slot] = 0;
  if (slot < ctx.dentRise.size()) ctx.dentRise[slot] = -1;
  if (slot < ctx.sampleDents.size()) ctx.sampleDents[slot] = {};
  noteShape(ctx, def);
  // The kept pairs' candidate lists were built for the old body in this slot.
  ctx.pairs.clear();
  ctx.previousPairs.clear();
  return {static_cast<int32_t>(slot), b.generation};
}

void World::remove(BodyId id) { removeBody(index(id)); }

bool World::valid(BodyId id) const {
  const detail::StepContext& ctx = *ctx_;
  return id.index >= 0 && static_cast<size_t>(id.index) < ctx.bodies.size() &&
         ctx.bodies[static_cast<size_t>(id.index)].generation == id.generation &&
         !ctx.bodies[static_cast<size_t>(id.index)].removed;
}

int World::index(BodyId id) const {
  if (!valid(id))
    throw std::invalid_argument("stale body id (index " + std::to_string(id.index) + ", generation " +
                                std::to_string(id.generation) + "): the body was removed");
  return id.index;
}

JointId World::jointId(int j) const {
  const detail::Joint& jt = ctx_->joints.at(static_cast<size_t>(j));
  return {j, jt.generation};
}

BodyId World::bodyId(int i) const {
  const RigidBody& b = ctx_->bodies.at(static_cast<size_t>(i));
  return {i, b.generation};
}

JointId World::add(const JointDef& def) {
  detail::StepContext& ctx = *ctx_;
  size_t slot = 0;
  while (slot < ctx.joints.size() && !ctx.joints[slot].removed) ++slot;
  const int appended = addJoint(def);  // checks and builds it at the end
  if (slot == ctx.joints.size() - 1) return {appended, ctx.joints.back().generation};
  detail::Joint jt = ctx.joints.back();
  ctx.joints.pop_back();
  jt.generation = ctx.joints[slot].generation + 1;
  ctx.joints[slot] = jt;
  return {static_cast<int32_t>(slot), jt.generation};
}

void World::remove(JointId id) { removeJoint(index(id)); }

bool World::valid(JointId id) const {
  const detail::StepContext& ctx = *ctx_;
  return id.index >= 0 && static_cast<size_t>(id.index) < ctx.joints.size() &&
         ctx.joints[static_cast<size_t>(id.index)].generation == id.generation &&
         !ctx.joints[static_cast<size_t>(id.index)].removed;
}

int World::index(JointId id) const {
  if (!valid(id))
    throw std::invalid_argument("stale joint id (index " + std::to_string(id.index) + ", generation " +
                                std::to_string(id.generation) + "): the joint was removed");
  return id.index;
}

const std::vector<RigidBody>& World::bodies() const { return ctx_->bodies; }
const RigidBody& World::body(int i) const { return ctx_->bodies.at(static_cast<size_t>(i)); }
size_t World::size() const { return ctx_->bodies.size(); }
WorldSettings& World::settings() { return ctx_->settings; }
const WorldSettings& World::settings() const { return ctx_->settings; }
double World::time() const { return ctx_->time; }
const std::vector<CollisionEvent>& World::events() const { return ctx_->events; }
const std::vector<CollisionEvent>& World::contactReports() const { return ctx_->contactReports; }
const StepStats& World::lastStats() const { return ctx_->stats; }
void World::setNormalModifier(NormalModifier modifier) { ctx_->normalModifier = std::move(modifier); }

namespace {
RigidBody& liveBody(detail::StepContext& ctx, int i) {
  RigidBody& b = ctx.bodies.at(static_cast<size_t>(i));
  if (b.removed) throw std::invalid_argument("body " + std::to_string(i) + " was removed");
  return b;
}
}  // namespace

void World::setVelocity(int i, const glm::dvec3& v) {
  RigidBody& b = liveBody(*ctx_, i);
  if (!finite(v)) throw std::invalid_argument("velocity is not finite");
  b.v = v;
  if (glm::dot(v, v) > 0) wake(i);
}
void World::setAngularVelocity(int i, const glm::dvec3& w) {
  RigidBody& b = liveBody(*ctx_, i);
  if (!finite(w)) throw std::invalid_argument("angular velocity is not finite");
  b.w = w;
  if (glm::dot(w, w) > 0) wake(i);
}
void World::setPose(int i, const Pose& pose) {
  RigidBody& b = liveBody(*ctx_, i);
  const glm::dquat& q = pose.orientation;
  if (!finite(pose.position) || !finite(q))
    throw std::invalid_argument("pose is not finite");
  if (!(glm::dot(q, q) > 0)) throw std::invalid_argument("orientation is not a rotation (zero quaternion)");
  b.x = pose.position;
  b.q = glm::normalize(q);
  wake(i);
  // Its joints close what the move opened: their closing energy is measured afresh (their credit, settleCredit in
  // joint_step.cpp, is refilled only by what the joints take away, and in zero gravity nothing would).
  for (detail::Joint& jt : ctx_->joints)
    if (!jt.removed && (jt.def.a == i || jt.def.b == i)) jt.credit = -1;
}
void World::setRestitution(int i, double restitution) {
  RigidBody& b = liveBody(*ctx_, i);
  if (!(restitution >= 0 && restitution <= 1)) throw std::invalid_argument("restitution outside [0, 1]");
  b.restitution = restitution;
}
void World::setFriction(int i, double friction) {
  RigidBody& b = liveBody(*ctx_, i);
  if (!(friction >= 0) || !std::isfinite(friction)) throw std::invalid_argument("friction must be >= 0");
  b.friction = friction;
}

void World::setReportContacts(int body, bool on) {
  ctx_->reportContacts.resize(ctx_->bodies.size(), 0);
  ctx_->reportContacts.at(static_cast<size_t>(body)) = on;
}

void World::setSurfaceDepth(SurfaceDepth depth) {
  ctx_->surfaceDepth = std::move(depth);
  for (detail::StepContext::SampleDents& kept : ctx_->sampleDents) kept.stale = true;  // another function's answers
}
void World::setDented(int i, double maxRise, const Aabb& region) {
  liveBody(*ctx_, i);
  if (std::isnan(maxRise)) throw std::invalid_argument("dent rise is not a number");
  std::vector<double>& rise = ctx_->dentRise;
  if (rise.size() < ctx_->bodies.size()) rise.resize(ctx_->bodies.size(), -1.0);
  const bool was = rise[static_cast<size_t>(i)] >= 0;
  rise[static_cast<size_t>(i)] = maxRise;
  ctx_->dentBox.resize(ctx_->bodies.size(), Aabb{glm::dvec3(0), glm::dvec3(-1)});
  ctx_->dentBox[static_cast<size_t>(i)] = region;
  ctx_->sampleDents.resize(ctx_->bodies.size());
  ctx_->sampleDents[static_cast<size_t>(i)].stale = true;  // asked again at the next step's start
  // Which of its pairs' sample sets are tested, and how far out, depend on it: their lists are made anew.
  if (was != (maxRise >= 0) || maxRise > 0)
    for (detail::Pair& pair : ctx_->pairs)
      if (pair.a == i || pair.b == i) pair.builtMargin = -1;
}
void World::setBumpNormals(int body, bool on) {
  ctx_->bumpNormals.resize(ctx_->bodies.size(), 0);
  char& flag = ctx_->bumpNormals.at(static_cast<size_t>(body));
  if (flag == static_cast<char>(on)) return;
  flag = on;
  // Which of its pairs' sample sets are tested depends on it (detail::sampleSides): their lists are made anew.
  for (detail::Pair& pair : ctx_->pairs)
    if (pair.a == body || pair.b == body) pair.builtMargin = -1;
}

void World::wake(int i) { ctx_->wake(i); }

void World::removeBody(int i) {
  detail::StepContext& ctx = *ctx_;
  RigidBody& b = liveBody(ctx, i);
  b.removed = true;
  b.isStatic = true;  // nothing moves it, it moves nothing
  b.kinematic = false;
  b.invMass = 0;
  b.invInertiaBody = glm::dmat3(0);
  b.v = b.w = glm::dvec3(0);
  for (size_t j = 0; j < ctx.joints.size(); ++j)
    if (!ctx.joints[j].removed && (ctx.joints[j].def.a == i || ctx.joints[j].def.b == i)) removeJoint(static_cast<int>(j));
}

// ---- joints -----------------------------------------------------------------

const char* jointTypeName(JointType t) {
  switch (t) {
    case JointType::Ball:
      return "ball";
    case JointType::Hinge:
      return "hinge";
    case JointType::Slider:
      return "slider";
    case JointType::Fixed:
      return "fixed";
    case JointType::Distance:
      return "distance";
  }
  return "?";
}

int World::addJoint(const JointDef& in) {
  detail::StepContext& ctx = *ctx_;
  JointDef d = in;
  const int n = static_cast<int>(ctx.bodies.size());
  auto bad = [](const std::string& why) { throw std::invalid_argument("joint: " + why); };
  if (d.b < 0 || d.b >= n) bad("body b " + std::to_string(d.b) + " does not exist");
  if (d.a < -1 || d.a >= n) bad("body a " + std::to_string(d.a) + " does not exist (-1 is the world)");
  if (d.a == d.b) bad("a body cannot be joined to itself");
  if ((d.a >= 0 && ctx.body(d.a).removed) || ctx.body(d.b).removed) bad("a joined body was removed");
  if (!finite(d.anchor) || !finite(d.anchorA) || !finite(d.anchorB) || !finite(d.axis)) bad("a point or axis is not finite");
  if (d.type == JointType::Hinge || d.type == JointType::Slider) {
    if (!(glm::length(d.axis) > 1e-9)) bad("the axis is zero");
    d.axis = glm::normalize(d.axis);
  }
  if (d.limited && !(d.lower <= d.upper)) bad("limits: lower is above upper");
  if (!(d.breakImpulse >= 0)) bad("break impulse must be >= 0");
  if (d.motor.enabled && (!(d.motor.maxForce >= 0) || !std::isfinite(d.motor.maxForce) || !std::isfinite(d.motor.speed)))
    bad("motor: max force must be >= 0 and the speed finite");
  detail::Joint jt;
  const Pose pa = d.a < 0 ? Pose{} : Pose{ctx.body(d.a).x, ctx.body(d.a).q};
  const Pose pb{ctx.body(d.b).x, ctx.body(d.b).q};
  // World points and directions into each body's frame (about its centre of mass).
  auto local = [](const Pose& p, int idx, const glm::dvec3& world) {
    return idx < 0 ? world : glm::transpose(glm::mat3_cast(p.orientation)) * (world - p.position);
  };
  auto localDir = [](const Pose& p, int idx, const glm::dvec3& world) {
    return idx < 0 ? world : glm::transpose(glm::mat3_cast(p.orientation)) * world;
  };
  if (d.type == JointType::Distance) {
    jt.rA = local(pa, d.a, d.anchorA);
    jt.rB = local(pb, d.b, d.anchorB);
    const double start = glm::length(d.anchorB - d.anchorA);
    if (d.minLength >= 0 || d.maxLength >= 0) {
      if (d.minLength < 0) d.minLength = 0;  // max alone: a rope
      if (!(d.minLength >= 0) || !(d.maxLength >= d.minLength) || !std::isfinite(d.maxLength))
        bad("distance range needs 0 <= min <= max");
      jt.minLength = d.minLength;
      jt.maxLength = d.maxLength;
      jt.length = std::clamp(start, d.minLength, d.maxLength);
    } else {
      if (d.length < 0) d.length = start;
      if (!std::isfinite(d.length)) bad("length is not finite");
      jt.length = jt.minLength = jt.maxLength = d.length;
    }
  } else {
    jt.rA = local(pa, d.a, d.anchor);
    jt.rB = local(pb, d.b, d.anchor);
  }
  const glm::dvec3 axis = glm::length(d.axis) > 1e-9 ? glm::normalize(d.axis) : glm::dvec3(0, 1, 0);
  jt.axisA = localDir(pa, d.a, axis);
  jt.axisB = localDir(pb, d.b, axis);
  const glm::dvec3 helper = std::abs(axis.x) < 0.57 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 ref = glm::normalize(glm::cross(axis, helper));
  jt.refA = localDir(pa, d.a, ref);
  jt.refB = localDir(pb, d.b, ref);
  jt.rel0 = glm::conjugate(pa.orientation) * pb.orientation;
  jt.def = d;
  ctx.joints.push_back(jt);
  ctx.jointExcludedDirty = true;
  if (d.a >= 0) ctx.wake(d.a);
  ctx.wake(d.b);
  return static_cast<int>(ctx.joints.size() - 1);
}

namespace {
detail::Joint& jointAt(detail::StepContext& ctx, int j) {
  detail::Joint& jt = ctx.joints.at(static_cast<size_t>(j));
  if (jt.removed) throw std::invalid_argument("joint " + std::to_string(j) + " was removed");
  return jt;
}
}  // namespace

void World::removeJoint(int j) {
  detail::Joint& jt = jointAt(*ctx_, j);
  jt.removed = true;
  ctx_->jointExcludedDirty = true;
  if (jt.def.a >= 0) ctx_->wake(jt.def.a);
  ctx_->wake(jt.def.b);
}
size_t World::jointCount() const { return ctx_->joints.size(); }
bool World::jointRemoved(int j) const { return ctx_->joints.at(static_cast<size_t>(j)).removed; }
const JointDef& World::jointDef(int j) const { return ctx_->joints.at(static_cast<size_t>(j)).def; }
JointState World::jointState(int j) const {
  const detail::Joint& jt = ctx_->joints.at(static_cast<size_t>(j));
  JointState s;
  s.broken = jt.broken;
  s.impulse = glm::length(jt.stepImpulse);
  s.angle = jt.angle;
  const detail::StepContext& ctx = *ctx_;
  const Pose pa = jt.def.a < 0 ? Pose{} : Pose{ctx.body(jt.def.a).x, ctx.body(jt.def.a).q};
  const Pose pb{ctx.body(jt.def.b).x, ctx.body(jt.def.b).q};
  const glm::dvec3 wa = jt.def.a < 0 ? jt.rA : pa.position + glm::mat3_cast(pa.orientation) * jt.rA;
  const glm::dvec3 wb = pb.position + glm::mat3_cast(pb.orientation) * jt.rB;
  if (jt.def.type == JointType::Slider) {
    const glm::dvec3 axis = jt.def.a < 0 ? jt.axisA : glm::mat3_cast(pa.orientation) * jt.axisA;
    s.offset = glm::dot(wb - wa, axis);
  } else if (jt.def.type == JointType::Distance) {
    s.offset = glm::length(wb - wa);
  }
  return s;
}
void World::setJointMotor(int j, const JointMotor& motor) {
  detail::Joint& jt = jointAt(*ctx_, j);
  if (motor.enabled && (!(motor.maxForce >= 0) || !std::isfinite(motor.maxForce) || !std::isfinite(motor.speed)))
    throw std::invalid_argument("joint motor: max force must be >= 0 and the speed finite");
  jt.def.motor = motor;
  if (jt.def.a >= 0) ctx_->wake(jt.def.a);
  ctx_->wake(jt.def.b);
}
const std::vector<JointBreak>& World::jointBreaks() const { return ctx_->jointBreaks; }

// ---- kinematic bodies, filters, snapshots -----------------------------------

void World::setKinematicTarget(int i, const Pose& target, double h) {
  RigidBody& b = liveBody(*ctx_, i);
  if (!b.kinematic) throw std::invalid_argument("body " + std::to_string(i) + " is not kinematic");
  const glm::dquat& q = target.orientation;
  if (!finite(target.position) || !finite(q) || !(glm::dot(q, q) > 0))
    throw std::invalid_argument("kinematic target is not a finite pose");
  if (!(h > 0) || !std::isfinite(h)) throw std::invalid_argument("time step must be positive and finite");
  b.v = (target.position - b.x) / h;
  glm::dquat d = glm::normalize(q) * glm::conjugate(b.q);
  if (d.w < 0) d = -d;
  const glm::dvec3 axis(d.x, d.y, d.z);
  const double s = glm::length(axis);
  b.w = s < 1e-15 ? glm::dvec3(0) : axis * (2 * std::atan2(s, d.w) / (s * h));
}

void World::setGroup(int i, int group) {
  RigidBody& b = liveBody(*ctx_, i);
  if (group < 0 || group > 63) throw std::invalid_argument("collision group outside 0..63");
  b.group = group;
}
void World::setGroupsCollide(int ga, int gb, bool collide) {
  if (ga < 0 || ga > 63 || gb < 0 || gb > 63) throw std::invalid_argument("collision group outside 0..63");
  std::vector<uint64_t>& m = ctx_->groupMasks;
  if (collide) {
    m[static_cast<size_t>(ga)] |= 1ull << gb;
    m[static_cast<size_t>(gb)] |= 1ull << ga;
  } else {
    m[static_cast<size_t>(ga)] &= ~(1ull << gb);
    m[static_cast<size_t>(gb)] &= ~(1ull << ga);
  }
}
void World::setCollisionFilter(CollisionFilter filter) { ctx_->filter = std::move(filter); }

WorldSnapshot::WorldSnapshot() = default;
WorldSnapshot::~WorldSnapshot() = default;
WorldSnapshot::WorldSnapshot(const WorldSnapshot&) = default;
WorldSnapshot& WorldSnapshot::operator=(const WorldSnapshot&) = default;

WorldSnapshot World::snapshot() const {
  WorldSnapshot s;
  s.state_ = std::make_shared<const detail::StepContext>(*ctx_);
  return s;
}
void World::restore(const WorldSnapshot& s) {
  if (!s.state_) throw std::invalid_argument("empty snapshot");
  *ctx_ = *s.state_;
}

void World::addForce(int i, const glm::dvec3& f) {
  if (!finite(f)) throw std::invalid_argument("force is not finite");
  ctx_->force.at(static_cast<size_t>(i)) += f;
  if (glm::dot(f, f) > 0) wake(i);
}
void World::addTorque(int i, const glm::dvec3& t) {
  if (!finite(t)) throw std::invalid_argument("torque is not finite");
  ctx_->torque.at(static_cast<size_t>(i)) += t;
  if (glm::dot(t, t) > 0) wake(i);
}
void World::addForceAtPoint(int i, const glm::dvec3& f, const glm::dvec3& p) {
  if (!finite(f) || !finite(p)) throw std::invalid_argument("force or point is not finite");
  addForce(i, f);
  addTorque(i, glm::cross(p - body(i).x, f));
}

uint64_t World::stateHash() const {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* data, size_t n) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ bytes[i]) * 1099511628211ull;
  };
  for (const auto& b : ctx_->bodies) {
    mix(&b.x, sizeof b.x);
    mix(&b.q, sizeof b.q);
    mix(&b.v, sizeof b.v);
    mix(&b.w, sizeof b.w);
  }
  for (const auto& j : ctx_->joints) {
    mix(&j.broken, sizeof j.broken);
    mix(&j.removed, sizeof j.removed);
    mix(&j.angle, sizeof j.angle);
  }
  return h;
}

}  // namespace crumple
