// The World's API and the order of the stages (step, substep). The stages
// themselves live one per file (physics/step_context.h lists them).
#include "physics/world.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "physics/step_context.h"

namespace crumple {

using detail::finite;

World::World(const WorldSettings& settings) : ctx_(std::make_unique<detail::StepContext>()) {
  ctx_->settings = settings;
}
World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

int World::addBody(const BodyDef& def) {
  if (!def.shape) throw std::invalid_argument("body has no shape");
  if (!finite(def.origin) || !finite(def.linearVelocity) || !finite(def.angularVelocity) ||
      !std::isfinite(def.orientation.w) || !std::isfinite(def.orientation.x) || !std::isfinite(def.orientation.y) ||
      !std::isfinite(def.orientation.z)) {
    throw std::invalid_argument("body state is not finite");
  }
  if (!(def.restitution >= 0 && def.restitution <= 1)) throw std::invalid_argument("restitution outside [0, 1]");
  if (!(def.friction >= 0) || !std::isfinite(def.friction)) throw std::invalid_argument("friction must be >= 0");
  RigidBody b;
  b.shape = def.shape;
  b.restitution = def.restitution;
  b.friction = def.friction;
  b.isStatic = def.isStatic;
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
    b.v = def.linearVelocity;
    b.w = def.angularVelocity;
  }
  detail::StepContext& c = *ctx_;
  c.bodies.push_back(b);
  c.force.emplace_back(0);
  c.torque.emplace_back(0);
  c.minHalfThickness = std::min(c.minHalfThickness, def.shape->halfThickness());
  return static_cast<int>(c.bodies.size() - 1);
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

void World::setVelocity(int i, const glm::dvec3& v) {
  RigidBody& b = ctx_->bodies.at(static_cast<size_t>(i));
  if (!finite(v)) throw std::invalid_argument("velocity is not finite");
  b.v = v;
  if (glm::dot(v, v) > 0) wake(i);
}
void World::setAngularVelocity(int i, const glm::dvec3& w) {
  RigidBody& b = ctx_->bodies.at(static_cast<size_t>(i));
  if (!finite(w)) throw std::invalid_argument("angular velocity is not finite");
  b.w = w;
  if (glm::dot(w, w) > 0) wake(i);
}
void World::setPose(int i, const Pose& pose) {
  RigidBody& b = ctx_->bodies.at(static_cast<size_t>(i));
  const glm::dquat& q = pose.orientation;
  if (!finite(pose.position) || !std::isfinite(q.w) || !std::isfinite(q.x) || !std::isfinite(q.y) ||
      !std::isfinite(q.z))
    throw std::invalid_argument("pose is not finite");
  if (!(glm::dot(q, q) > 0)) throw std::invalid_argument("orientation is not a rotation (zero quaternion)");
  b.x = pose.position;
  b.q = glm::normalize(q);
  wake(i);
}
void World::setRestitution(int i, double restitution) {
  RigidBody& b = ctx_->bodies.at(static_cast<size_t>(i));
  if (!(restitution >= 0 && restitution <= 1)) throw std::invalid_argument("restitution outside [0, 1]");
  b.restitution = restitution;
}
void World::setFriction(int i, double friction) {
  RigidBody& b = ctx_->bodies.at(static_cast<size_t>(i));
  if (!(friction >= 0) || !std::isfinite(friction)) throw std::invalid_argument("friction must be >= 0");
  b.friction = friction;
}

void World::setReportContacts(int body, bool on) {
  ctx_->reportContacts.resize(ctx_->bodies.size(), 0);
  ctx_->reportContacts.at(static_cast<size_t>(body)) = on;
}

void World::setBumpNormals(int body, bool on) {
  ctx_->bumpNormals.resize(ctx_->bodies.size(), 0);
  ctx_->bumpNormals.at(static_cast<size_t>(body)) = on;
}

void World::wake(int i) { ctx_->wake(i); }

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
  return h;
}

namespace {
// Adds the milliseconds since `since` to `ms` and restarts the clock.
class StageClock {
 public:
  void lap(double& ms) {
    const auto now = std::chrono::steady_clock::now();
    ms += std::chrono::duration<double, std::milli>(now - since_).count();
    since_ = now;
  }

 private:
  std::chrono::steady_clock::time_point since_ = std::chrono::steady_clock::now();
};
}  // namespace

void World::substep(double h) {
  detail::StepContext& c = *ctx_;
  StepProfile& ms = c.stats.ms;
  StageClock clock;
  // World inverse inertias: orientations stay fixed until the position update.
  c.invInertia.resize(c.bodies.size());
  for (size_t i = 0; i < c.bodies.size(); ++i) c.invInertia[i] = c.bodies[i].invInertiaWorld();
  detail::findPairs(c, h);
  c.stats.pairs += static_cast<int>(c.pairs.size());
  clock.lap(ms.broadPhase);
  detail::findCandidates(c, h);
  clock.lap(ms.candidates);
  // 1. collision with restitution on predicted positions (emits events)
  detail::collide(c, h);
  clock.lap(ms.collide);
  // 2. velocities, 3. contact with the restitution ramp
  detail::integrateVelocities(c, h);
  detail::contactStep(c, h);
  clock.lap(ms.contact);
  // 4. shock propagation
  detail::shockPropagation(c);
  clock.lap(ms.shockPropagation);
  // 5. positions, then the positional projection
  c.stepStart.resize(c.bodies.size());
  for (size_t i = 0; i < c.bodies.size(); ++i) c.stepStart[i] = {c.bodies[i].x, c.bodies[i].q};
  detail::endOfStepDepths(c, h);
  detail::integratePositions(c, h);
  detail::projectPositions(c);
  clock.lap(ms.positions);
  // 6. sleeping
  detail::updateSleep(c, h);
  clock.lap(ms.sleep);
  c.time += h;
}

void World::step(double h) {
  if (!(h > 0) || !std::isfinite(h)) throw std::invalid_argument("time step must be positive and finite");
  const auto start = std::chrono::steady_clock::now();
  detail::StepContext& c = *ctx_;
  c.events.clear();
  c.contactReports.clear();
  c.reportContacts.resize(c.bodies.size(), 0);
  if (!c.bumpNormals.empty()) c.bumpNormals.resize(c.bodies.size(), 0);
  c.stats = {};
  c.frozen.assign(c.bodies.size(), 0);
  // Substeps: no body may move more than a fraction of the thinnest half thickness.
  double maxTravel = 0;
  for (const RigidBody& b : c.bodies) {
    if (!b.movable()) continue;
    const double speed =
        glm::length(b.v) + glm::length(c.settings.gravity) * h + glm::length(b.w) * b.shape->boundingRadius;
    maxTravel = std::max(maxTravel, speed * h);
  }
  const double allowed = c.settings.substepFraction * std::max(c.minHalfThickness, 1e-4);
  const int n = std::clamp(static_cast<int>(std::ceil(maxTravel / allowed)), 1, std::max(1, c.settings.maxSubsteps));
  for (int s = 0; s < n; ++s) substep(h / n);
  c.stats.substeps = n;
  for (size_t i = 0; i < c.bodies.size(); ++i) {
    c.force[i] = glm::dvec3(0);
    c.torque[i] = glm::dvec3(0);
    c.stats.awake += c.bodies[i].movable();
  }
  c.stats.ms.total = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace crumple
