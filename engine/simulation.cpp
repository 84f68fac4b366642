#include <crumple/engine/simulation.h>

#include <cstring>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <array>
#include <unordered_map>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include <crumple/engine/atlas.h>
#include <crumple/engine/mesh_io.h>
#include <crumple/engine/primitives.h>
#include <crumple/core/log.h>
#include <crumple/deform/model/stress_strain.h>
#include <crumple/gl/image.h>

namespace crumple {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

}  // namespace

SideDecision decideSide(const Material& material, double thickness, double impulse) {
  SideDecision d;
  d.threshold = yieldThreshold(material.restitution);                     // eq. 6
  d.percentDeform = percentDeform(material.kappa, impulse, d.threshold);  // eq. 5
  d.deformDepth = deformDepth(thickness, d.percentDeform);
  return d;
}

Simulation::Simulation(const Scene& scene, bool gl) : scene_(scene), gl_(gl), assets_(scene.file) {
  world_.settings().gravity = scene.gravity;
  world_.settings().threads = scene.threads;
  if (gl_) {
    deformer_ = std::make_unique<deform::Deformer>(scene.deformation.options);
    deformTimer_ = std::make_unique<gl::GpuTimer>();
    renderTimer_ = std::make_unique<gl::GpuTimer>();
  }
  bodies_.reserve(scene.bodies.size());
  // Collision groups: the names the bodies use, numbered in name order (the loader allows at most 64).
  for (const BodyDesc& b : scene.bodies) groups_.emplace(b.group, 0);
  int g = 0;
  for (auto& [name, number] : groups_) number = g++;
  for (size_t i = 0; i < scene.bodies.size(); ++i) buildBody(scene.bodies[i], i);
  for (const auto& [ga, gb] : scene.noCollide) world_.setGroupsCollide(groups_.at(ga), groups_.at(gb), false);
  buildJoints();
  if (gl_ && scene.deformation.normalMappedNormals) setNormalMappedNormals(true);
  dents_.resize(bodies_.size());
  bool anyFelt = false;
  for (size_t i = 0; i < bodies_.size(); ++i) {
    dents_[i].feel = gl_ && bodies_[i].surface && !bodies_[i].mesh->uvs.empty() &&
                     scene.bodies[i].feelDents.value_or(scene.deformation.feelDents);
    anyFelt = anyFelt || dents_[i].feel;
    if (!dents_[i].feel) continue;
    bodies_[i].surface->setChangeLog(static_cast<int>(i));
    bodies_[i].surface->setDentsFelt(true);
    setSurfaceDepths(i, bodies_[i].surface->bumpDepth(), bodies_[i].surface->bumpDepthCollide());
  }
  prepareDents();
  if (anyFelt) {
    deformer_->logChanges(scene.deformation.options.changeLog);
    std::vector<int> bodyOf(world_.size(), -1);
    for (size_t i = 0; i < bodies_.size(); ++i) bodyOf[static_cast<size_t>(bodies_[i].index)] = static_cast<int>(i);
    world_.setSurfaceDepth([this, bodyOf](int index, const glm::dvec3& p, const glm::dvec3& n, glm::dvec3& bent) {
      return surfaceDepth(bodyOf[static_cast<size_t>(index)], p, n, bent);
    });
  }
}

Simulation::~Simulation() {
  if (dentFence_) glDeleteSync(dentFence_);
}

void Simulation::gpuTimes(bool wait) {
  if (deformTimer_) timings_.deformGpuMs = wait ? deformTimer_->finish() : deformTimer_->ms();
  if (renderTimer_) timings_.renderGpuMs = wait ? renderTimer_->finish() : renderTimer_->ms();
}

void Simulation::updateCreaseBevels() {
  if (!deformer_) return;
  for (BodyRuntime& b : bodies_)
    if (b.surface) deformer_->creaseBevel(*b.surface);
}

