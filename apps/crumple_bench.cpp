// crumple-bench: speed, measured side by side in one run.
//   physics: crumple vs Bullet 3 (and Jolt, when built with CRUMPLE_JOLT_DIR: bench_jolt.cpp)
//            on a 20-level box pyramid (210 boxes), piles
//            of 1000, 4000 and 10000 boxes (10 high), a heap of 500 mixed bodies
//            (boxes, spheres, capsules, 12 tori), 200 nonconvex mesh bodies (tori)
//            and 10 chains of 20 ball-jointed links; ms per step (on --threads threads);
//            the 4000 and 10000 piles again on 1, 2, 4, 8 and 16 threads (--thread-counts), with
//            the speedup over one thread and whether every count ended in the same bits
//   deform:  the GPU path vs the paper's read-back path, ms per deformation
//            (both sides of one event) at address maps of 256..2048
//   render:  ms per 1280x720 frame of the sandbox scene: everything on (parallax occlusion, sky light, FXAA),
//            then each of those off in turn
// Prints Google Benchmark's table, then the ratios (with crumple's ms per step in
// each stage: World::lastStats().ms).
#include <benchmark/benchmark.h>
#include <btBulletDynamicsCommon.h>
#include <BulletCollision/Gimpact/btGImpactCollisionAlgorithm.h>
#include <BulletCollision/Gimpact/btGImpactShape.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>
#include <fstream>
#include <cstdint>
#include <cstdio>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <map>
#include <memory>
#include <string>
#include <tuple>

#include "bench_scenes.h"
#include <crumple/core/version.h>
#include <crumple/deform/deformer.h>
#include <crumple/engine/primitives.h>
#include <crumple/engine/scene_view.h>
#include <crumple/engine/builtin_scenes.h>
#include <crumple/engine/simulation.h>
#include <crumple/physics/world.h>
#include <crumple/gl/context.h>
#include <crumple/gl/objects.h>
#include <crumple/gl/gpu_timer.h>
#include <crumple/gl/program.h>
#include <crumple/render/renderer.h>

using namespace crumple;
using namespace crumple::bench;

#ifndef CRUMPLE_BENCH_JOLT
// Built without CRUMPLE_JOLT_DIR: no Jolt rows.
std::unique_ptr<PeerWorld> crumple::bench::makeJoltWorld(const SceneSpec&) { return nullptr; }
bool crumple::bench::joltBuilt() { return false; }
std::string crumple::bench::joltConfiguration() { return ""; }
std::vector<std::string> crumple::bench::joltWarnings() { return {}; }
void crumple::bench::joltLeaveClean() {}
#endif

