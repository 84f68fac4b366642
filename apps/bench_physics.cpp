// crumple-bench's physics rows: its scenes (bench_scenes.h) built in crumple, Bullet and Jolt, and stepped.
#include <btBulletDynamicsCommon.h>
#include <BulletCollision/Gimpact/btGImpactCollisionAlgorithm.h>
#include <BulletCollision/Gimpact/btGImpactShape.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <glm/gtc/constants.hpp>
#include <memory>
#include <string>
#include <tuple>

#include <crumple/engine/primitives.h>
#include <crumple/physics/world.h>

#include "bench_rows.h"

namespace crumple::bench {

namespace {

constexpr double kStep = 1.0 / 240;
}  // namespace


SceneSpec chainScene(int chains, int links) {
  SceneSpec s;
  s.chains = chains;
  s.links = links;
  return s;
}
namespace {

BodySpec box(const glm::dvec3& size, const glm::dvec3& position) {
  BodySpec b;
  b.size = size;
  b.position = position;
  return b;
}
}  // namespace

SceneSpec pyramid(int levels) {
  SceneSpec s;
  for (int row = 0; row < levels; ++row)
    for (int k = 0; k < levels - row; ++k)
      s.bodies.push_back(box({0.5, 0.5, 0.5}, {(k - (levels - row - 1) / 2.0) * 0.51, 0.25 + row * 0.5, 0}));
  return s;
}
// nx by nz columns of `layers` 0.4 m boxes, 0.5 m apart; every other layer shifted 5 cm along x.
SceneSpec pile(int nx, int nz, int layers) {
  SceneSpec s;
  for (int l = 0; l < layers; ++l)
    for (int z = 0; z < nz; ++z)
      for (int x = 0; x < nx; ++x)
        s.bodies.push_back(box({0.4, 0.4, 0.4}, {x * 0.5 - (nx - 1) * 0.25 + 0.05 * (l % 2), 0.3 + 0.5 * l,
                                                 z * 0.5 - (nz - 1) * 0.25}));
  return s;
}
namespace {
glm::dvec3 torusPosition(int k) { return {-2.0 + 0.85 * (k % 6), 0.5 + 0.85 * (k / 36), -2.0 + 0.85 * ((k / 6) % 6)}; }
glm::dquat torusOrientation(int k) {
  return glm::angleAxis(0.7 * k, glm::normalize(glm::dvec3(1, 0.3 * (k % 3), 0.5)));
}
BodySpec torus(const glm::dvec3& position, const glm::dquat& orientation) {
  BodySpec b;
  b.kind = Kind::Torus;
  b.position = position;
  b.orientation = orientation;
  b.friction = 0.5;
  b.restitution = 0.2;
  b.density = 800;
  return b;
}
}  // namespace

SceneSpec toriScene(int n) {
  SceneSpec s;
  for (int k = 0; k < n; ++k) s.bodies.push_back(torus(torusPosition(k), torusOrientation(k)));
  return s;
}
// A heap of n mixed bodies dropped in a tight block onto the ground: boxes, spheres and capsules
// (0.2-0.5 m, random orientations) and, every n/12-th, a torus (12 in all).
SceneSpec heapScene(int n) {
  SceneSpec s;
  uint64_t state = 11;
  auto u = [&]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  };
  const int side = 8;
  const double cell = 0.6;
  const int torusEvery = std::max(1, n / 12);
  for (int k = 0; k < n; ++k) {
    const int x = k % side, z = (k / side) % side, layer = k / (side * side);
    const glm::dvec3 p((x - (side - 1) * 0.5) * cell + 0.05 * (u() - 0.5), 0.35 + layer * cell,
                       (z - (side - 1) * 0.5) * cell + 0.05 * (u() - 0.5));
    const glm::dquat q = glm::angleAxis(6.283 * u(), glm::normalize(glm::dvec3(u() - 0.5, u() - 0.5, u() - 0.5) +
                                                                      glm::dvec3(1e-3, 0, 0)));
    BodySpec b;
    if (k % torusEvery == torusEvery / 2 && k / torusEvery < 12) {
      b = torus(p, q);
    } else if (k % 3 == 0) {
      b = box({0.2 + 0.3 * u(), 0.2 + 0.3 * u(), 0.2 + 0.3 * u()}, p);
    } else if (k % 3 == 1) {
      b.kind = Kind::Sphere;
      b.size = {0.1 + 0.12 * u(), 0, 0};
    } else {
      b.kind = Kind::Capsule;
      b.size = {0.08 + 0.07 * u(), 0.1 + 0.2 * u(), 0};
    }
    b.position = p;
    b.orientation = q;
    s.bodies.push_back(b);
  }
  return s;
}
namespace {


std::shared_ptr<Shape> crumpleShape(const BodySpec& b, const std::shared_ptr<Shape>& torus) {
  switch (b.kind) {
    case Kind::Box:
      return makeBox(b.size);
    case Kind::Sphere:
      return makeSphere(b.size.x);
    case Kind::Capsule:
      return makeCapsule(b.size.x, b.size.y);
    case Kind::Torus:
      return torus;
  }
  return nullptr;
}

std::unique_ptr<World> crumpleWorld(const SceneSpec& spec) {
  auto w = std::make_unique<World>();
  BodyDef g;
  g.shape = makeBox({60, 1, 60});
  g.origin = {0, -0.5, 0};
  g.isStatic = true;
  g.friction = 0.6;
  g.restitution = 0.1;
  w->addBody(g);
  std::shared_ptr<Shape> torus;
  for (const auto& b : spec.bodies)
    if (b.kind == Kind::Torus && !torus) torus = makeMeshShape(benchTorus(), 32);
  // One shape per distinct kind and size, shared by its bodies (as the scene loader and Bullet's side do).
  std::map<std::tuple<int, double, double, double>, std::shared_ptr<Shape>> shapes;
  for (const auto& b : spec.bodies) {
    BodyDef d;
    std::shared_ptr<Shape>& shape = shapes[{static_cast<int>(b.kind), b.size.x, b.size.y, b.size.z}];
    if (!shape) shape = crumpleShape(b, torus);
    d.shape = shape;
    d.origin = b.position;
    d.orientation = b.orientation;
    d.friction = b.friction;
    d.restitution = b.restitution;
    d.density = b.density;
    w->addBody(d);
  }
  const auto link = makeBox({kLink, 0.04, 0.04});
  for (int c = 0; c < spec.chains; ++c) {
    int previous = -1;
    for (int k = 0; k < spec.links; ++k) {
      BodyDef d;
      d.shape = link;
      d.origin = chainPivot(c) + glm::dvec3((k + 0.5) * kLink, 0, 0);
      d.mass = 1;
      const int body = w->addBody(d);
      JointDef j;
      j.a = previous;
      j.b = body;
      j.anchor = chainPivot(c) + glm::dvec3(k * kLink, 0, 0);
      w->addJoint(j);
      previous = body;
    }
  }
  return w;
}

btVector3 bt(const glm::dvec3& v) { return btVector3(btScalar(v.x), btScalar(v.y), btScalar(v.z)); }

struct BulletWorld {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &config};
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> motions;
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  std::vector<std::unique_ptr<btTypedConstraint>> constraints;
  TriangleMesh torus;
  std::unique_ptr<btTriangleIndexVertexArray> torusArray;
  std::vector<int> torusIndices;
  std::vector<btScalar> torusVertices;
  explicit BulletWorld(const SceneSpec& spec) {
    // Both engines put resting bodies to sleep after the same 0.5 s still
    // (Bullet's default is 2 s, crumple's WorldSettings::sleepTime 0.5 s).
    gDeactivationTime = btScalar(0.5);
    btGImpactCollisionAlgorithm::registerAlgorithm(&dispatcher);
    world.setGravity(btVector3(0, -9.81f, 0));
    add(own(new btBoxShape(btVector3(30, 0.5f, 30))), 0, btVector3(0, -0.5f, 0), btQuaternion::getIdentity(), 0.6, 0.1);
    double torusVolume = 0;
    for (const auto& b : spec.bodies) {
      if (b.kind != Kind::Torus || torusArray) continue;
      torus = benchTorus();
      for (const auto& p : torus.positions) torusVertices.insert(torusVertices.end(), {p.x, p.y, p.z});
      for (const auto& t : torus.triangles) torusIndices.insert(torusIndices.end(), {int(t.x), int(t.y), int(t.z)});
      torusArray = std::make_unique<btTriangleIndexVertexArray>(int(torus.triangles.size()), torusIndices.data(),
                                                                3 * sizeof(int), int(torus.positions.size()),
                                                                torusVertices.data(), 3 * sizeof(btScalar));
      torusVolume = polyhedralMassProperties(torus).volume;
    }
    // One shape per distinct kind and size, shared by its bodies (as crumple's side does).
    std::map<std::tuple<int, double, double, double>, btCollisionShape*> shared;
    for (const auto& b : spec.bodies) {
      btCollisionShape*& shape = shared[{static_cast<int>(b.kind), b.size.x, b.size.y, b.size.z}];
      const bool known = shape != nullptr;
      double volume = 0;
      switch (b.kind) {
        case Kind::Box:
          if (!known) shape = own(new btBoxShape(bt(b.size * 0.5)));
          volume = b.size.x * b.size.y * b.size.z;
          break;
        case Kind::Sphere:
          if (!known) shape = own(new btSphereShape(btScalar(b.size.x)));
          volume = makeSphere(b.size.x)->unitMass.volume;
          break;
        case Kind::Capsule:  // both along y, height = the straight part
          if (!known) shape = own(new btCapsuleShape(btScalar(b.size.x), btScalar(b.size.y)));
          volume = makeCapsule(b.size.x, b.size.y)->unitMass.volume;
          break;
        case Kind::Torus: {
          if (!known) {
            auto* mesh = new btGImpactMeshShape(torusArray.get());
            mesh->updateBound();
            shape = own(mesh);
          }
          volume = torusVolume;
          break;
        }
      }
      const glm::dquat& q = b.orientation;
      add(shape, btScalar(volume * b.density), bt(b.position),
          btQuaternion(btScalar(q.x), btScalar(q.y), btScalar(q.z), btScalar(q.w)), b.friction, b.restitution);
    }
    btCollisionShape* linkShape = nullptr;
    for (int c = 0; c < spec.chains; ++c) {
      btRigidBody* previous = nullptr;
      for (int k = 0; k < spec.links; ++k) {
        const glm::dvec3 p = chainPivot(c) + glm::dvec3((k + 0.5) * kLink, 0, 0);
        if (!linkShape) linkShape = own(new btBoxShape(btVector3(btScalar(kLink / 2), 0.02f, 0.02f)));
        add(linkShape, 1, bt(p), btQuaternion::getIdentity(), 0.5,
            0.5);
        btRigidBody* body = bodies.back().get();
        const btVector3 own(btScalar(-kLink / 2), 0, 0);
        if (previous)
          constraints.push_back(
              std::make_unique<btPoint2PointConstraint>(*previous, *body, btVector3(btScalar(kLink / 2), 0, 0), own));
        else
          constraints.push_back(std::make_unique<btPoint2PointConstraint>(*body, own));
        world.addConstraint(constraints.back().get(), true);  // joined links do not collide (as in crumple)
        previous = body;
      }
    }
  }
  btCollisionShape* own(btCollisionShape* shape) {
    shapes.emplace_back(shape);
    return shape;
  }
  void add(btCollisionShape* shape, btScalar mass, const btVector3& pos, const btQuaternion& q, double friction,
           double restitution) {
    btVector3 inertia(0, 0, 0);
    if (mass > 0) shape->calculateLocalInertia(mass, inertia);
    motions.push_back(std::make_unique<btDefaultMotionState>(btTransform(q, pos)));
    btRigidBody::btRigidBodyConstructionInfo info(mass, motions.back().get(), shape, inertia);
    info.m_friction = btScalar(friction);
    info.m_restitution = btScalar(restitution);
    bodies.push_back(std::make_unique<btRigidBody>(info));
    world.addRigidBody(bodies.back().get());
  }
  ~BulletWorld() {
    for (auto& c : constraints) world.removeConstraint(c.get());
    for (auto& b : bodies) world.removeRigidBody(b.get());
  }
};
}  // namespace


