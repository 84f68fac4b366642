// Vehicles in a simulation: raycast cars (physics/vehicle.h) with their
// wheels drawn, tracked vehicles' belts and grousers, the scripted input, and
// the prints wheels and treads press into contact-deformable ground.
#pragma once
#include <glm/glm.hpp>

#include <functional>
#include <memory>
#include <vector>

#include <crumple/deform/surface.h>
#include <crumple/engine/scene.h>
#include <crumple/physics/vehicle.h>
#include <crumple/physics/world.h>

namespace crumple {

// One track of a tracked vehicle: the belt around the wheels of one side.
// Tread frame: x forward along the body's x, origin at the belt's centre in x,
// on that side's wheel plane (z), at the grousers' bottom (the ground).
struct TreadRuntime {
  double centreX = 0, z = 0;
  std::vector<int> wheels;  // indices into the vehicle's wheels
};

struct VehicleRuntime {
  VehicleRuntime(int bodyIndex, const Vehicle& v) : body(bodyIndex), vehicle(v) {}
  int body = -1;  // index in Simulation::bodies()
  Vehicle vehicle;
  std::shared_ptr<const deform::GpuMesh> wheelMesh;  // prints wheels into contact-deformable ground
  std::vector<VehicleInput> script;
  bool manual = false;  // the sandbox drives: `controls` instead of the script
  VehicleControls controls;
  // Tracked vehicles: two treads, the belt and the grousers as meshes in the
  // tread frame. The grousers move back along the belt as the body moves on
  // (`travel`), so that under the body they stay put on the ground, as a
  // track's links do, and print a clean ladder.
  std::vector<TreadRuntime> treads;
  std::shared_ptr<const deform::GpuMesh> beltMesh, grouserMesh;
  // The wheel's, the belt's and the grousers' meshes on the CPU (for exports; the GPU's above are made from them).
  std::shared_ptr<const TriangleMesh> wheelShape, beltShape, grouserShape;
  double pitch = 0, grouserHeight = 0;
  double travel = 0;  // m along the body's x since the start
};

// A vehicle's wheel or track, placed in the world, for drawing.
struct VehiclePart {
  const deform::GpuMesh* mesh = nullptr;  // null without GL
  glm::dmat4 model{1};
  glm::vec3 color{0.08f};
  const TriangleMesh* shape = nullptr;  // the mesh on the CPU (exports)
  const char* kind = "part";            // "wheel", "belt", "grousers", "cable"
};

// A vehicle for body `bodyIndex` (in Simulation::bodies()), world body `worldIndex`;
// with `gl`, the meshes of its wheels, belts and grousers.
VehicleRuntime makeVehicle(const VehicleDesc& desc, int bodyIndex, int worldIndex, bool gl);

// The scripted input at time t (the last entry at or before t; zero before the first).
VehicleControls scriptAt(const std::vector<VehicleInput>& script, double t);

// Tread frame to world for tread t of v (body at `bodyModel`); `grousers` adds their shift along the belt.
glm::dmat4 treadModel(const VehicleRuntime& v, size_t t, bool grousers, const glm::dmat4& bodyModel);

// Wheels, belts and grousers of v (body at `bodyModel`) at their current poses, appended to `parts`.
void addVehicleParts(const VehicleRuntime& v, const glm::dmat4& bodyModel, std::vector<VehiclePart>& parts);

// A print a wheel or tread presses into the ground: `mesh` placed by `model`,
// pushed into ground body `groundBody` (index in Simulation::bodies()) at
// `point` along `normal` with impulse `push` (N s) over the step.
struct GroundPrint {
  int groundBody = -1;
  const deform::GpuMesh* mesh = nullptr;
  glm::dmat4 model{1};
  glm::dvec3 point{0}, normal{0};
  double push = 0;
};
// The prints of v over a step of h: tracks press each belt with its wheels'
// load (the grousers first, then the belt between them); cars a wheel-shaped
// print under each loaded wheel. `bodyOf` maps world body indices to
// Simulation::bodies() (-1: none).
std::vector<GroundPrint> vehiclePrints(const VehicleRuntime& v, const World& world, const std::vector<int>& bodyOf,
                                       const glm::dmat4& bodyModel, double h);

}  // namespace crumple