namespace {

constexpr double kStep = 1.0 / 240;

SceneSpec chainScene(int chains, int links) {
  SceneSpec s;
  s.chains = chains;
  s.links = links;
  return s;
}

BodySpec box(const glm::dvec3& size, const glm::dvec3& position) {
  BodySpec b;
  b.size = size;
  b.position = position;
  return b;
}
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
void bulletPhysics(benchmark::State& state, SceneSpec spec) {
  BulletWorld w(spec);
  for (auto _ : state) w.world.stepSimulation(btScalar(kStep), 0);
  double top = 0;
  int awake = 0;
  for (const auto& b : w.bodies) {
    if (b->getInvMass() == 0) continue;
    top = std::max(top, static_cast<double>(b->getWorldTransform().getOrigin().y()));
    awake += b->isActive();
  }
  state.counters["bodies"] = static_cast<double>(w.bodies.size());
  state.counters["awake"] = awake;
  state.counters["top_m"] = top;
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

// ---- deformation ----------------------------------------------------------
struct DeformStage {
  std::shared_ptr<deform::GpuMesh> plate = std::make_shared<deform::GpuMesh>(boxMesh({2, 0.2, 2}, 1024));
  std::shared_ptr<deform::GpuMesh> ball = std::make_shared<deform::GpuMesh>(sphereMesh(0.25, 512));
};
DeformStage* gDeformStage = nullptr;

// One deformer with its two surfaces and the event they meet in: a ball
// (map 512) pressed into a plate (map 1024), both sides dented.
struct DeformCase {
  deform::Deformer deformer;
  deform::Surface plate, ball;
  deform::DeformRequest request;
  explicit DeformCase(const deform::DeformOptions& o)
      : deformer(o),
        plate(gDeformStage->plate, 1024, 0.1f, 0.02f,
              deformer.createMaps(1024, nullptr, 0.1f, float(gDeformStage->plate->metresPerUv / 1024))),
        ball(gDeformStage->ball, 512, 0.1f, 0.02f,
             deformer.createMaps(512, nullptr, 0.1f, float(gDeformStage->ball->metresPerUv / 512))) {
    request.a = {&plate, gDeformStage->plate.get(), glm::dmat4(1)};
    request.b = {&ball, gDeformStage->ball.get(), glm::translate(glm::dmat4(1), glm::dvec3(0, 0.35, 0))};
    request.point = {0, 0.1, 0};
    request.normal = {0, 1, 0};
    request.deformA = 0.002;
    request.deformB = 0.001;
    deformer.deform(request);  // warm-up: shaders, lazy allocations
    glFinish();
  }
};

// Wall time per event (glFinish after each), and the GPU's time (gpu_ms: timer queries around the event).
// A GPU idles at a low clock (an H200 at 345 MHz) and takes a while under load to ramp up: each GPU row first runs
// its work, untimed, for gWarmUp seconds (0 with --quick).
double gWarmUp = 0.3;
template <typename F>
void warmUp(F&& work) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(gWarmUp);
  do {
    work();
    glFinish();
  } while (std::chrono::steady_clock::now() < end);
}

void deformBench(benchmark::State& state, deform::Path path, deform::AddressRaster raster) {
  deform::DeformOptions o{static_cast<int>(state.range(0)), path};
  o.addressRaster = raster;
  DeformCase c(o);
  warmUp([&] { c.deformer.deform(c.request); });
  gl::GpuTimer timer;
  for (auto _ : state) {
    timer.begin();
    c.deformer.deform(c.request);
    timer.end();
    glFinish();
  }
  const double gpu = timer.finish();
  state.counters["gpu_ms"] = timer.measured() ? gpu / static_cast<double>(timer.measured()) : 0.0;
}

// A step with many collisions: `events` deformations among 20 pairs of bodies (a plate, map 1024, and a ball, 512,
// each pair its own surfaces), each pair hit events / 20 times at different places, in turn; issued as one batch
// (Deformer::deform of them all: waves of events on different surfaces with the compute rasteriser, one by one
// with the fragment stage's), one glFinish at the end; gpu_ms is the whole batch's GPU time.
struct BatchCase {
  static constexpr int kPairs = 20;
  deform::Deformer deformer;
  std::vector<std::unique_ptr<deform::Surface>> plates, balls;
  std::vector<deform::DeformRequest> requests;
  BatchCase(const deform::DeformOptions& o, int events) : deformer(o) {
    for (int p = 0; p < kPairs; ++p) {
      plates.push_back(std::make_unique<deform::Surface>(
          gDeformStage->plate, 1024, 0.1f, 0.02f,
          deformer.createMaps(1024, nullptr, 0.1f, float(gDeformStage->plate->metresPerUv / 1024))));
      balls.push_back(std::make_unique<deform::Surface>(
          gDeformStage->ball, 512, 0.1f, 0.02f,
          deformer.createMaps(512, nullptr, 0.1f, float(gDeformStage->ball->metresPerUv / 512))));
    }
    for (int k = 0; k < events; ++k) {
      const int p = k % kPairs, hit = k / kPairs, hits = std::max(1, events / kPairs);
      const double x = -0.4 + 0.8 * hit / std::max(1, hits - 1);
      deform::DeformRequest rq;
      rq.a = {plates[static_cast<size_t>(p)].get(), gDeformStage->plate.get(), glm::dmat4(1)};
      rq.b = {balls[static_cast<size_t>(p)].get(), gDeformStage->ball.get(),
              glm::translate(glm::dmat4(1), glm::dvec3(x, 0.35, 0))};
      rq.point = {x, 0.1, 0};
      rq.normal = {0, 1, 0};
      rq.deformA = 0.002;
      rq.deformB = 0.001;
      requests.push_back(rq);
    }
  }
};

void deformBatchBench(benchmark::State& state, int events, deform::AddressRaster raster) {
  deform::DeformOptions o{static_cast<int>(state.range(0)), deform::Path::Gather};
  o.addressRaster = raster;
  BatchCase c(o, events);
  deform::Deformer& deformer = c.deformer;
  const std::vector<deform::DeformRequest>& requests = c.requests;
  deformer.deform(requests);  // warm-up: shaders, lazy allocations
  warmUp([&] { deformer.deform(requests); });
  const long waves = deformer.wavesRun();
  gl::GpuTimer timer;
  for (auto _ : state) {
    timer.begin();
    deformer.deform(requests);
    timer.end();
    glFinish();
  }
  const double gpu = timer.finish();
  state.counters["gpu_ms"] = timer.measured() ? gpu / static_cast<double>(timer.measured()) : 0.0;
  state.counters["waves"] = static_cast<double>(deformer.wavesRun() - waves) / static_cast<double>(state.iterations());
}

// Runs `deform` `iterations` times after the warm-up and prints the mean of each phase of `d`'s profile.
template <typename F>
void printPhases(const std::string& label, deform::Deformer& d, int iterations, F&& deform) {
  warmUp(deform);
  std::vector<deform::PhaseTime> sum;
  for (int i = 0; i < iterations; ++i) {
    deform();
    for (const auto& p : d.profile()) {
      auto it = std::find_if(sum.begin(), sum.end(), [&](const deform::PhaseTime& q) { return std::string(q.name) == p.name; });
      if (it == sum.end())
        sum.push_back(p);
      else {
        it->ms += p.ms;
        it->gpuMs += p.gpuMs;
      }
    }
  }
  double total = 0, gpuTotal = 0;
  for (const auto& p : sum) total += p.ms / iterations, gpuTotal += p.gpuMs / iterations;
  std::printf("%s  wall %8.3f (gpu %7.3f) :", label.c_str(), total, gpuTotal);
  for (const auto& p : sum) std::printf("  %s %.3f (%.3f)", p.name, p.ms / iterations, p.gpuMs / iterations);
  std::printf("\n");
}

// Per-phase wall times (glFinish at each boundary) of every path at each size, and of one wave.
void deformProfile(int iterations) {
  std::printf("\n== deformation phases: wall ms (GPU ms), mean of %d, glFinish between phases ==\n", iterations);
  for (int size : {256, 512, 1024, 2048})
    for (int variant = 0; variant < 4; ++variant) {
      // The gather with its address pass in compute, the same in the fragment stage, the scatter, the read-back.
      const deform::Path path = variant < 2 ? deform::Path::Gather : variant == 2 ? deform::Path::Scatter : deform::Path::Readback;
      const std::string label = variant < 2 ? (variant == 0 ? "gather_compute" : "gather_fragment") : deform::pathName(path);
      deform::DeformOptions o{size, path};
      o.addressRaster = variant == 0 ? deform::AddressRaster::Compute : deform::AddressRaster::Fragment;
      o.profile = true;
      DeformCase c(o);
      char name[64];
      std::snprintf(name, sizeof name, "%-15s %4d", label.c_str(), size);
      printPhases(name, c.deformer, iterations, [&] { c.deformer.deform(c.request); });
    }
  // One wave: as many events on different surfaces as DeformOptions::waveMemory holds at 1024 (the phases of the
  // wave, all its events' sides in each), with the compute rasteriser.
  deform::DeformOptions o{1024, deform::Path::Gather};
  o.addressRaster = deform::AddressRaster::Compute;
  o.profile = true;
  const int events = static_cast<int>(std::min<size_t>(BatchCase::kPairs, deform::Deformer(o).waveLimit()));
  BatchCase c(o, events);
  c.deformer.deform(c.requests);
  printPhases("wave of " + std::to_string(events) + " events (compute, 1024)", c.deformer, iterations,
              [&] { c.deformer.deform(c.requests); });
  // The dented maps' way back to the physics (dents felt): each read back through a pixel buffer and a fence a
  // step after its dent, then taken in (the copy, the changed tiles, the lookups' triangles).
  Simulation sim(builtinHighway(), true);
  for (int s = 0; s < 900; ++s) sim.step();
  const Timings& t = sim.timings();
  const double each = t.dentReads ? 1.0 / static_cast<double>(t.dentReads) : 0.0;
  std::printf("transfer  highway, 900 steps: %ld maps read back, %.3f ms each taking in (%.3f ms of it blocked on "
              "the fence), %.3f ms a step of physics\n",
              t.dentReads, t.dentReadMs * each, t.dentWaitMs * each, t.physicsMs / static_cast<double>(sim.steps()));
}

// ---- rendering --------------------------------------------------------------
// The sandbox's scene (the built-in highway) after its car has hit the rail,
// seen from its chase camera. `off`: the feature turned off ("" none, "parallax", "ibl", "aa"), or "+displace":
// displacement (tessellation) turned on, "+simplified": simplified meshes (RendererSettings::simplified), "+msaa":
// MSAA (4 samples) instead of FXAA, "+forward" / "+compute": the items shaded in the fragment stage / from a
// visibility buffer in compute (RendererSettings::shading; the other rows take Auto),
// "sandbox": the sandbox's view at its smallest automatic scale (960x540 x 0.35, simplified meshes, FXAA).
void renderBench(benchmark::State& state, const std::string& off) {
  Simulation sim(builtinHighway(), true);
  for (int s = 0; s < 900; ++s) sim.step();  // 3.75 s: past the first hit, dents in car and rail
  const bool sandbox = off == "sandbox";
  render::Renderer r(sandbox ? 336 : 1280, sandbox ? 189 : 720);
  r.settings().simplified = sandbox || off == "+simplified";
  const bool pom = off != "parallax";
  r.settings().parallax = pom ? render::ParallaxMode::Occlusion : render::ParallaxMode::None;
  r.settings().selfShadow = pom;
  r.settings().ibl = off != "ibl";
  r.settings().antialias = off == "aa"      ? render::Antialias::None
                           : off == "+msaa" ? render::Antialias::Msaa
                                            : render::Antialias::Fxaa;
  r.settings().displace = off == "+displace";
  if (off == "+forward") r.settings().shading = render::Shading::Forward;
  if (off == "+compute") r.settings().shading = render::Shading::Compute;
  const std::vector<render::RenderItem> items = renderItems(sim);
  const render::View view = cameraView(sim.scene().cameras.front(), &sim);
  r.draw(items, view);  // untimed: the shaders of this view's features are compiled on first use
  glFinish();
  warmUp([&] { r.draw(items, view); });
  gl::GpuTimer timer;
  for (auto _ : state) {
    timer.begin();
    r.draw(items, view);
    timer.end();
    glFinish();
  }
  const double gpu = timer.finish();
  state.counters["gpu_ms"] = timer.measured() ? gpu / static_cast<double>(timer.measured()) : 0.0;
}

// The floor under shading from a visibility buffer: the same view's items (culled and ordered as the renderer
// does) drawn with positions alone into depth and an item / triangle id target (RG32UI), no shading. What a
// renderer that shades in compute (all of a GPU's multiprocessors rather than its graphics ones) would still pay
// for the items' geometry.
void visibilityBench(benchmark::State& state) {
  Simulation sim(builtinHighway(), true);
  for (int s = 0; s < 900; ++s) sim.step();
  const int w = 1280, h = 720;
  gl::Texture2D ids(w, h, GL_RG32UI), depth(w, h, GL_DEPTH_COMPONENT32F);
  gl::Framebuffer fbo;
  fbo.attachColor(ids, 0);
  fbo.attachDepth(depth);
  fbo.checkComplete();
  const gl::Program program({{GL_VERTEX_SHADER, "visibility.vert",
                                  "#version 450 core\nlayout(location = 0) in vec3 aPosition;\nuniform mat4 uMvp;\n"
                                  "void main() { gl_Position = uMvp * vec4(aPosition, 1.0); }\n"},
                                 {GL_FRAGMENT_SHADER, "visibility.frag",
                                  "#version 450 core\nuniform uint uItem;\nout uvec2 id;\n"
                                  "void main() { id = uvec2(uItem, uint(gl_PrimitiveID)); }\n"}});
  const gl::Uniform<glm::mat4> uMvp(program, "uMvp");
  const gl::Uniform<GLuint> uItem(program, "uItem");
  const std::vector<render::RenderItem> items = renderItems(sim);
  const render::View view = cameraView(sim.scene().cameras.front(), &sim);
  const glm::mat4 vp = glm::perspective(glm::radians(view.fovDegrees), float(w) / float(h), view.zNear, view.zFar) *
                       glm::lookAt(view.eye, view.target, view.up);
  std::vector<std::pair<float, size_t>> order;
  for (size_t i = 0; i < items.size(); ++i) {
    const render::RenderItem& it = items[i];
    const glm::mat4 mvp = vp * it.model;
    bool outside = false;
    for (int axis = 0; axis < 3 && !outside; ++axis)
      for (float side : {-1.0f, 1.0f}) {
        bool all = true;
        for (int c = 0; c < 8 && all; ++c) {
          const glm::vec4 q = mvp * glm::vec4(c & 1 ? it.boundsMax.x : it.boundsMin.x, c & 2 ? it.boundsMax.y : it.boundsMin.y,
                                              c & 4 ? it.boundsMax.z : it.boundsMin.z, 1.0f);
          all = side * q[axis] > q.w;
        }
        outside = outside || all;
      }
    if (outside) continue;
    const glm::vec3 c = glm::vec3(it.model * glm::vec4(0.5f * (it.boundsMin + it.boundsMax), 1.0f));
    order.emplace_back(glm::dot(c - view.eye, c - view.eye), i);
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  auto frame = [&] {
    fbo.bind();
    glViewport(0, 0, w, h);
    const GLuint none[4] = {0xffffffffu, 0, 0, 0};
    const float far = 1.0f;
    glClearNamedFramebufferuiv(fbo.id(), GL_COLOR, 0, none);
    glClearNamedFramebufferfv(fbo.id(), GL_DEPTH, 0, &far);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    program.use();
    for (const auto& [d, i] : order) {
      const glm::mat4 mvp = vp * items[i].model;
      uMvp.set(mvp);
      uItem.set(static_cast<GLuint>(i));
      glBindVertexArray(items[i].vao);
      glDrawElements(GL_TRIANGLES, items[i].indexCount, GL_UNSIGNED_INT, nullptr);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
  };
  frame();
  glFinish();
  warmUp(frame);
  gl::GpuTimer timer;
  for (auto _ : state) {
    timer.begin();
    frame();
    timer.end();
    glFinish();
  }
  const double gpu = timer.finish();
  state.counters["gpu_ms"] = timer.measured() ? gpu / static_cast<double>(timer.measured()) : 0.0;
  state.counters["items"] = static_cast<double>(order.size());
}

// GPU time of each part of the highway frame at 1280x720 (POM, IBL, FXAA: the render/1280x720/pom row), from
// timestamps at the renderer's pass markers, mean of `iterations` frames after the warm-up.
void renderProfile(int iterations) {
  Simulation sim(builtinHighway(), true);
  for (int s = 0; s < 900; ++s) sim.step();
  render::Renderer r(1280, 720);
  const std::vector<render::RenderItem> items = renderItems(sim);
  const render::View view = cameraView(sim.scene().cameras.front(), &sim);
  std::vector<std::pair<std::string, GLuint>> marks;
  std::vector<GLuint> pool;
  // The CPU's time at each mark as well: a part whose GPU time is about its CPU time may be the GPU waiting for
  // the commands (their issue), not running them.
  using Clock = std::chrono::steady_clock;
  std::vector<Clock::time_point> issued;
  Clock::time_point began;
  r.setPassMarker([&](const char* part) {
    if (marks.size() >= pool.size()) {
      pool.push_back(0);
      glGenQueries(1, &pool.back());
    }
    glQueryCounter(pool[marks.size()], GL_TIMESTAMP);
    marks.emplace_back(part, pool[marks.size()]);
    issued.push_back(Clock::now());
  });
  GLuint start = 0;
  glGenQueries(1, &start);
  auto frame = [&] {
    marks.clear();
    issued.clear();
    glQueryCounter(start, GL_TIMESTAMP);
    began = Clock::now();
    r.draw(items, view);
    glFinish();
  };
  frame();
  warmUp(frame);
  std::vector<std::pair<std::string, double>> sum;
  std::vector<double> cpu;  // ms of issuing each part
  for (int i = 0; i < iterations; ++i) {
    frame();
    GLuint64 last = 0;
    glGetQueryObjectui64v(start, GL_QUERY_RESULT, &last);
    Clock::time_point before = began;
    for (size_t k = 0; k < marks.size(); ++k) {
      GLuint64 t = 0;
      glGetQueryObjectui64v(marks[k].second, GL_QUERY_RESULT, &t);
      if (sum.size() <= k) sum.emplace_back(marks[k].first, 0.0);
      if (cpu.size() <= k) cpu.push_back(0.0);
      sum[k].second += static_cast<double>(t - last) * 1e-6;
      cpu[k] += std::chrono::duration<double, std::milli>(issued[k] - before).count();
      last = t;
      before = issued[k];
    }
  }
  double total = 0;
  for (const auto& [part, ms] : sum) total += ms / iterations;
  std::printf("\n== render/1280x720/pom parts: GPU ms (CPU ms issuing it), mean of %d frames ==\nframe %.3f :",
              iterations, total);
  for (size_t k = 0; k < sum.size(); ++k)
    std::printf("  %s %.3f (%.3f)", sum[k].first.c_str(), sum[k].second / iterations, cpu[k] / iterations);
  std::printf("\n  (%d items drawn, %d culled, %d shadow casters)\n", r.stats().drawn, r.stats().culled,
              r.stats().shadowCasters);
  glDeleteQueries(1, &start);
  glDeleteQueries(static_cast<GLsizei>(pool.size()), pool.data());
}

class Collector : public benchmark::ConsoleReporter {
 public:
  std::map<std::string, double> ms;  // per iteration
  std::map<std::string, std::map<std::string, double>> counters;
  // Per benchmark, the fastest of its repetitions (--repetitions: a run that a busy machine slowed is not the
  // engine's time); the aggregates Google Benchmark adds are left to the console.
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs) {
      if (r.run_type != Run::RT_Iteration) continue;
      std::string name = r.benchmark_name();
      name = name.substr(0, name.find("/iterations:"));
      const double t = r.GetAdjustedRealTime() * 1e3 / benchmark::GetTimeUnitMultiplier(r.time_unit);
      const auto kept = ms.find(name);
      if (kept != ms.end() && kept->second <= t) continue;
      ms[name] = t;
      for (const auto& [key, counter] : r.counters) counters[name][key] = counter.value;
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "crumple-bench: crumple vs Bullet (and Jolt, if built with CRUMPLE_JOLT_DIR) (physics), gather vs scatter vs read-back (deformation), POM on/off (render); "
      "prints ms per step/deformation/frame and the ratios."};
  bool quick = false, noGl = false, deformPhases = false, renderParts = false, strictPeers = false;
  std::string filter;
  int threads = 1, repetitions = 1;
  std::vector<int> threadCounts = {1, 2, 4, 8, 16};
  app.add_flag("--quick", quick, "Fewer steps and smaller scenes (a smoke run)");
  app.add_flag("--render-profile", renderParts, "Also print the GPU time of each part of the highway frame");
  app.add_flag("--no-gl", noGl, "Physics only");
  app.add_flag("--deform-profile", deformPhases, "Also print the wall time of each phase of a deformation, every path");
  app.add_option("--filter", filter, "Only benchmarks whose name matches this regular expression");
  app.add_flag("--strict-peers", strictPeers,
               "Refuse to run (exit 1) when a peer's build would slow its rows (a Jolt built with its profiler, debug "
               "renderer, asserts or without NDEBUG): figures meant for publishing (tools/bench-vs-jolt.sh)");
  app.add_option("--repetitions", repetitions,
                 "Runs of each benchmark, interleaved at random with the others'; the ratios take each one's fastest "
                 "(a machine whose speed drifts then slows no engine more than another)")
      ->check(CLI::Range(1, 100));
  app.add_option("--threads", threads, "Threads of crumple's physics rows (WorldSettings::threads; 0: the hardware's)")
      ->check(CLI::Range(0, 256));
  app.add_option("--thread-counts", threadCounts,
                 "Thread counts of the scaling rows (the 4000 and 10000 piles; --quick: the small pile)")
      ->check(CLI::Range(1, 256))
      ->delimiter(',');
  app.set_version_flag("--version", std::string("crumple-bench ") + versionString());
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;  // bad command-line input is bad input: exit 2
  }
  if (strictPeers && joltBuilt() && !joltWarnings().empty()) {
    std::printf("jolt: %s\n", joltConfiguration().c_str());
    for (const std::string& w : joltWarnings()) std::printf("WARNING: %s\n", w.c_str());
    std::fprintf(stderr, "crumple-bench: error: --strict-peers: Jolt's build would slow its rows (WARNING above); "
                         "build it as tools/build-jolt.sh does\n");
    return 1;
  }
  gSteps = quick ? 24 : 240;
  if (quick) gWarmUp = 0;

  struct PhysicsCase {
    std::string name;
    SceneSpec spec;
  };
  const int levels = quick ? 6 : 20, tori = quick ? 20 : 200, heap = quick ? 60 : 500;
  auto pileCase = [](int nx, int nz) {
    return PhysicsCase{"pile_" + std::to_string(nx * nz * 10) + "boxes", pile(nx, nz, 10)};
  };
  std::vector<PhysicsCase> cases = {
      {"pyramid" + std::to_string(levels) + "_" + std::to_string(levels * (levels + 1) / 2) + "boxes", pyramid(levels)},
      quick ? pileCase(4, 3) : pileCase(10, 10)};
  if (!quick) {
    cases.push_back(pileCase(20, 20));
    cases.push_back(pileCase(40, 25));
  }
  cases.push_back({"heap_" + std::to_string(heap) + "mixed", heapScene(heap)});
  cases.push_back({"tori_" + std::to_string(tori) + "meshes", toriScene(tori)});
  cases.push_back({"chains_" + std::to_string(quick ? 2 : 10) + "x20links", chainScene(quick ? 2 : 10, 20)});
  for (const auto& c : cases) {
    benchmark::RegisterBenchmark(("physics/crumple/" + c.name).c_str(), crumplePhysics, c.spec, c.name, threads)
        ->Iterations(gSteps)
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("physics/bullet/" + c.name).c_str(), bulletPhysics, c.spec)
        ->Iterations(gSteps)
        ->Unit(benchmark::kMillisecond);
    if (joltBuilt())
      benchmark::RegisterBenchmark(("physics/jolt/" + c.name).c_str(), joltPhysics, c.spec)
          ->Iterations(gSteps)
          ->Unit(benchmark::kMillisecond);
  }
  // Scaling: the big piles on each thread count (crumple only).
  std::vector<PhysicsCase> scaling;
  if (quick) {
    scaling.push_back(pileCase(4, 3));
  } else {
    scaling.push_back(pileCase(20, 20));
    scaling.push_back(pileCase(40, 25));
  }
  auto threadsName = [](const PhysicsCase& c, int t) { return c.name + "/threads:" + std::to_string(t); };
  for (const auto& c : scaling)
    for (int t : threadCounts)
      benchmark::RegisterBenchmark(("physics/crumple_threads/" + threadsName(c, t)).c_str(), crumplePhysics, c.spec,
                                   threadsName(c, t), t)
          ->Iterations(gSteps)
          ->Unit(benchmark::kMillisecond);
  std::unique_ptr<gl::GlContext> gl;
  std::unique_ptr<DeformStage> stage;
  if (!noGl) {
    gl = gl::createHeadlessContext({true, false});
    std::printf("GL: %s\n", gl->description().c_str());
    std::printf("deform: the gather's address pass is rasterised by %s here (DeformOptions::addressRaster auto)\n",
                deform::addressRasterName(deform::resolveAddressRaster(
                    deform::AddressRaster::Auto, reinterpret_cast<const char*>(glGetString(GL_RENDERER)))));
    stage = std::make_unique<DeformStage>();
    gDeformStage = stage.get();
    for (int size : {256, 512, 1024, 2048}) {
      for (deform::Path path : {deform::Path::Gather, deform::Path::Scatter, deform::Path::Readback})
        benchmark::RegisterBenchmark((std::string("deform/") + deform::pathName(path)).c_str(), deformBench, path,
                                     deform::AddressRaster::Auto)
            ->Arg(size)
            ->Iterations(quick ? 3 : 20)
            ->Unit(benchmark::kMillisecond);
      // The gather with its address pass rasterised by each (DeformOptions::addressRaster; the row above: Auto).
      // --quick: up to 512 (the compute path on a software rasteriser takes seconds an event at 2048).
      if (quick && size > 512) continue;
      for (auto raster : {deform::AddressRaster::Compute, deform::AddressRaster::Fragment})
        benchmark::RegisterBenchmark(("deform/gather_" + std::string(deform::addressRasterName(raster))).c_str(),
                                     deformBench, deform::Path::Gather, raster)
            ->Arg(size)
            ->Iterations(quick ? 3 : 20)
            ->Unit(benchmark::kMillisecond);
    }
    // A busy step's batch: 100 events in one step at address map 1024, with each rasteriser.
    for (auto raster : {deform::AddressRaster::Compute, deform::AddressRaster::Fragment})
      benchmark::RegisterBenchmark(
          ("deform/gather_" + std::string(deform::addressRasterName(raster)) + "_100events").c_str(),
          deformBatchBench, quick ? 10 : 100, raster)
          ->Arg(1024)
          ->Iterations(quick ? 1 : 3)
          ->Unit(benchmark::kMillisecond);
    for (const auto& [name, off] : std::vector<std::pair<std::string, std::string>>{
             {"pom", ""}, {"no_parallax", "parallax"}, {"no_ibl", "ibl"}, {"no_aa", "aa"}, {"msaa", "+msaa"}, {"displace", "+displace"},
             {"simplified", "+simplified"}, {"sandbox_336x189", "sandbox"}, {"forward_shading", "+forward"},
             {"compute_shading", "+compute"}})
      benchmark::RegisterBenchmark(("render/" + std::string(off == "sandbox" ? "" : "1280x720/") + name).c_str(),
                                   renderBench, off)
          ->Iterations(quick ? 2 : 10)
          ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("render/1280x720/visibility_pass", visibilityBench)
        ->Iterations(quick ? 2 : 10)
        ->Unit(benchmark::kMillisecond);
  }
  std::vector<char*> args = {argv[0]};
  std::string filterArg = "--benchmark_filter=" + filter;
  if (!filter.empty()) args.push_back(filterArg.data());
  std::string repetitionsArg = "--benchmark_repetitions=" + std::to_string(repetitions);
  std::string interleave = "--benchmark_enable_random_interleaving=true";
  if (repetitions > 1) {
    args.push_back(repetitionsArg.data());
    args.push_back(interleave.data());
  }
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  Collector collector;
  if (benchmark::RunSpecifiedBenchmarks(&collector) == 0) {
    std::fprintf(stderr, "crumple-bench: --filter '%s' matches no benchmark\n", filter.c_str());
    return 2;
  }