std::vector<VehiclePart> Simulation::jointParts() const {
  std::vector<VehiclePart> parts;
  if (!cableMesh_) return parts;
  for (int id : joints_) {
    const JointDef& d = world_.jointDef(id);
    if (d.type != JointType::Distance || world_.jointState(id).broken || world_.jointRemoved(id)) continue;
    // The anchors now: each body keeps its anchor where it was at the start, relative to itself.
    auto now = [&](int body, const glm::dvec3& start) {
      if (body < 0) return start;
      const RigidBody& rb = world_.body(body);
      const Pose& p0 = initialPoses_[static_cast<size_t>(body)];
      return rb.x + rb.rotation() * (glm::transpose(glm::mat3_cast(p0.orientation)) * (start - p0.position));
    };
    const glm::dvec3 pa = now(d.a, d.anchorA), pb = now(d.b, d.anchorB);
    const double len = glm::length(pb - pa);
    if (len < 1e-6) continue;
    const glm::dvec3 y = (pb - pa) / len;
    const glm::dvec3 helper = std::abs(y.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 0, 1);
    const glm::dvec3 x = glm::normalize(glm::cross(helper, y)), z = glm::cross(x, y);
    const double r = 0.035;
    glm::dmat4 m(1);
    m[0] = glm::dvec4(x * r, 0);
    m[1] = glm::dvec4(y * len, 0);
    m[2] = glm::dvec4(z * r, 0);
    m[3] = glm::dvec4((pa + pb) * 0.5, 1);
    parts.push_back({cableMesh_.get(), m, glm::vec3(0.12f, 0.12f, 0.13f)});
  }
  return parts;
}

void Simulation::buildJoints() {
  initialPoses_.clear();
  for (const RigidBody& rb : world_.bodies()) initialPoses_.push_back({rb.x, rb.q});
  bool cables = false;
  for (const JointDesc& d : scene_.joints) cables = cables || d.def.type == JointType::Distance;
  if (gl_ && cables) cableMesh_ = std::make_shared<deform::GpuMesh>(cylinderMesh(1.0, 1.0, 64, 12));
  std::map<std::string, int> index;
  for (const BodyRuntime& b : bodies_) index[b.name] = b.index;
  for (size_t i = 0; i < scene_.joints.size(); ++i) {
    const JointDesc& d = scene_.joints[i];
    JointDef j = d.def;
    j.a = d.a.empty() ? -1 : index.at(d.a);
    j.b = index.at(d.b);
    try {
      joints_.push_back(world_.addJoint(j));
    } catch (const std::invalid_argument& e) {
      throw SceneError(scene_.file, "joints[" + std::to_string(i) + "]", e.what());
    }
  }
}

namespace {
// The pose of a keyframed path at time t: linear between keys, slerped; held at the ends.
Pose pathPose(const std::vector<PathKey>& path, double t) {
  if (t <= path.front().time) return {path.front().position, path.front().orientation};
  for (size_t k = 1; k < path.size(); ++k) {
    if (t > path[k].time) continue;
    const PathKey &p0 = path[k - 1], &p1 = path[k];
    const double u = (t - p0.time) / (p1.time - p0.time);
    return {glm::mix(p0.position, p1.position, u), glm::slerp(p0.orientation, p1.orientation, u)};
  }
  return {path.back().position, path.back().orientation};
}
}  // namespace

void Simulation::driveKinematic(double h) {
  for (size_t i = 0; i < bodies_.size(); ++i) {
    const BodyDesc& d = scene_.bodies[i];
    if (!d.kinematic || d.path.empty()) continue;
    const Pose frame = pathPose(d.path, world_.time() + h);  // the shape frame's pose
    const RigidBody& rb = world_.body(bodies_[i].index);
    const Pose com{frame.position + glm::mat3_cast(frame.orientation) * rb.localCom, frame.orientation};
    world_.setKinematicTarget(bodies_[i].index, com, h);
  }
}

void Simulation::setDeformOptions(const deform::DeformOptions& o) {
  scene_.deformation.options = o;
  if (deformer_) deformer_->setOptions(o);
}

void Simulation::setRestitution(const std::string& material, double eps) {
  Material& m = scene_.materials.at(material);
  m.restitution = std::clamp(eps, 0.0, 1.0);
  for (const BodyRuntime& b : bodies_)
    if (b.material == &m) world_.setRestitution(b.index, m.restitution);
}