int gSteps = 240;

// crumple's stage times (World::lastStats().ms) per case: mean ms per step.
std::map<std::string, StepProfile> gStageMs;
// The state hash each crumple run ended with, per benchmark name (thread rows: the same bits for every count).
std::map<std::string, uint64_t> gEndHash;

// Besides the time, each engine's end state: how many bodies are still awake
// and the highest centre (a pyramid or column that fell would show here), so
// that the two figures are seen to time the same work.
void crumplePhysics(benchmark::State& state, SceneSpec spec, std::string name, int threads) {
  auto w = crumpleWorld(spec);
  w->settings().threads = threads;
  StepProfile sum;
  int largestIsland = 0, islandsThen = 0;  // over the run: the largest island, and the island count of that step
  double substeps = 0, pairs = 0;         // summed over the run: substeps, and pairs per substep
  for (auto _ : state) {
    w->step(kStep);
    substeps += w->lastStats().substeps;
    pairs += w->lastStats().pairs;
    if (w->lastStats().largestIsland > largestIsland) {
      largestIsland = w->lastStats().largestIsland;
      islandsThen = w->lastStats().islands;
    }
    const StepProfile& p = w->lastStats().ms;
    sum.broadPhase += p.broadPhase;
    sum.candidates += p.candidates;
    sum.collide += p.collide;
    sum.contact += p.contact;
    sum.shockPropagation += p.shockPropagation;
    sum.positions += p.positions;
    sum.sleep += p.sleep;
    sum.joints += p.joints;
    sum.total += p.total;
  }
  const double n = std::max<double>(1, static_cast<double>(state.iterations()));
  StepProfile mean;
  mean.broadPhase = sum.broadPhase / n;
  mean.candidates = sum.candidates / n;
  mean.collide = sum.collide / n;
  mean.contact = sum.contact / n;
  mean.shockPropagation = sum.shockPropagation / n;
  mean.positions = sum.positions / n;
  mean.sleep = sum.sleep / n;
  mean.joints = sum.joints / n;
  mean.total = sum.total / n;
  // With repetitions: the stages of the fastest run (the one the ratios quote).
  const auto kept = gStageMs.find(name);
  if (kept == gStageMs.end() || mean.total < kept->second.total) gStageMs[name] = mean;
  gEndHash[name] = w->stateHash();
  double top = 0;
  for (const RigidBody& b : w->bodies())
    if (!b.isStatic) top = std::max(top, b.x.y);
  state.counters["bodies"] = static_cast<double>(w->size());
  state.counters["awake"] = w->lastStats().awake;
  state.counters["islands"] = islandsThen;
  state.counters["substeps"] = substeps / n;
  state.counters["pairs"] = pairs / std::max(1.0, substeps);
  state.counters["largest_island"] = largestIsland;
  state.counters["top_m"] = top;
}
namespace {
// Bullet's dynamic bodies still awake.
int bulletAwake(const BulletWorld& w) {
  int awake = 0;
  for (const auto& b : w.bodies) awake += b->getInvMass() != 0 && b->isActive();
  return awake;
}
// CPU time of the calling thread, in ms.
double threadMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}
}  // namespace

