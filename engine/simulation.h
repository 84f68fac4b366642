// The world of crumple: bodies (physics) with their surfaces (deform), and the
// step loop of docs/architecture.md: physics -> deformation decision -> deform.
#pragma once
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <crumple/deform/deformer.h>
#include <crumple/deform/surface.h>
#include <crumple/engine/assets.h>
#include <crumple/engine/scene.h>
#include <crumple/engine/vehicles.h>
#include <crumple/physics/sdf_grid.h>
#include <crumple/physics/vehicle.h>
#include <crumple/physics/world.h>
#include <crumple/gl/gpu_timer.h>

namespace crumple {

// One side of a collision at the deformation decision (eq. 5 and 6).
struct SideDecision {
  double threshold = 0;  // Y
  double percentDeform = 0;
  double deformDepth = 0;  // t * percentDeform (m)
  bool deformed = false;
  deform::SideStats stats;
};

// Equations 5 and 6 for one side: its threshold Y from its restitution, the
// fraction pushed in by elastic impulse |j_eps=1| (N s), and the dent's depth
// t * percentDeform for wall thickness t (m). `deformed` is left to the caller.
SideDecision decideSide(const Material& material, double thickness, double impulse);

struct EventRecord {
  CollisionEvent event;
  SideDecision side[2];
  int statsHandle = -1;
};

struct BodyRuntime {
  std::string name;
  int index = -1;  // in the physics world
  const Material* material = nullptr;
  std::shared_ptr<const TriangleMesh> mesh;        // render mesh, shape frame, one-to-one uvs
  std::shared_ptr<const deform::GpuMesh> gpuMesh;  // null without GL
  std::unique_ptr<deform::Surface> surface;        // null without a bump map
  std::shared_ptr<const render::GpuLook> look;     // the mesh file's own materials; null without (or without GL)
  bool contactDeformation = false;
};

// A joint that broke (events.jsonl's joint_break line).
struct JointBreakRecord {
  double time = 0;
  std::string joint;  // its name in the scene
  double impulse = 0;
};

// Wall-clock milliseconds (deformMs and renderMs: issuing the GL commands; the GPU runs them behind, never
// waited for in the loop) and the GPU's own milliseconds for the deformations and the frames (timer queries,
// read when they come back: gpuTimes() brings them up to date).
struct Timings {
  double physicsMs = 0, deformMs = 0, renderMs = 0;
  double dentReadMs = 0;  // taking the dents' changed texels into the physics (the fence's wait included)
  double dentWaitMs = 0;  // of which blocked on the fences (the GPU not done a step after the dent)
  long dentReads = 0;     // maps taken in
  long dentTexels = 0;    // texels the change log brought
  long dentFullReads = 0;  // maps read back whole (a step changed more texels than the change log holds)
  double deformGpuMs = 0, renderGpuMs = 0;
  long steps = 0, deformations = 0, frames = 0, contactDeformations = 0;
};

class Simulation {
 public:
  // `gl` true: a current GL context exists (required for bump maps and deformation).
  Simulation(const Scene& scene, bool gl);
  ~Simulation();

  // One step of the scene (std::runtime_error naming the body when physics would go non-finite: the state is
  // then as before the step).
  void step();
  const Scene& scene() const { return scene_; }
  World& world() { return world_; }
  const World& world() const { return world_; }
  const std::vector<BodyRuntime>& bodies() const { return bodies_; }
  std::vector<BodyRuntime>& bodies() { return bodies_; }
  const std::vector<EventRecord>& events() const { return events_; }
  const std::vector<JointBreakRecord>& jointBreaks() const { return jointBreaks_; }
  // The scene's joints, in its order: world joint ids.
  const std::vector<int>& joints() const { return joints_; }
  // The largest impulse (N s) each joint carried in one step so far: what its break_impulse is compared with.
  const std::vector<double>& jointPeaks() const { return jointPeaks_; }
  long steps() const { return steps_; }
  Timings& timings() { return timings_; }
  // Brings timings()' GPU times up to date: the results back so far, or (wait) all of them.
  void gpuTimes(bool wait);
  // Makes the displaced renderer's crease bevels current for every dented surface (deform::Deformer::creaseBevel;
  // drawFrame calls it before a displaced frame).
  void updateCreaseBevels();
  // The frames' GPU timer (drawFrame; null without GL).
  gl::GpuTimer* renderTimer() { return renderTimer_.get(); }
  deform::Deformer* deformer() { return deformer_.get(); }
  std::vector<VehicleRuntime>& vehicles() { return vehicles_; }
  const std::vector<VehicleRuntime>& vehicles() const { return vehicles_; }
  // Live changes (the sandbox's panel).
  std::map<std::string, Material>& sceneMaterials() { return scene_.materials; }
  DeformationSettings& deformationSettings() { return scene_.deformation; }
  void setRestitution(const std::string& material, double eps);
  void setBumpDepths(double k, double kCollide);
  // Address map, update path, tangent correction, crater rims: from the next deformation on.
  void setDeformOptions(const deform::DeformOptions& options);
  void setNormalMappedNormals(bool on);
  // The normal map's normal at a point of body i's surface (shape frame), around
  // the geometric normal n: what contacts use with normal-mapped normals on.
  glm::dvec3 bumpNormal(int body, const glm::dvec3& point, const glm::dvec3& n);
  // Shape frame to world for body i (current pose).
  glm::dmat4 model(int i) const;
  // Shape frame to world for body i at a given pose (a collision's).
  glm::dmat4 modelAt(int i, const Pose& pose) const;
  // Wheels, belts and grousers of the vehicles at their current poses.
  std::vector<VehiclePart> vehicleParts() const;
  // Cables drawn along the distance joints that hold (ropes, chains' strings), at the current poses.
  std::vector<VehiclePart> jointParts() const;
  // Tread frame to world for tread t of vehicle v; `grousers` adds their shift along the belt.
  glm::dmat4 treadModel(const VehicleRuntime& v, size_t t, bool grousers) const {
    return crumple::treadModel(v, t, grousers, model(v.body));
  }
  // Fetches the per-event texel statistics (one small read of the GPU's counters).
  void resolveEventStats();
  // Called after each step with the events it produced (the sandbox's HUD, vehicles).
  std::function<void(const std::vector<CollisionEvent>&)> onStep;
  // External forces for the next step (vehicles).
  std::function<void(Simulation&, double h)> beforeStep;