void Simulation::setBumpDepths(double k, double kCollide) {
  scene_.deformation.bumpDepth = k;
  scene_.deformation.bumpDepthCollide = kCollide;
  for (size_t i = 0; i < bodies_.size(); ++i)
    if (bodies_[i].surface) setSurfaceDepths(i, static_cast<float>(k), static_cast<float>(kCollide));
}

void Simulation::setSurfaceDepths(size_t i, float k, float kCollide) {
  // A body whose dents are felt: the next dent is measured from the surface the physics puts the other body on,
  // the dented one, all of its relief (k' = k). With a smaller k' the new dent would be cut from below the old
  // floor again, as deep as the old dent is more than k'/k of, and a ball resting in its crater would dig itself
  // in hit by hit.
  const bool felt = i < dents_.size() && dents_[i].feel;
  bodies_[i].surface->setBumpDepths(k, felt ? k : kCollide);
}

void Simulation::setNormalMappedNormals(bool on) {
  scene_.deformation.normalMappedNormals = on;
  for (const BodyRuntime& b : bodies_)
    if (b.surface) world_.setBumpNormals(b.index, on);
  if (!on) return;
  std::map<int, int> bodyOf;
  for (size_t i = 0; i < bodies_.size(); ++i) bodyOf[bodies_[i].index] = static_cast<int>(i);
  world_.setNormalModifier([this, bodyOf](int index, const glm::dvec3& p, const glm::dvec3& n) {
    return bumpNormal(bodyOf.at(index), p, n);
  });
}

glm::dvec3 Simulation::bumpNormal(int i, const glm::dvec3& p, const glm::dvec3& n) {
  BodyRuntime& b = bodies_[static_cast<size_t>(i)];
  if (!b.surface || b.mesh->uvs.empty()) return n;
  NormalLookup& look = normalLookups_[i];
  if (!look.bvh) look.bvh = std::make_unique<TriangleBvh>(*b.mesh);
  if (look.version != timings_.deformations) {
    const int r = b.surface->resolution();
    look.normals.resize(static_cast<size_t>(r) * r * 4);
    b.surface->normal().download(GL_RGBA, GL_UNSIGNED_BYTE, look.normals.data(), look.normals.size());
    look.version = timings_.deformations;
  }
  const TriangleBvh::Hit hit = look.bvh->closest(p);
  if (hit.triangle < 0) return n;
  const glm::uvec3 t = b.mesh->triangles[static_cast<size_t>(hit.triangle)];
  const glm::dvec2 uv0(b.mesh->uvs[t.x]), uv1(b.mesh->uvs[t.y]), uv2(b.mesh->uvs[t.z]);
  const glm::dvec2 uv = hit.barycentric.x * uv0 + hit.barycentric.y * uv1 + hit.barycentric.z * uv2;
  // Tangent frame of the triangle: dP/du and dP/dv.
  UvFrame frame;
  if (!uvFrame(*b.mesh, t, frame)) return n;
  glm::dvec3 T = frame.dPdu, B = frame.dPdv;
  T = glm::normalize(T - n * glm::dot(T, n));
  B = glm::normalize(B - n * glm::dot(B, n));
  const int r = b.surface->resolution();
  const int x = std::clamp(static_cast<int>(uv.x * r), 0, r - 1), y = std::clamp(static_cast<int>(uv.y * r), 0, r - 1);
  const unsigned char* px = &look.normals[(static_cast<size_t>(y) * r + x) * 4];
  const glm::dvec3 nt(px[0] / 127.5 - 1.0, px[1] / 127.5 - 1.0, px[2] / 127.5 - 1.0);
  const glm::dvec3 out = T * nt.x + B * nt.y + n * nt.z;
  const double len = glm::length(out);
  return len > 1e-9 ? out / len : n;
}

