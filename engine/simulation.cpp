#include "engine/simulation.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "engine/atlas.h"
#include "engine/mesh_io.h"
#include "engine/primitives.h"
#include "physics/log.h"
#include "physics/stress_strain.h"
#include "render/image.h"

namespace crumple {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {
// The wheel mesh is a cylinder along y; wheels turn about the body's z axis.
const glm::dmat4 kWheelToAxle = glm::rotate(glm::dmat4(1), glm::half_pi<double>(), glm::dvec3(1, 0, 0));
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

std::string shapeKey(const ShapeDesc& s) {
  std::ostringstream os;
  os.precision(17);
  if (s.type == "box") os << "box:" << s.size.x << "," << s.size.y << "," << s.size.z;
  else if (s.type == "sphere") os << "sphere:" << s.radius;
  else if (s.type == "mesh") os << "mesh:" << s.file << "|" << s.scale.x << "," << s.scale.y << "," << s.scale.z;
  else os << s.type << ":" << s.radius << "," << s.height;
  return os.str();
}

deform::Path toDeformPath(DeformPath p) {
  switch (p) {
    case DeformPath::Gather: return deform::Path::Gather;
    case DeformPath::Scatter: return deform::Path::Scatter;
    case DeformPath::Readback: return deform::Path::Readback;
  }
  return deform::Path::Gather;
}
}  // namespace

Simulation::Simulation(const Scene& scene, bool gl) : scene_(scene), gl_(gl) {
  world_.settings().gravity = scene.gravity;
  if (gl_) {
    deform::DeformOptions o;
    o.addressMap = scene.deformation.addressMap;
    o.path = toDeformPath(scene.deformation.path);
    o.tangent = static_cast<deform::TangentMode>(scene.deformation.tangentCorrection);
    o.tangentFloor = static_cast<float>(scene.deformation.tangentFloor);
    o.craterRims = scene.deformation.craterRims;
    deformer_ = std::make_unique<deform::Deformer>(o);
  }
  bodies_.reserve(scene.bodies.size());
  for (size_t i = 0; i < scene.bodies.size(); ++i) buildBody(scene.bodies[i], i);
  if (gl_ && scene.deformation.normalMappedNormals) setNormalMappedNormals(true);
}

Simulation::~Simulation() = default;

void Simulation::setDeformPath(DeformPath p) {
  scene_.deformation.path = p;
  if (deformer_) {
    deform::DeformOptions o = deformer_->options();
    o.path = toDeformPath(p);
    deformer_->setOptions(o);
  }
}

void Simulation::setRestitution(const std::string& material, double eps) {
  Material& m = scene_.materials.at(material);
  m.restitution = std::clamp(eps, 0.0, 1.0);
  for (const BodyRuntime& b : bodies_)
    if (b.material == &m) world_.body(b.index).restitution = m.restitution;
}

void Simulation::setBumpDepths(double k, double kCollide) {
  scene_.deformation.bumpDepth = k;
  scene_.deformation.bumpDepthCollide = kCollide;
  for (BodyRuntime& b : bodies_)
    if (b.surface) b.surface->setBumpDepths(static_cast<float>(k), static_cast<float>(kCollide));
}

void Simulation::setAddressMap(int size) {
  scene_.deformation.addressMap = size;
  if (deformer_) {
    deform::DeformOptions o = deformer_->options();
    o.addressMap = size;
    deformer_->setOptions(o);
  }
}

void Simulation::setCraterRims(bool on) {
  scene_.deformation.craterRims = on;
  if (deformer_) {
    deform::DeformOptions o = deformer_->options();
    o.craterRims = on;
    deformer_->setOptions(o);
  }
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
  const glm::dvec3 e1 = glm::dvec3(b.mesh->positions[t.y] - b.mesh->positions[t.x]);
  const glm::dvec3 e2 = glm::dvec3(b.mesh->positions[t.z] - b.mesh->positions[t.x]);
  const glm::dvec2 d1 = uv1 - uv0, d2 = uv2 - uv0;
  const double det = d1.x * d2.y - d1.y * d2.x;
  if (std::abs(det) < 1e-20) return n;
  glm::dvec3 T = (e1 * d2.y - e2 * d1.y) / det, B = (e2 * d1.x - e1 * d2.x) / det;
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
  const int res = d.bumpMap.present ? d.bumpMap.resolution : 256;
  render::Image initial;
  bool hasImage = false;
  if (d.bumpMap.present && !d.bumpMap.image.empty()) {
    try {
      initial = render::readPng(d.bumpMap.image, 1);
    } catch (const render::ImageError& e) {
      throw SceneError(scene_.file, where + ".bump_map.image", e.what());
    }
    if (initial.width != initial.height)
      throw SceneError(scene_.file, where + ".bump_map.image", "must be square, got " + std::to_string(initial.width) + "x" + std::to_string(initial.height));
    if (initial.width < 8 || initial.width > 4096)
      throw SceneError(scene_.file, where + ".bump_map.image", "size must be in [8, 4096]");
    hasImage = true;
  }
  const int mapRes = hasImage ? initial.width : res;
  const std::string key = shapeKey(d.shape);
  const std::string meshKey = key + "|" + std::to_string(mapRes);

  // Physics shape, shared between bodies of one shape.
  std::shared_ptr<const Shape> shape;
  std::shared_ptr<const TriangleMesh> mesh;
  if (auto it = meshCache_.find(meshKey); it != meshCache_.end()) mesh = it->second;
  try {
    if (auto it = shapeCache_.find(key); it != shapeCache_.end()) shape = it->second;
    const ShapeDesc& s = d.shape;
    if (s.type == "box") {
      if (!shape) shape = makeBox(s.size);
      if (!mesh) mesh = std::make_shared<TriangleMesh>(boxMesh(s.size, mapRes));
    } else if (s.type == "sphere") {
      if (!shape) shape = makeSphere(s.radius);
      if (!mesh) mesh = std::make_shared<TriangleMesh>(sphereMesh(s.radius, mapRes));
    } else if (s.type == "capsule") {
      if (!shape) shape = makeCapsule(s.radius, s.height);
      if (!mesh) mesh = std::make_shared<TriangleMesh>(capsuleMesh(s.radius, s.height, mapRes));
    } else if (s.type == "cylinder") {
      if (!shape) shape = makeCylinder(s.radius, s.height);
      if (!mesh) mesh = std::make_shared<TriangleMesh>(cylinderMesh(s.radius, s.height, mapRes));
    } else {
      TriangleMesh m;
      try {
        m = loadMeshFile(s.file);
      } catch (const MeshError& e) {
        throw SceneError(scene_.file, where + ".shape.file", e.what());
      }
      for (auto& p : m.positions) p *= glm::vec3(s.scale);
      for (auto& n : m.normals) n = glm::normalize(n / glm::vec3(s.scale));
      const double volume = polyhedralMassProperties(m).volume;
      if (volume < 0) {
        logWarning(where, " (", d.name, "): ", s.file, " is inside out: flipped its triangles");
        for (auto& t : m.triangles) std::swap(t.y, t.z);
        for (auto& n : m.normals) n = -n;
      }
      if (!mesh) {
        const AtlasCheck check = checkAtlas(m, mapRes);
        if (!check.oneToOne) {
          std::string why = check.missing ? "has no texture coordinates"
                            : check.overlappingTexels ? std::to_string(check.overlappingTexels) + " texels used twice"
                            : check.outsideTriangles ? std::to_string(check.outsideTriangles) + " triangles outside [0,1]"
                                                     : std::to_string(check.collapsedTriangles) + " triangles with no texture area";
          m = generateAtlas(m, mapRes);
          logInfo(where, " (", d.name, "): ", fs::path(s.file).filename().string(), " ", why,
                  ": generated an automatic one-to-one atlas");
        }
        mesh = std::make_shared<TriangleMesh>(std::move(m));
      }
      if (!shape) shape = makeMeshShape(*mesh);
    }
  } catch (const std::invalid_argument& e) {
    throw SceneError(scene_.file, where + ".shape", e.what());
  }
  shapeCache_[key] = shape;
  meshCache_[meshKey] = mesh;
  b.mesh = mesh;

  BodyDef def;
  def.shape = shape;
  def.origin = d.position;
  def.orientation = d.orientation;
  def.linearVelocity = d.velocity;
  def.angularVelocity = d.angularVelocity;
  def.density = b.material->density;
  def.mass = d.mass.value_or(0.0);
  def.restitution = b.material->restitution;
  def.friction = b.material->friction;
  def.isStatic = d.isStatic;
  try {
    b.index = world_.addBody(def);
  } catch (const std::invalid_argument& e) {
    throw SceneError(scene_.file, where, e.what());
  }
  b.contactDeformation = d.contactDeformation;
  if (d.contactDeformation) world_.setReportContacts(b.index, true);

  if (gl_) {
    auto& g = gpuMeshCache_[meshKey];
    if (!g) g = std::make_shared<deform::GpuMesh>(*mesh);
    b.gpuMesh = g;
    if (d.bumpMap.present) {
      const float k = static_cast<float>(d.bumpMap.bumpDepth.value_or(scene_.deformation.bumpDepth));
      const float kc = static_cast<float>(d.bumpMap.bumpDepthCollide.value_or(scene_.deformation.bumpDepthCollide));
      const float texel = static_cast<float>(g->metresPerUv / mapRes);
      std::shared_ptr<deform::SurfaceMaps> maps;
      const std::string mapKey = meshKey + "|" + std::to_string(k);
      if (hasImage) {
        maps = deformer_->createMaps(mapRes, &initial, k, texel);
      } else if (scene_.deformation.lazyMaps) {
        auto& shared = mapCache_[mapKey];
        if (!shared) shared = deformer_->createMaps(mapRes, nullptr, k, texel);
        maps = shared;
      } else {
        maps = deformer_->createMaps(mapRes, nullptr, k, texel);
      }
      b.surface = std::make_unique<deform::Surface>(g, mapRes, k, kc, maps);
    }
  }
  if (d.vehicle.present) {
    VehicleParams vp;
    vp.wheels = d.vehicle.wheels;
    vp.wheelRadius = d.vehicle.wheelRadius;
    vp.suspensionRest = d.vehicle.suspensionRest;
    vp.stiffness = d.vehicle.suspensionStiffness;
    vp.damping = d.vehicle.suspensionDamping;
    vp.engineForce = d.vehicle.engineForce;
    vp.brakeForce = d.vehicle.brakeForce;
    vp.maxSteer = d.vehicle.maxSteer;
    vp.grip = d.vehicle.tyreGrip;
    VehicleRuntime v(static_cast<int>(bodies_.size()), Vehicle(b.index, vp));
    v.script = d.vehicle.script;
    if (gl_) v.wheelMesh = std::make_shared<deform::GpuMesh>(cylinderMesh(d.vehicle.wheelRadius, d.vehicle.wheelWidth, 64));
    if (d.vehicle.treads) {
      v.pitch = d.vehicle.treadPitch;
      v.grouserHeight = d.vehicle.grouserHeight;
      const double r = d.vehicle.wheelRadius;
      double length = 0;
      for (double side : {1.0, -1.0}) {
        TreadRuntime t;
        double lo = 1e300, hi = -1e300, z = 0;
        for (size_t i = 0; i < vp.wheels.size(); ++i) {
          if ((vp.wheels[i].z < 0) != (side < 0)) continue;
          t.wheels.push_back(static_cast<int>(i));
          lo = std::min(lo, vp.wheels[i].x);
          hi = std::max(hi, vp.wheels[i].x);
          z += vp.wheels[i].z;
        }
        t.centreX = 0.5 * (lo + hi);
        t.z = z / static_cast<double>(t.wheels.size());
        length = std::max(length, hi - lo + 2 * r);
        v.treads.push_back(t);
      }
      if (gl_) {
        const double w = d.vehicle.wheelWidth, gh = v.grouserHeight, p = v.pitch;
        // The belt wraps the wheels: from the grousers' roots up to the wheel tops.
        TriangleMesh belt = boxMesh({length, 2 * r, w}, 128);
        for (auto& q : belt.positions) q.y += static_cast<float>(gh + r);
        v.beltMesh = std::make_shared<deform::GpuMesh>(belt);
        // Grousers every pitch along the belt's underside, as many as fit
        // whatever their shift in [0, pitch).
        TriangleMesh bars;
        const int count = std::max(1, static_cast<int>(std::floor(length / p)) - 1);
        const TriangleMesh bar = boxMesh({0.4 * p, gh, w}, 16);
        for (int k = 0; k < count; ++k) {
          const float x = static_cast<float>(-0.5 * length + p * (k + 1));
          const auto base = static_cast<unsigned>(bars.positions.size());
          for (const auto& q : bar.positions) bars.positions.push_back(q + glm::vec3(x, static_cast<float>(0.5 * gh), 0));
          bars.normals.insert(bars.normals.end(), bar.normals.begin(), bar.normals.end());
          bars.uvs.insert(bars.uvs.end(), bar.uvs.begin(), bar.uvs.end());
          for (const auto& tri : bar.triangles) bars.triangles.push_back(tri + glm::uvec3(base));
        }
        v.grouserMesh = std::make_shared<deform::GpuMesh>(bars);
      }
    }
    vehicles_.push_back(std::move(v));
  }
  bodies_.push_back(std::move(b));
}

bool Simulation::pressGround(int groundBody, const deform::GpuMesh* mesh, const glm::dmat4& model, const glm::dvec3& point,
                             const glm::dvec3& normal, double push) {
  BodyRuntime& ground = bodies_[static_cast<size_t>(groundBody)];
  if (!ground.contactDeformation || !ground.surface) return false;
  const double depth = deformDepth(ground.material->thickness, percentDeform(ground.material->kappa, push,
                                                                    yieldThreshold(ground.material->restitution)));
  if (!(depth > 0)) return false;
  const RigidBody& g = world_.body(ground.index);
  deform::DeformRequest rq;
  rq.a = {ground.surface.get(), ground.gpuMesh.get(), modelAt(groundBody, {g.x, g.q})};
  rq.b = {nullptr, mesh, model};
  rq.point = point;
  rq.normal = normal;
  rq.penetration = 0;
  rq.deformA = depth;
  deformer_->deform(rq);
  ++timings_.contactDeformations;
  return true;
}

glm::dmat4 Simulation::treadModel(const VehicleRuntime& v, size_t t, bool grousers) const {
  const TreadRuntime& tr = v.treads[t];
  const VehicleParams& p = v.vehicle.params();
  // The grousers' bottom: where that side's wheels meet the ground (their
  // suspension as it is now), in the body's shape frame.
  double bottom = 0;
  for (int wi : tr.wheels) {
    const WheelState& w = v.vehicle.wheels()[static_cast<size_t>(wi)];
    bottom += p.wheels[static_cast<size_t>(wi)].y - p.suspensionRest + w.compression - p.wheelRadius;
  }
  bottom /= static_cast<double>(tr.wheels.size());
  double x = tr.centreX;
  if (grousers) x -= std::fmod(std::fmod(v.travel, v.pitch) + v.pitch, v.pitch);
  return model(v.body) * glm::translate(glm::dmat4(1), glm::dvec3(x, bottom, tr.z));
}

std::vector<VehiclePart> Simulation::vehicleParts() const {
  std::vector<VehiclePart> parts;
  for (const VehicleRuntime& v : vehicles_) {
    const VehicleParams& p = v.vehicle.params();
    const glm::dmat4 body = model(v.body);
    if (v.wheelMesh) {
      for (size_t i = 0; i < p.wheels.size(); ++i) {
        const WheelState& w = v.vehicle.wheels()[i];
        // The wheel's centre hangs below its attachment by the spring's length.
        const glm::dvec3 centre = p.wheels[i] - glm::dvec3(0, p.suspensionRest - (w.onGround ? w.compression : 0.0), 0);
        parts.push_back({v.wheelMesh.get(), body * glm::translate(glm::dmat4(1), centre) * kWheelToAxle, glm::vec3(0.06f)});
      }
    }
    for (size_t t = 0; t < v.treads.size(); ++t) {
      if (v.beltMesh) parts.push_back({v.beltMesh.get(), treadModel(v, t, false), glm::vec3(0.12f, 0.12f, 0.11f)});
      if (v.grouserMesh) parts.push_back({v.grouserMesh.get(), treadModel(v, t, true), glm::vec3(0.2f, 0.19f, 0.17f)});
    }
  }
  return parts;
}

VehicleControls Simulation::scriptAt(const std::vector<VehicleInput>& script, double t) {
  VehicleControls c;
  for (const VehicleInput& in : script) {
    if (in.time > t) break;
    c.throttle = in.throttle;
    c.steer = in.steer;
    c.brake = in.brake;
    c.handbrake = in.handbrake;
  }
  return c;
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

deform::DeformRequest Simulation::eventRequest(const CollisionEvent& e, int a, int b, double depthA, double depthB) const {
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

void Simulation::step() {
  const double h = scene_.timestep;
  auto t0 = Clock::now();
  if (beforeStep) beforeStep(*this, h);
  for (VehicleRuntime& v : vehicles_) {
    const VehicleControls c = v.manual ? v.controls : scriptAt(v.script, world_.time());
    world_.wake(v.vehicle.body());
    v.vehicle.apply(world_, c, h);
  }
  world_.step(h);
  for (VehicleRuntime& v : vehicles_) {
    const RigidBody& car = world_.body(v.vehicle.body());
    v.travel += glm::dot(car.v, car.rotation() * glm::dvec3(1, 0, 0)) * h;
  }
  timings_.physicsMs += msSince(t0);
  ++steps_;
  ++timings_.steps;

  // The deformation decision (eq. 5, 6) for every collision of this step.
  t0 = Clock::now();
  bool deformed = false;
  std::vector<int> bodyOf(world_.size(), -1);
  for (size_t i = 0; i < bodies_.size(); ++i) bodyOf[static_cast<size_t>(bodies_[i].index)] = static_cast<int>(i);
  for (const CollisionEvent& e : world_.events()) {
    if (e.elasticImpulse < scene_.deformation.impulseFloor) continue;  // the paper's floor: too weak to mark
    EventRecord rec;
    rec.event = e;
    const int bi[2] = {bodyOf[static_cast<size_t>(e.a)], bodyOf[static_cast<size_t>(e.b)]};
    for (int s = 0; s < 2; ++s) {
      const BodyRuntime& body = bodies_[static_cast<size_t>(bi[s])];
      SideDecision& d = rec.side[s];
      d.threshold = yieldThreshold(body.material->restitution);
      d.percentDeform = percentDeform(body.material->kappa, e.elasticImpulse, d.threshold);
      d.deformDepth = deformDepth(body.material->thickness, d.percentDeform);
      d.deformed = scene_.deformation.enabled && body.surface && d.deformDepth > 0;
    }
    if (deformer_ && (rec.side[0].deformed || rec.side[1].deformed)) {
      rec.statsHandle = deformer_->deform(eventRequest(e, bi[0], bi[1], rec.side[0].deformed ? rec.side[0].deformDepth : 0,
                                                       rec.side[1].deformed ? rec.side[1].deformDepth : 0));
      ++timings_.deformations;
      deformed = true;
    }
    events_.push_back(rec);
  }
  // Contact deformation (figure 8): resting contacts of flagged bodies press
  // their maps too, at most every contact_interval seconds.
  const long every = std::max(1L, std::lround(scene_.deformation.contactInterval / h));
  // Resting contact pushes intermittently (a step of push, a step of none), so
  // the strongest report of each pair over the interval is kept.
  for (const CollisionEvent& e : world_.contactReports()) {
    auto [it, inserted] = pendingContacts_.try_emplace({e.a, e.b}, e);
    if (!inserted && e.elasticImpulse >= it->second.elasticImpulse) it->second = e;
  }
  if (deformer_ && scene_.deformation.enabled && steps_ % every == 0) {
    std::vector<CollisionEvent> due;
    for (const auto& [key, e] : pendingContacts_) due.push_back(e);
    pendingContacts_.clear();
    for (const CollisionEvent& e : due) {
      const int bi[2] = {bodyOf[static_cast<size_t>(e.a)], bodyOf[static_cast<size_t>(e.b)]};
      double depth[2] = {0, 0};
      for (int s = 0; s < 2; ++s) {
        const BodyRuntime& body = bodies_[static_cast<size_t>(bi[s])];
        if (!body.contactDeformation || !body.surface) continue;
        depth[s] = deformDepth(body.material->thickness, percentDeform(body.material->kappa, e.elasticImpulse,
                                                             yieldThreshold(body.material->restitution)));
      }
      if (!(depth[0] > 0) && !(depth[1] > 0)) continue;
      deformer_->deform(eventRequest(e, bi[0], bi[1], depth[0], depth[1]));
      ++timings_.contactDeformations;
      deformed = true;
    }
    // Wheels press contact-deformable ground too: a wheel-shaped print under
    // each loaded wheel, its push over one step taken as the impulse (like the
    // resting contacts above).
    for (const VehicleRuntime& v : vehicles_) {
      if (!v.treads.empty()) {
        // Tracks: each belt presses with its wheels' load; the grousers print
        // first, the belt between them once the grousers have sunk in.
        for (size_t t = 0; t < v.treads.size(); ++t) {
          double load = 0;
          int groundBody = -1;
          glm::dvec3 contact(0), normal(0);
          for (int wi : v.treads[t].wheels) {
            const WheelState& w = v.vehicle.wheels()[static_cast<size_t>(wi)];
            if (!w.onGround || w.ground < 0 || bodyOf[static_cast<size_t>(w.ground)] < 0) continue;
            load += w.load;
            groundBody = bodyOf[static_cast<size_t>(w.ground)];
            contact += w.contact * w.load;
            normal += w.normal * w.load;
          }
          if (groundBody < 0 || !(load > 0)) continue;
          for (bool grousers : {true, false})
            deformed |= pressGround(groundBody, grousers ? v.grouserMesh.get() : v.beltMesh.get(),
                                    treadModel(v, t, grousers), contact / load, glm::normalize(normal), 2 * load * h);
        }
        continue;
      }
      if (!v.wheelMesh) continue;
      const RigidBody& car = world_.body(v.vehicle.body());
      for (const WheelState& w : v.vehicle.wheels()) {
        if (!w.onGround || w.ground < 0 || bodyOf[static_cast<size_t>(w.ground)] < 0) continue;
        // The wheel standing on the contact, its axle along the car's.
        const glm::dvec3 centre = w.contact + w.normal * v.vehicle.params().wheelRadius;
        const glm::dmat4 wheel = glm::translate(glm::dmat4(1), centre) * glm::dmat4(car.rotation()) * kWheelToAxle;
        deformed |= pressGround(bodyOf[static_cast<size_t>(w.ground)], v.wheelMesh.get(), wheel, w.contact, w.normal,
                                2 * w.load * h);
      }
    }
  }
  if (deformed) glFinish();  // honest timings: the GPU work is part of the deformation's cost
  timings_.deformMs += msSince(t0);
  if (onStep) onStep(world_.events());
}

void Simulation::resolveEventStats() {
  if (!deformer_) return;
  for (EventRecord& r : events_) {
    if (r.statsHandle < 0) continue;
    for (int s = 0; s < 2; ++s)
      if (r.side[s].deformed) r.side[s].stats = deformer_->stats(r.statsHandle, s);
  }
}

// ---- outputs ---------------------------------------------------------------

OutputWriter::OutputWriter(const std::string& dir) : dir_(fs::absolute(dir).lexically_normal().string()) {
  while (!dir_.empty() && dir_.back() == '/') dir_.pop_back();
  std::error_code ec;
  if (fs::exists(dir_, ec)) {
    if (!fs::is_directory(dir_, ec)) throw SceneError(dir, "", "output path exists and is not a folder");
    const bool empty = fs::is_empty(dir_, ec);
    if (!empty && !fs::exists(fs::path(dir_) / "summary.json", ec))
      throw SceneError(dir, "", "output folder exists, is not empty and holds no crumple output (summary.json): refusing to overwrite it");
  }
  const fs::path parent = fs::path(dir_).parent_path();
  fs::create_directories(parent, ec);
  if (ec) throw SceneError(dir, "", "cannot create the parent folder: " + ec.message());
  std::random_device rd;
  staging_ = dir_ + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(rd() % 100000);
  fs::create_directories(staging_, ec);
  if (ec) throw SceneError(dir, "", "cannot create a folder next to it: " + ec.message());
}

OutputWriter::~OutputWriter() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
  }
}

namespace {
nlohmann::ordered_json vec(const glm::dvec3& v) { return {v.x, v.y, v.z}; }
}  // namespace

void OutputWriter::write(Simulation& sim, const std::map<std::string, std::string>& extra) {
  using json = nlohmann::ordered_json;
  sim.resolveEventStats();
  const fs::path root(staging_);
  fs::create_directories(root / "heightmaps");
  fs::create_directories(root / "normalmaps");
  // Events.
  {
    std::ofstream ev(root / "events.jsonl");
    for (const EventRecord& r : sim.events()) {
      const auto& e = r.event;
      json line;
      line["t"] = e.time;
      const std::string* names[2] = {nullptr, nullptr};
      for (const auto& b : sim.bodies()) {
        if (b.index == e.a) names[0] = &b.name;
        if (b.index == e.b) names[1] = &b.name;
      }
      line["a"] = *names[0];
      line["b"] = *names[1];
      line["point"] = vec(e.point);
      line["normal"] = vec(e.normal);
      line["penetration"] = e.penetration;
      line["impulse_elastic"] = e.elasticImpulse;
      line["impulse"] = e.impulse;
      for (int s = 0; s < 2; ++s) {
        const SideDecision& d = r.side[s];
        json side;
        side["threshold"] = std::isfinite(d.threshold) ? json(d.threshold) : json(nullptr);  // null: infinite (eps = 1)
        side["percent_deform"] = d.percentDeform;
        side["deform_depth"] = d.deformDepth;
        side["deformed"] = d.deformed;
        side["texels_changed"] = d.stats.texelsChanged;
        side["max_dent"] = d.stats.maxDent;
        side["saturated"] = d.stats.saturated;
        line[s == 0 ? "a_side" : "b_side"] = side;
      }
      ev << line.dump() << "\n";
    }
    if (!ev) throw std::runtime_error("writing events.jsonl failed");
  }
  // Maps.
  long deformedSides = 0;
  for (const EventRecord& r : sim.events()) deformedSides += r.side[0].deformed + r.side[1].deformed;
  // Bodies that were never dented share their maps (lazy maps): encode each once, copy the files.
  std::map<GLuint, std::string> written;
  for (const auto& b : sim.bodies()) {
    if (!b.surface) continue;
    const fs::path heightPath = root / "heightmaps" / (b.name + ".png"), normalPath = root / "normalmaps" / (b.name + ".png");
    if (auto it = written.find(b.surface->height().id()); it != written.end()) {
      fs::copy_file(root / "heightmaps" / it->second, heightPath);
      fs::copy_file(root / "normalmaps" / it->second, normalPath);
      continue;
    }
    written[b.surface->height().id()] = b.name + ".png";
    const render::Image h = b.surface->downloadHeight();
    render::writePng(heightPath.string(), h, 16);
    const int n = b.surface->resolution();
    std::vector<unsigned char> rgba(static_cast<size_t>(n) * n * 4);
    b.surface->normal().download(GL_RGBA, GL_UNSIGNED_BYTE, rgba.data(), rgba.size());
    render::Image nm(n, n, 3);
    for (size_t i = 0; i < static_cast<size_t>(n) * n; ++i)
      for (int c = 0; c < 3; ++c) nm.pixels[i * 3 + static_cast<size_t>(c)] = rgba[i * 4 + static_cast<size_t>(c)] / 255.0f;
    render::writePng(normalPath.string(), nm, 8);
  }
  // Summary.
  json s;
  s["scene"] = sim.scene().name;
  s["scene_file"] = sim.scene().file;
  s["steps"] = sim.steps();
  s["time"] = sim.world().time();
  json bodies = json::array();
  for (const auto& b : sim.bodies()) {
    const RigidBody& rb = sim.world().body(b.index);
    json jb;
    jb["name"] = b.name;
    jb["position"] = vec(rb.origin());
    jb["orientation"] = {rb.q.w, rb.q.x, rb.q.y, rb.q.z};
    jb["linear_velocity"] = vec(rb.v);
    jb["angular_velocity"] = vec(rb.w);
    jb["center_of_mass"] = vec(rb.x);
    jb["mass"] = rb.isStatic ? json(nullptr) : json(rb.mass);
    jb["static"] = rb.isStatic;
    jb["asleep"] = rb.asleep;
    bodies.push_back(jb);
  }
  s["bodies"] = bodies;
  s["collisions"] = sim.events().size();
  s["deformations"] = sim.timings().deformations;
  s["deformed_sides"] = deformedSides;
  s["contact_deformations"] = sim.timings().contactDeformations;
  const Timings& t = sim.timings();
  json tj;
  tj["physics_ms"] = t.physicsMs;
  tj["physics_ms_per_step"] = t.steps ? t.physicsMs / static_cast<double>(t.steps) : 0.0;
  tj["deform_ms"] = t.deformMs;
  tj["deform_ms_per_deformation"] = t.deformations ? t.deformMs / static_cast<double>(t.deformations) : 0.0;
  tj["render_ms"] = t.renderMs;
  tj["render_ms_per_frame"] = t.frames ? t.renderMs / static_cast<double>(t.frames) : 0.0;
  tj["frames"] = t.frames;
  s["timings"] = tj;
  for (const auto& [k, v] : extra) s[k] = v;
  std::ofstream f(root / "summary.json");
  f << s.dump(2) << "\n";
  if (!f) throw std::runtime_error("writing summary.json failed");
}

void OutputWriter::commit() {
  std::error_code ec;
  if (fs::exists(dir_, ec)) {
    const std::string old = staging_ + ".old";
    fs::rename(dir_, old, ec);
    if (ec) throw std::runtime_error(dir_ + ": cannot replace the previous output: " + ec.message());
    fs::rename(staging_, dir_, ec);
    if (ec) {
      fs::rename(old, dir_);
      throw std::runtime_error(dir_ + ": cannot move the new output into place: " + ec.message());
    }
    fs::remove_all(old, ec);
  } else {
    fs::rename(staging_, dir_, ec);
    if (ec) throw std::runtime_error(dir_ + ": cannot move the output into place: " + ec.message());
  }
  committed_ = true;
}

namespace engine::scenes {
std::string_view shaderSource(std::string_view name);
}

std::string builtinSceneText(const std::string& name) {
  if (name == "default" || name == "sphere-into-plate") return std::string(engine::scenes::shaderSource("sphere-into-plate.json"));
  if (name == "highway") return std::string(engine::scenes::shaderSource("highway.json"));
  for (const char* asset : {"car.obj", "sedan.obj", "wbeam.obj"})
    if (name == asset) return std::string(engine::scenes::shaderSource(asset));
  throw std::invalid_argument("no built-in scene named " + name);
}

Scene builtinHighway() {
  const fs::path dir = fs::temp_directory_path() / ("crumple-highway-" + std::to_string(::getpid()));
  fs::create_directories(dir / "assets");
  for (const char* asset : {"sedan.obj", "wbeam.obj"}) std::ofstream(dir / "assets" / asset) << builtinSceneText(asset);
  return parseScene(builtinSceneText("highway"), "<built-in highway scene>", dir.string());
}

}  // namespace crumple