 private:
  void buildBody(const BodyDesc& desc, size_t index);
  void buildJoints();
  // Kinematic bodies on a path: the velocities that reach the path's pose at time t + h.
  void driveKinematic(double h);
  // The stages of step(): physics with the vehicles' forces; the decision and
  // deformation of this step's collisions; contact deformation. `bodyOf` maps
  // world body indices to bodies_. The last two return whether anything deformed.
  // Throws std::runtime_error naming the body when the world refuses a step that went non-finite.
  void stepPhysics(double h);
  std::string nonFiniteMessage(const StepStatus& status) const;
  bool deformCollisions(const std::vector<int>& bodyOf);
  bool deformContacts(const std::vector<int>& bodyOf, double h);
  // A print of `mesh` (placed by `model`, flat) pressed into contact-deformable
  // ground body `groundBody` by a resting push (N s) at `point`; false when the
  // ground takes no print or the push is below its threshold.
  bool pressGround(int groundBody, const deform::GpuMesh* mesh, const glm::dmat4& model, const glm::dvec3& point,
                   const glm::dvec3& normal, double push);
  // The deformation of one event (a collision or a resting contact) between bodies a and b.
  deform::DeformRequest eventRequest(const CollisionEvent& e, int a, int b, double depthA, double depthB) const;
  Scene scene_;
  bool gl_;
  World world_;
  std::vector<BodyRuntime> bodies_;
  std::vector<EventRecord> events_;
  std::vector<JointBreakRecord> jointBreaks_;
  std::vector<int> joints_;
  std::vector<double> jointPeaks_;
  bool warnedPairs_ = false;
  std::vector<Pose> initialPoses_;  // world bodies' poses when the joints were added
  std::map<std::string, int> groups_;  // collision group names to world groups
  std::shared_ptr<deform::GpuMesh> cableMesh_;  // unit cylinder (radius 1, height 1, along y); null without GL
  std::vector<VehicleRuntime> vehicles_;
  std::map<std::pair<int, int>, CollisionEvent> pendingContacts_;
  struct NormalLookup {
    std::unique_ptr<TriangleBvh> bvh;
    std::vector<unsigned char> normals;  // RGBA8 copy of the normal map
    long version = -1;                   // deformation count when copied
  };
  std::map<int, NormalLookup> normalLookups_;  // by body index in bodies_
  // The world feels its dents (World::setSurfaceDepth): per body of bodies_ whose dents are felt, a CPU copy of
  // its height map where it differs from the start. The deformer logs the texels its commits change in those maps
  // (Deformer::logChanges, written by the GPU into a buffer the CPU reads in place); after a step's deformations a
  // fence follows them, and the next step takes the log in before its physics.
  static constexpr int kDentTile = 16;         // texels: the grain of a map's changed part
  static constexpr double kOnSurface = 0.02;   // m: a lookup point this near a triangle over the change is on it
  static constexpr double kNearCell = 0.0125;  // m: the cells the nearest-triangle lists are kept for
  static constexpr double kGridCell = 0.01;    // m: the finest cells of DentCopy::grid (coarser past kGridCells)
  static constexpr double kGridCells = 1 << 20;
  // What the bodies of one render mesh and map resolution share for their dents, made when the simulation is
  // built (not at the first dent, where the crash's frame would wait for it): the nearest of the mesh's triangles
  // (shape frame; the lists it keeps per cell serve every later lookup on any of them), and per triangle the
  // texels its uvs cover, one around (lo, hi).
  struct DentMesh {
    std::shared_ptr<const NearTriangles> near;
    std::vector<glm::ivec4> triangleTexels;
    std::vector<UvFrame> frames;  // per triangle: its uv frame (uvFrame), all zero where its uvs are degenerate
  };
  std::map<std::pair<const TriangleMesh*, int>, std::shared_ptr<const DentMesh>> dentMeshes_;
  std::map<size_t, std::shared_ptr<const std::vector<float>>> imageStarts_;  // by body: its bump map image's heights
  struct DentCopy {
    bool feel = false;                 // its dents are felt (feel_dents)
    bool pending = false;              // dented this step: its changes are to be taken in
    std::shared_ptr<const DentMesh> mesh;
    std::vector<char> overChange;                           // per triangle: part of it lies over changed texels
    std::vector<std::pair<glm::dvec3, glm::dvec3>> pieces;  // boxes of those parts (shape frame), a changed tile each
    // The map before its first dent: its bump map image's heights, or flat (shared by the bodies of a resolution),
    // known from the start (no read-back from the GPU).
    std::shared_ptr<const std::vector<float>> start;
    int resolution = 0;
    int across = 0;                    // tiles a row
    // Per tile of kDentTile x kDentTile texels (row by row; made at the first take-in): once a dent changed one
    // of its texels, all its texels as the map now holds them (kDentTile a row; empty before: the start holds
    // there), those of them that differ from `start` (their rectangle, none while hi < lo) and the highest of
    // them (0.5 at least).
    struct Tile {
      std::vector<float> texels;
      glm::ivec2 lo{0}, hi{-1};
      float highest = 0.5f;
      bool moved = false;              // changed by the take-in under way
    };
    std::vector<Tile> tiles;
    std::vector<size_t> moved;         // the tiles with `moved` set
    glm::ivec2 lo{0}, hi{-1};          // the texels that differ from `start` (inclusive; none while hi < lo)
    glm::dvec3 boxLo{0}, boxHi{-1};    // shape-frame box of `pieces`, grown by the bump depth (kOnSurface at least)
    // Cells of that box (row by row, gridCell a side): 1 where a point may lie within kOnSurface of a part of a
    // triangle over changed texels (the cell meets a piece's box grown by it); a point elsewhere feels nothing.
    glm::dvec3 gridLo{0};
    double gridCell = 1;
    glm::ivec3 gridDims{0};
    std::vector<unsigned char> grid;
    size_t gridIndex(const glm::ivec3& c) const {
      return (static_cast<size_t>(c.z) * static_cast<size_t>(gridDims.y) + static_cast<size_t>(c.y)) *
                 static_cast<size_t>(gridDims.x) + static_cast<size_t>(c.x);
    }
    double k = 0;                      // the bump depth (m)
    float height(int x, int y) const;  // the map at texel (x, y) as last taken in
    void set(int x, int y, float h);   // takes in one texel's new height
  };
  std::vector<DentCopy> dents_;
  GLsync dentFence_ = nullptr;  // after the last step's deformations: their change log is complete once it signals
  void prepareDents();        // the felt bodies' starting maps and shared meshes (DentMesh)
  void beforeDent(int body);  // body (of bodies_) is about to be dented: its changes are to be taken in
  void readBackDents();       // after the step's deformations: the fence behind their change log
  void takeInDents();         // before the physics: the changes of the last step's deformations, in the world
  void takeInFullMap(DentCopy& d, int body);  // where the log overflowed: the whole map read back, compared
  void measureTiles(DentCopy& d);  // its moved tiles' rectangles and highest, and d.lo/hi
  void findDentedTriangles(DentCopy& d, int body);  // the triangles' parts over its changed texels, in the world
  void markNearChange(DentCopy& d);                 // d.grid
  // Body i's surface's k and k' (k' = k where its dents are felt).
  void setSurfaceDepths(size_t i, float k, float kCollide);
  double surfaceDepth(int body, const glm::dvec3& point, const glm::dvec3& normal, glm::dvec3& bent) const;
  double lookUpDepth(const DentCopy& d, int body, const glm::dvec3& point, const glm::dvec3& normal,
                     glm::dvec3& bent) const;
  std::unique_ptr<deform::Deformer> deformer_;
  std::unique_ptr<gl::GpuTimer> deformTimer_, renderTimer_;
  AssetCache assets_;
  long steps_ = 0;
  Timings timings_;
};

}  // namespace crumple