void Simulation::buildBody(const BodyDesc& d, size_t index) {
  const std::string where = "bodies[" + std::to_string(index) + "]";
  BodyRuntime b;
  b.name = d.name;
  b.material = &scene_.materials.at(d.material);
  const BodyAssets assets = assets_.load(d, where);
  b.mesh = assets.mesh;

  BodyDef def;
  def.shape = assets.shape;
  def.origin = d.position;
  def.orientation = d.orientation;
  def.linearVelocity = d.velocity;
  def.angularVelocity = d.angularVelocity;
  def.density = b.material->density;
  def.mass = d.mass.value_or(0.0);
  def.restitution = b.material->restitution;
  def.friction = b.material->friction;
  def.isStatic = d.isStatic;
  def.kinematic = d.kinematic;
  def.group = groups_.at(d.group);
  if (d.kinematic && !d.path.empty()) {
    // It starts where its path starts.
    def.origin = d.path.front().position;
    def.orientation = d.path.front().orientation;
  }
  try {
    b.index = world_.addBody(def);
  } catch (const std::invalid_argument& e) {
    throw SceneError(scene_.file, where, e.what());
  }
  b.contactDeformation = d.contactDeformation;
  if (d.contactDeformation) world_.setReportContacts(b.index, true);

  if (gl_) {
    b.gpuMesh = assets_.gpuMesh(assets);
    b.look = assets_.gpuLook(assets);
    if (d.bumpMap.present) {
      const float k = static_cast<float>(d.bumpMap.bumpDepth.value_or(scene_.deformation.bumpDepth));
      const float kc = static_cast<float>(d.bumpMap.bumpDepthCollide.value_or(scene_.deformation.bumpDepthCollide));
      b.surface = assets_.surface(assets, b.gpuMesh, k, kc, scene_.deformation.lazyMaps, *deformer_);
      if (assets.hasImage)  // the heights its map starts with (Deformer::createMaps uploads the same floats)
        imageStarts_[bodies_.size()] = std::make_shared<const std::vector<float>>(assets.initialMap.pixels);
    }
  }
  if (d.vehicle.present) vehicles_.push_back(makeVehicle(d.vehicle, static_cast<int>(bodies_.size()), b.index, gl_));
  bodies_.push_back(std::move(b));
}

bool Simulation::pressGround(int groundBody, const deform::GpuMesh* mesh, const glm::dmat4& model,
                             const glm::dvec3& point, const glm::dvec3& normal, double push) {
  BodyRuntime& ground = bodies_[static_cast<size_t>(groundBody)];
  if (!ground.contactDeformation || !ground.surface) return false;
  const double depth = decideSide(*ground.material, ground.material->thickness, push).deformDepth;
  if (!(depth > 0)) return false;
  beforeDent(groundBody);
  const RigidBody& g = world_.body(ground.index);
  deform::DeformRequest rq;
  rq.a = {ground.surface.get(), ground.gpuMesh.get(), modelAt(groundBody, {g.x, g.q})};
  rq.b = {nullptr, mesh, model};
  rq.point = point;
  rq.normal = normal;
  rq.penetration = 0;
  rq.boundByDepth = false;  // the body as it stands is pressed in
  rq.deformA = depth;
  deformer_->deform(rq);
  ++timings_.contactDeformations;
  return true;
}

std::vector<VehiclePart> Simulation::vehicleParts() const {
  std::vector<VehiclePart> parts;
  for (const VehicleRuntime& v : vehicles_) addVehicleParts(v, model(v.body), parts);
  return parts;
}

glm::dmat4 Simulation::model(int i) const {
  const RigidBody& rb = world_.body(bodies_[static_cast<size_t>(i)].index);
  return modelAt(i, {rb.x, rb.q});
}

glm::dmat4 Simulation::modelAt(int i, const Pose& pose) const {
  const RigidBody& rb = world_.body(bodies_[static_cast<size_t>(i)].index);
  return glm::translate(glm::dmat4(1), pose.position) * glm::dmat4(glm::mat3_cast(pose.orientation)) *
         glm::translate(glm::dmat4(1), -rb.localCom);
}

deform::DeformRequest Simulation::eventRequest(const CollisionEvent& e, int a, int b, double depthA,
                                               double depthB) const {
  const BodyRuntime& A = bodies_[static_cast<size_t>(a)];
  const BodyRuntime& B = bodies_[static_cast<size_t>(b)];
  deform::DeformRequest rq;
  rq.a = {A.surface.get(), A.gpuMesh.get(), modelAt(a, e.poseA)};
  rq.b = {B.surface.get(), B.gpuMesh.get(), modelAt(b, e.poseB)};
  rq.point = e.point;
  rq.normal = e.normal;
  rq.penetration = e.penetration;
  rq.deformA = depthA;
  rq.deformB = depthB;
  return rq;
}

