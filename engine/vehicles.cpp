#include <crumple/engine/vehicles.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <crumple/engine/primitives.h>

namespace crumple {

namespace {
// A wheel's mesh is a cylinder along y: its axle turned onto the body's z.
const glm::dmat4 kWheelToAxle = glm::rotate(glm::dmat4(1), glm::half_pi<double>(), glm::dvec3(1, 0, 0));
}  // namespace

VehicleRuntime makeVehicle(const VehicleDesc& d, int bodyIndex, int worldIndex, bool gl) {
  const VehicleParams& vp = d.params;
  VehicleRuntime v(bodyIndex, Vehicle(worldIndex, vp));
  v.script = d.script;
  v.wheelShape = std::make_shared<TriangleMesh>(cylinderMesh(vp.wheelRadius, d.wheelWidth, 64));
  if (gl) v.wheelMesh = std::make_shared<deform::GpuMesh>(*v.wheelShape);
  if (!d.treads) return v;
  v.pitch = d.treadPitch;
  v.grouserHeight = d.grouserHeight;
  const double r = vp.wheelRadius;
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
  {
    const double w = d.wheelWidth, gh = v.grouserHeight, p = v.pitch;
    // The belt wraps the wheels: from the grousers' roots up to the wheel tops.
    TriangleMesh belt = boxMesh({length, 2 * r, w}, 128);
    for (auto& q : belt.positions) q.y += static_cast<float>(gh + r);
    v.beltShape = std::make_shared<TriangleMesh>(std::move(belt));
    if (gl) v.beltMesh = std::make_shared<deform::GpuMesh>(*v.beltShape);
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
    v.grouserShape = std::make_shared<TriangleMesh>(std::move(bars));
    if (gl) v.grouserMesh = std::make_shared<deform::GpuMesh>(*v.grouserShape);
  }
  return v;
}

VehicleControls scriptAt(const std::vector<VehicleInput>& script, double t) {
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

glm::dmat4 treadModel(const VehicleRuntime& v, size_t t, bool grousers, const glm::dmat4& bodyModel) {
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
  return bodyModel * glm::translate(glm::dmat4(1), glm::dvec3(x, bottom, tr.z));
}

void addVehicleParts(const VehicleRuntime& v, const glm::dmat4& body, std::vector<VehiclePart>& parts) {
  const VehicleParams& p = v.vehicle.params();
  if (v.wheelShape) {
    for (size_t i = 0; i < p.wheels.size(); ++i) {
      const WheelState& w = v.vehicle.wheels()[i];
      // The wheel's centre hangs below its attachment by the spring's length.
      const glm::dvec3 centre = p.wheels[i] - glm::dvec3(0, p.suspensionRest - (w.onGround ? w.compression : 0.0), 0);
      parts.push_back({v.wheelMesh.get(), body * glm::translate(glm::dmat4(1), centre) * kWheelToAxle,
                       glm::vec3(0.06f), v.wheelShape.get(), "wheel"});
    }
  }
  for (size_t t = 0; t < v.treads.size(); ++t) {
    if (v.beltShape)
      parts.push_back({v.beltMesh.get(), treadModel(v, t, false, body), glm::vec3(0.12f, 0.12f, 0.11f),
                       v.beltShape.get(), "belt"});
    if (v.grouserShape)
      parts.push_back({v.grouserMesh.get(), treadModel(v, t, true, body), glm::vec3(0.2f, 0.19f, 0.17f),
                       v.grouserShape.get(), "grousers"});
  }
}

std::vector<GroundPrint> vehiclePrints(const VehicleRuntime& v, const World& world, const std::vector<int>& bodyOf,
                                       const glm::dmat4& bodyModel, double h) {
  std::vector<GroundPrint> prints;
  auto groundOf = [&](const WheelState& w) {
    return w.onGround && w.ground >= 0 ? bodyOf[static_cast<size_t>(w.ground)] : -1;
  };
  if (!v.treads.empty()) {
    for (size_t t = 0; t < v.treads.size(); ++t) {
      double load = 0;
      int groundBody = -1;
      glm::dvec3 contact(0), normal(0);
      for (int wi : v.treads[t].wheels) {
        const WheelState& w = v.vehicle.wheels()[static_cast<size_t>(wi)];
        if (groundOf(w) < 0) continue;
        load += w.load;
        groundBody = groundOf(w);
        contact += w.contact * w.load;
        normal += w.normal * w.load;
      }
      if (groundBody < 0 || !(load > 0)) continue;
      for (bool grousers : {true, false})
        prints.push_back({groundBody, grousers ? v.grouserMesh.get() : v.beltMesh.get(),
                          treadModel(v, t, grousers, bodyModel), contact / load, glm::normalize(normal), 2 * load * h});
    }
    return prints;
  }
  if (!v.wheelMesh) return prints;
  const RigidBody& car = world.body(v.vehicle.body());
  for (const WheelState& w : v.vehicle.wheels()) {
    if (groundOf(w) < 0) continue;
    // The wheel standing on the contact, its axle along the car's.
    const glm::dvec3 centre = w.contact + w.normal * v.vehicle.params().wheelRadius;
    const glm::dmat4 wheel = glm::translate(glm::dmat4(1), centre) * glm::dmat4(car.rotation()) * kWheelToAxle;
    prints.push_back({groundOf(w), v.wheelMesh.get(), wheel, w.contact, w.normal, 2 * w.load * h});
  }
  return prints;
}

}  // namespace crumple