  auto ms = [&](const std::string& k) { return collector.ms.count(k) ? collector.ms[k] : NAN; };
  auto gpu = [&](const std::string& k) {
    auto it = collector.counters.find(k);
    return it != collector.counters.end() && it->second.count("gpu_ms") ? it->second.at("gpu_ms") : NAN;
  };
  // What the figures were measured on and against: the CPU, and each peer's build.
  std::printf("\n== machine and peers ==\n");
  {
    std::ifstream cpu("/proc/cpuinfo");
    std::string line, model = "unknown";
    while (std::getline(cpu, line))
      if (line.rfind("model name", 0) == 0) {
        model = line.substr(line.find(':') + 2);
        break;
      }
    std::printf("cpu: %s, %u hardware threads\n", model.c_str(), std::thread::hardware_concurrency());
  }
  std::printf("crumple %s: its physics library at -O3 (CMake build type %s)\n", crumple::versionString(),
              CRUMPLE_BENCH_BUILD_TYPE);
  std::printf("bullet: Debian's libbullet-dev, btSequentialImpulseConstraintSolver, one thread\n");
  if (joltBuilt()) {
    std::printf("jolt: %s, one thread\n", joltConfiguration().c_str());
    for (const std::string& w : joltWarnings()) std::printf("WARNING: %s\n", w.c_str());
  }
  std::printf("\n== ratios ==\n");
  for (const auto& c : cases) {
    const double a = ms("physics/crumple/" + c.name), b = ms("physics/bullet/" + c.name);
    if (std::isnan(a) && std::isnan(b)) continue;  // filtered out
    std::printf("physics %-22s crumple %8.3f ms/step  bullet %8.3f ms/step  crumple/bullet %6.2fx\n", c.name.c_str(), a,
                b, a / b);
    const double j = ms("physics/jolt/" + c.name);
    if (!std::isnan(j))
      std::printf("        %-22s jolt %8.3f ms/step  crumple/jolt %6.2fx  bullet/jolt %6.2fx\n", "", j, a / j, b / j);
    auto& ca = collector.counters["physics/crumple/" + c.name];
    auto& cb = collector.counters["physics/bullet/" + c.name];
    if (!ca.empty() && !cb.empty())
      std::printf("        at the end: crumple %4.0f awake, top centre %.2f m; bullet %4.0f awake, top centre %.2f m\n",
                  ca["awake"], ca["top_m"], cb["awake"], cb["top_m"]);
    auto& cj = collector.counters["physics/jolt/" + c.name];
    if (!cj.empty())
      std::printf("                    jolt %4.0f awake, top centre %.2f m\n", cj["awake"], cj["top_m"]);
    if (gStageMs.count(c.name)) {
      const StepProfile& p = gStageMs[c.name];
      std::printf(
          "        crumple stages, ms/step: broad phase %.3f  candidates %.3f  collide %.3f  contact %.3f  shock %.3f  "
          "positions %.3f  sleep %.3f  joints %.3f  (total %.3f)\n",
          p.broadPhase, p.candidates, p.collide, p.contact, p.shockPropagation, p.positions, p.sleep, p.joints, p.total);
    }
  }
  for (const auto& c : scaling) {
    const double one = ms("physics/crumple_threads/" + threadsName(c, threadCounts.front()));
    bool sameBits = true;
    int measured = 0;
    for (int t : threadCounts) {
      const double a = ms("physics/crumple_threads/" + threadsName(c, t));
      if (std::isnan(a)) continue;
      ++measured;
      std::printf("threads %-22s %3d threads %8.3f ms/step  speedup over %d %6.2fx\n", c.name.c_str(), t, a,
                  threadCounts.front(), one / a);
      if (gStageMs.count(threadsName(c, t))) {
        const StepProfile& p = gStageMs[threadsName(c, t)];
        auto& counters = collector.counters["physics/crumple_threads/" + threadsName(c, t)];
        std::printf(
            "        ms/step: broad phase %.3f  candidates %.3f  collide %.3f  contact %.3f  shock %.3f  positions %.3f  "
            "sleep %.3f  joints %.3f; largest island %.0f pairs (of %.0f islands then)\n",
            p.broadPhase, p.candidates, p.collide, p.contact, p.shockPropagation, p.positions, p.sleep, p.joints,
            counters["largest_island"], counters["islands"]);
      }
      sameBits = sameBits && gEndHash[threadsName(c, t)] == gEndHash[threadsName(c, threadCounts.front())];
    }
    if (measured > 0)
      std::printf("        %s: every thread count ended in the %s (state hash)\n", c.name.c_str(),
                  sameBits ? "same bits" : "DIFFERENT bits");
  }
  for (int size : {256, 512, 1024, 2048}) {
    const std::string s = "/" + std::to_string(size);
    const double g = ms("deform/gather" + s), c = ms("deform/scatter" + s), r = ms("deform/readback" + s);
    if (!std::isnan(g))
      std::printf(
          "deform  address map %4d  gather %8.3f ms  scatter %8.3f ms  readback %8.3f ms  gather/scatter %6.2fx  "
          "readback/scatter %6.2fx\n",
          size, g, c, r, g / c, r / c);
    const double cw = ms("deform/gather_compute" + s), fw = ms("deform/gather_fragment" + s);
    const double cg = gpu("deform/gather_compute" + s), fg = gpu("deform/gather_fragment" + s);
    if (!std::isnan(cw) && !std::isnan(fw))
      std::printf(
          "deform  address map %4d  gather, address pass in compute %8.3f ms (GPU %7.3f)  in the fragment stage %8.3f "
          "ms (GPU %7.3f)  compute/fragment %6.2fx (GPU %6.2fx)\n",
          size, cw, cg, fw, fg, cw / fw, cg / fg);
  }
  for (const char* n : {"deform/gather_compute_100events/1024", "deform/gather_fragment_100events/1024"})
    if (!std::isnan(ms(n)))
      std::printf("deform  %-38s %8.3f ms  (GPU %8.3f ms, %.0f waves)\n", n, ms(n), gpu(n),
                  collector.counters[n]["waves"]);
  const std::string it;
  const double p = ms("render/1280x720/pom" + it), f = ms("render/1280x720/no_parallax" + it);
  if (!std::isnan(p))
    std::printf("render  1280x720   pom %8.3f ms/frame  no parallax %8.3f ms/frame  pom/none %6.2fx\n", p, f, p / f);
  const double noIbl = ms("render/1280x720/no_ibl"), noAa = ms("render/1280x720/no_aa");
  if (!std::isnan(p) && !std::isnan(noIbl))
    std::printf("render  1280x720   ibl %8.3f ms/frame  no ibl %8.3f ms/frame  ibl/none %6.2fx\n", p, noIbl, p / noIbl);
  if (!std::isnan(p) && !std::isnan(noAa))
    std::printf("render  1280x720   fxaa %8.3f ms/frame  no aa %8.3f ms/frame  fxaa/none %6.2fx\n", p, noAa, p / noAa);
  const double msaa = ms("render/1280x720/msaa");
  if (!std::isnan(msaa) && !std::isnan(noAa) && !std::isnan(p))
    std::printf("render  1280x720   msaa4 %8.3f ms/frame  no aa %8.3f ms/frame  msaa/none %6.2fx  msaa/fxaa %6.2fx\n", msaa,
                noAa, msaa / noAa, msaa / p);
  const double displaced = ms("render/1280x720/displace");
  if (!std::isnan(p) && !std::isnan(displaced))
    std::printf("render  1280x720   displace %8.3f ms/frame  pom alone %8.3f ms/frame  displace/pom %6.2fx\n", displaced, p,
                displaced / p);
  const double simplified = ms("render/1280x720/simplified"), sandboxView = ms("render/sandbox_336x189");
  if (!std::isnan(p) && !std::isnan(simplified))
    std::printf("render  1280x720   simplified meshes %8.3f ms/frame  full %8.3f ms/frame  simplified/full %6.2fx\n",
                simplified, p, simplified / p);
  const double fw = ms("render/1280x720/forward_shading"), cw = ms("render/1280x720/compute_shading");
  const double fg = gpu("render/1280x720/forward_shading"), cg = gpu("render/1280x720/compute_shading");
  if (!std::isnan(fw) && !std::isnan(cw))
    std::printf("render  1280x720   shaded in compute %8.3f ms/frame (GPU %7.3f)  in the fragment stage %8.3f ms/frame "
                "(GPU %7.3f)  compute/fragment %6.2fx (GPU %6.2fx)\n",
                cw, cg, fw, fg, cw / fw, cg / fg);
  if (!std::isnan(sandboxView))
    std::printf("render  sandbox view 336x189 (960x540 x 0.35, simplified)  %8.3f ms/frame  (%.1f frames/s of rendering)\n",
                sandboxView, 1000.0 / sandboxView);
  if (deformPhases && gDeformStage) deformProfile(quick ? 3 : 20);
  if (renderParts && gDeformStage) renderProfile(quick ? 3 : 20);
  return 0;
}