// The step of docs/architecture.md ("One step of the engine"): physics (1, 2), the deformation decision (3)
// and the deformations (4) of this step's collisions, then contact
// deformation (figure 8) of resting contacts and vehicle prints.
void Simulation::step() {
  const double h = scene_.timestep;
  auto t0 = Clock::now();
  takeInDents();
  timings_.dentReadMs += msSince(t0);
  t0 = Clock::now();
  stepPhysics(h);
  timings_.physicsMs += msSince(t0);
  ++steps_;
  ++timings_.steps;
  t0 = Clock::now();
  std::vector<int> bodyOf(world_.size(), -1);
  for (size_t i = 0; i < bodies_.size(); ++i) bodyOf[static_cast<size_t>(bodies_[i].index)] = static_cast<int>(i);
  if (deformTimer_) deformTimer_->begin();
  bool deformed = deformCollisions(bodyOf);
  deformed |= deformContacts(bodyOf, h);
  if (deformed) readBackDents();
  // No glFinish: the GPU's time comes from timer queries read steps later (gpuTimes).
  if (deformTimer_) deformTimer_->end(deformed);
  timings_.deformMs += msSince(t0);
  if (onStep) onStep(world_.events());
}

std::string Simulation::nonFiniteMessage(const StepStatus& status) const {
  std::string name = "#" + std::to_string(status.body);
  for (const BodyRuntime& b : bodies_)
    if (b.index == status.body) name = "'" + b.name + "'";
  auto vec = [](const glm::dvec3& v) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "[%.9g, %.9g, %.9g]", v.x, v.y, v.z);
    return std::string(buf);
  };
  const glm::dquat& q = status.lastPose.orientation;
  char quat[128];
  std::snprintf(quat, sizeof quat, "[%.9g, %.9g, %.9g, %.9g]", q.w, q.x, q.y, q.z);
  char when[96];
  std::snprintf(when, sizeof when, "at step %ld (t = %.9g s)", steps_ + 1, world_.time());
  return scene_.file + ": body " + name + " left finite numbers " + when + "; its last finite state: centre of mass " +
         vec(status.lastPose.position) + " m, orientation (w, x, y, z) " + quat + ", velocity " +
         vec(status.lastVelocity) + " m/s, angular velocity " + vec(status.lastAngularVelocity) + " rad/s";
}

void Simulation::stepPhysics(double h) {
  if (beforeStep) beforeStep(*this, h);
  for (VehicleRuntime& v : vehicles_) {
    const VehicleControls c = v.manual ? v.controls : scriptAt(v.script, world_.time());
    world_.wake(v.vehicle.body());
    v.vehicle.apply(world_, c, h);
  }
  driveKinematic(h);
  const StepStatus status = world_.step(h);
  if (!status) throw std::runtime_error(nonFiniteMessage(status));
  if (world_.lastStats().droppedPairs > 0 && !warnedPairs_) {
    warnedPairs_ = true;
    logWarning(scene_.file, ": more than ", world_.settings().maxPairs,
               " pairs of touching bodies at t = ", world_.time(), " s: the rest pass through each other");
  }
  jointPeaks_.resize(joints_.size(), 0.0);
  for (size_t k = 0; k < joints_.size(); ++k)
    jointPeaks_[k] = std::max(jointPeaks_[k], world_.jointState(joints_[k]).impulse);
  for (const JointBreak& b : world_.jointBreaks()) {
    const size_t k = static_cast<size_t>(std::find(joints_.begin(), joints_.end(), b.joint) - joints_.begin());
    jointBreaks_.push_back({b.time, k < scene_.joints.size() ? scene_.joints[k].name : std::to_string(b.joint),
                            b.impulse});
  }
  for (VehicleRuntime& v : vehicles_) {
    const RigidBody& car = world_.body(v.vehicle.body());
    v.travel += glm::dot(car.v, car.rotation() * glm::dvec3(1, 0, 0)) * h;
  }
}

