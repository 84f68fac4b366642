// crumple-bench's rows, registered by its main (crumple_bench.cpp): the physics rows (bench_physics.cpp: the
// scenes built in crumple, Bullet and Jolt) and the GPU rows (bench_gpu.cpp: deformation and rendering).
#pragma once
#include <benchmark/benchmark.h>

#include <cstdint>
#include <map>
#include <string>

#include <crumple/deform/deformer.h>
#include <crumple/physics/world.h>

#include "bench_scenes.h"

namespace crumple::bench {

// ---- physics (bench_physics.cpp)
extern int gSteps;  // steps a physics row times
// crumple's stage times (World::lastStats().ms) per case: mean ms per step.
extern std::map<std::string, StepProfile> gStageMs;
// The state hash each crumple run ended with, per benchmark name (thread rows: the same bits for every count).
extern std::map<std::string, uint64_t> gEndHash;
SceneSpec pyramid(int levels);
SceneSpec pile(int nx, int nz, int layers);
SceneSpec heapScene(int n);
SceneSpec toriScene(int n);
SceneSpec chainScene(int chains, int links);
// A row: the scene stepped gSteps times in one engine (counters: awake bodies and the highest centre at the end).
void crumplePhysics(benchmark::State& state, SceneSpec spec, std::string name, int threads);
void bulletPhysics(benchmark::State& state, SceneSpec spec);
void joltPhysics(benchmark::State& state, SceneSpec spec);
// --timeline: the scene stepped gSteps times in each engine, a window of steps at a time in turn, printing each
// window's CPU time per step and the bodies awake at its end (where in the run each engine spends its time).
void physicsTimeline(const std::string& name, const SceneSpec& spec, int threads, int window);

// ---- deformation and rendering (bench_gpu.cpp), with a GL context current
extern double gWarmUp;  // seconds each GPU row runs untimed first (a GPU ramps its clock up under load)
// The GPU rows' shared meshes, while one is alive (made after the GL context, gone before it).
class GpuRows {
 public:
  GpuRows();
  ~GpuRows();
};
void deformBench(benchmark::State& state, deform::Path path, deform::AddressRaster raster);
void deformBatchBench(benchmark::State& state, int events, deform::AddressRaster raster);
void renderBench(benchmark::State& state, const std::string& off);
void visibilityBench(benchmark::State& state);
// --deform-profile, --render-profile: printed after the table.
void deformProfile(int iterations);
void renderProfile(int iterations);

}  // namespace crumple::bench