void bulletPhysics(benchmark::State& state, SceneSpec spec) {
  BulletWorld w(spec);
  for (auto _ : state) w.world.stepSimulation(btScalar(kStep), 0);
  double top = 0;
  for (const auto& b : w.bodies)
    if (b->getInvMass() != 0) top = std::max(top, static_cast<double>(b->getWorldTransform().getOrigin().y()));
  state.counters["bodies"] = static_cast<double>(w.bodies.size());
  state.counters["awake"] = bulletAwake(w);
  state.counters["top_m"] = top;
}

void physicsTimeline(const std::string& name, const SceneSpec& spec, int threads, int window) {
  auto crumple = crumpleWorld(spec);
  crumple->settings().threads = threads;
  BulletWorld bullet(spec);
  std::unique_ptr<PeerWorld> jolt = makeJoltWorld(spec);
  joltLeaveClean();
  std::printf(
      "timeline %s: ms per step (CPU time of the stepping thread) over each %d steps, and the bodies awake "
      "at its end; the engines take each window in turn\n",
      name.c_str(), window);
  if (jolt)
    std::printf("  %-9s %-16s %-16s %-16s %s\n", "steps", "crumple", "bullet", "jolt", "crumple/jolt");
  else
    std::printf("  %-9s %-16s %s\n", "steps", "crumple", "bullet");
  double total[3] = {0, 0, 0};
  for (int first = 0; first < gSteps; first += window) {
    const int n = std::min(window, gSteps - first);
    double ms[3] = {0, 0, 0};
    double start = threadMs();
    for (int k = 0; k < n; ++k) crumple->step(kStep);
    ms[0] = threadMs() - start;
    start = threadMs();
    for (int k = 0; k < n; ++k) bullet.world.stepSimulation(btScalar(kStep), 0);
    ms[1] = threadMs() - start;
    if (jolt) {
      start = threadMs();
      for (int k = 0; k < n; ++k) jolt->step(kStep);
      ms[2] = threadMs() - start;
      joltLeaveClean();
    }
    char range[32], cell[3][32];
    std::snprintf(range, sizeof range, "%d-%d", first + 1, first + n);
    std::snprintf(cell[0], sizeof cell[0], "%7.3f (%d)", ms[0] / n, crumple->lastStats().awake);
    std::snprintf(cell[1], sizeof cell[1], "%7.3f (%d)", ms[1] / n, bulletAwake(bullet));
    std::snprintf(cell[2], sizeof cell[2], "%7.3f (%d)", ms[2] / n, jolt ? jolt->awake() : 0);
    if (jolt)
      std::printf("  %-9s %-16s %-16s %-16s %6.2fx\n", range, cell[0], cell[1], cell[2], ms[0] / ms[2]);
    else
      std::printf("  %-9s %-16s %s\n", range, cell[0], cell[1]);
    for (int e = 0; e < 3; ++e) total[e] += ms[e];
  }
  if (jolt)
    std::printf("  %-9s %7.3f          %7.3f          %7.3f          %6.2fx\n", "all", total[0] / gSteps,
                total[1] / gSteps, total[2] / gSteps, total[0] / total[2]);
  else
    std::printf("  %-9s %7.3f          %7.3f\n", "all", total[0] / gSteps, total[1] / gSteps);
}

void joltPhysics(benchmark::State& state, SceneSpec spec) {
  std::unique_ptr<PeerWorld> w = makeJoltWorld(spec);
  joltLeaveClean();
  for (auto _ : state) w->step(kStep);  // (each step leaves clean)
  state.counters["bodies"] = w->bodies();
  state.counters["awake"] = w->awake();
  state.counters["top_m"] = w->top();
  w.reset();
  joltLeaveClean();
}

}  // namespace crumple::bench