bool Simulation::deformCollisions(const std::vector<int>& bodyOf) {
  bool deformed = false;
  // The step's deformations go to the deformer as one batch (waves of events on different surfaces, in order).
  std::vector<deform::DeformRequest> requests;
  std::vector<size_t> recordOf;
  for (const CollisionEvent& e : world_.events()) {
    if (e.elasticImpulse < scene_.deformation.impulseFloor) continue;  // the paper's floor: too weak to mark
    EventRecord rec;
    rec.event = e;
    const int bi[2] = {bodyOf[static_cast<size_t>(e.a)], bodyOf[static_cast<size_t>(e.b)]};
    for (int s = 0; s < 2; ++s) {
      const BodyRuntime& body = bodies_[static_cast<size_t>(bi[s])];
      SideDecision& d = rec.side[s];
      d = decideSide(*body.material, body.material->thickness, e.elasticImpulse);
      d.deformed = scene_.deformation.enabled && body.surface && d.deformDepth > 0;
    }
    if (deformer_ && (rec.side[0].deformed || rec.side[1].deformed)) {
      for (int side = 0; side < 2; ++side)
        if (rec.side[side].deformed) beforeDent(bi[side]);
      requests.push_back(eventRequest(e, bi[0], bi[1], rec.side[0].deformed ? rec.side[0].deformDepth : 0,
                                      rec.side[1].deformed ? rec.side[1].deformDepth : 0));
      recordOf.push_back(events_.size());
      ++timings_.deformations;
      deformed = true;
    }
    events_.push_back(rec);
  }
  if (!requests.empty()) {
    const std::vector<int> handles = deformer_->deform(requests);
    for (size_t k = 0; k < handles.size(); ++k) events_[recordOf[k]].statsHandle = handles[k];
  }
  return deformed;
}

bool Simulation::deformContacts(const std::vector<int>& bodyOf, double h) {
  // Resting contact pushes intermittently (a step of push, a step of none), so
  // the strongest report of each pair over the interval is kept.
  for (const CollisionEvent& e : world_.contactReports()) {
    auto [it, inserted] = pendingContacts_.try_emplace({e.a, e.b}, e);
    if (!inserted && e.elasticImpulse >= it->second.elasticImpulse) it->second = e;
  }
  // At most every contact_interval seconds.
  const long every = std::max(1L, std::lround(scene_.deformation.contactInterval / h));
  if (!deformer_ || !scene_.deformation.enabled || steps_ % every != 0) return false;
  bool deformed = false;
  std::vector<CollisionEvent> due;
  for (const auto& [key, e] : pendingContacts_) due.push_back(e);
  pendingContacts_.clear();
  std::vector<deform::DeformRequest> requests;
  for (const CollisionEvent& e : due) {
    const int bi[2] = {bodyOf[static_cast<size_t>(e.a)], bodyOf[static_cast<size_t>(e.b)]};
    double depth[2] = {0, 0};
    for (int s = 0; s < 2; ++s) {
      const BodyRuntime& body = bodies_[static_cast<size_t>(bi[s])];
      if (!body.contactDeformation || !body.surface) continue;
      depth[s] = decideSide(*body.material, body.material->thickness, e.elasticImpulse).deformDepth;
    }
    if (!(depth[0] > 0) && !(depth[1] > 0)) continue;
    for (int side = 0; side < 2; ++side)
      if (depth[side] > 0) beforeDent(bi[side]);
    requests.push_back(eventRequest(e, bi[0], bi[1], depth[0], depth[1]));
    ++timings_.contactDeformations;
    deformed = true;
  }
  if (!requests.empty()) deformer_->deform(requests);
  // Wheels and treads press contact-deformable ground too, their push over
  // one step taken as the impulse (like the resting contacts above).
  for (const VehicleRuntime& v : vehicles_)
    for (const GroundPrint& p : vehiclePrints(v, world_, bodyOf, model(v.body), h))
      deformed |= pressGround(p.groundBody, p.mesh, p.model, p.point, p.normal, p.push);
  return deformed;
}

void Simulation::resolveEventStats() {
  if (!deformer_) return;
  for (EventRecord& r : events_) {
    if (r.statsHandle < 0) continue;
    for (int s = 0; s < 2; ++s)
      if (r.side[s].deformed) r.side[s].stats = deformer_->stats(r.statsHandle, s);
  }
}

}  // namespace crumple
