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
// each stage: World::lastStats().ms). The rows are in bench_physics.cpp and bench_gpu.cpp (bench_rows.h).
#include <benchmark/benchmark.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <crumple/core/version.h>
#include <crumple/deform/deformer.h>
#include <crumple/gl/context.h>

#include "bench_rows.h"
#include "cli.h"

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

// The instruction sets this program (and crumple's libraries, built with the same flags) was compiled for, named
// as Jolt's configuration string names them.
std::vector<std::string> crumpleInstructionSets() {
  std::vector<std::string> sets;
#if defined(__SSE2__)
  sets.push_back("SSE2");
#endif
#if defined(__SSE4_1__)
  sets.push_back("SSE4.1");
#endif
#if defined(__SSE4_2__)
  sets.push_back("SSE4.2");
#endif
#if defined(__AVX__)
  sets.push_back("AVX");
#endif
#if defined(__AVX2__)
  sets.push_back("AVX2");
#endif
#if defined(__AVX512F__)
  sets.push_back("AVX512");
#endif
#if defined(__F16C__)
  sets.push_back("F16C");
#endif
#if defined(__LZCNT__)
  sets.push_back("LZCNT");
#endif
#if defined(__BMI__)
  sets.push_back("TZCNT");
#endif
#if defined(__FMA__)
  sets.push_back("FMADD");
#endif
  return sets;
}

// The instruction sets a peer's configuration string lists ("... with instructions: SSE2 AVX ... (" up to the first
// parenthesis) that crumple's build does not use.
std::vector<std::string> instructionSetsBeyondCrumple(const std::string& configuration) {
  std::vector<std::string> beyond;
  const std::string key = "with instructions:";
  const size_t at = configuration.find(key);
  if (at == std::string::npos) return beyond;
  const std::string list = configuration.substr(at + key.size(), configuration.find('(', at) - at - key.size());
  const std::vector<std::string> ours = crumpleInstructionSets();
  size_t i = 0;
  while (i < list.size()) {
    const size_t end = std::min(list.find(' ', i), list.size());
    const std::string set = list.substr(i, end - i);
    if (!set.empty() && std::find(ours.begin(), ours.end(), set) == ours.end()) beyond.push_back(set);
    i = end + 1;
  }
  return beyond;
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
  // The fastest ms per iteration of a benchmark, NaN where it did not run (filtered out).
  double fastest(const std::string& name) const {
    const auto it = ms.find(name);
    return it != ms.end() ? it->second : NAN;
  }
  // One of its counters, NaN where it has none.
  double counter(const std::string& name, const std::string& key) const {
    const auto it = counters.find(name);
    if (it == counters.end()) return NAN;
    const auto c = it->second.find(key);
    return c != it->second.end() ? c->second : NAN;
  }
};

// The command line.
struct Options {
  bool quick = false, noGl = false, deformPhases = false, renderParts = false, strictPeers = false, timeline = false;
  std::string filter;
  int threads = 1, repetitions = 1;
  std::vector<int> threadCounts = {1, 2, 4, 8, 16};
};

void addOptions(CLI::App& app, Options& o) {
  app.add_flag("--quick", o.quick, "Fewer steps and smaller scenes (a smoke run)");
  app.add_flag("--render-profile", o.renderParts, "Also print the GPU time of each part of the highway frame");
  app.add_flag("--no-gl", o.noGl, "Physics only");
  app.add_flag("--deform-profile", o.deformPhases,
               "Also print the wall time of each phase of a deformation, every path");
  app.add_option("--filter", o.filter, "Only benchmarks whose name matches this regular expression");
  app.add_flag("--timeline", o.timeline,
               "Also print, for each physics scene whose crumple row ran, each engine's CPU time per step over every "
               "20 steps and the bodies awake then (the engines step each window in turn): where in the run each "
               "spends its time");
  app.add_flag("--strict-peers", o.strictPeers,
               "Refuse to run (exit 1) when a peer's build would slow its rows (a Jolt built with its profiler, debug "
               "renderer, asserts or without NDEBUG): figures meant for publishing (tools/bench-vs-jolt.sh)");
  app.add_option("--repetitions", o.repetitions,
                 "Runs of each benchmark, interleaved at random with the others'; the ratios take each one's fastest "
                 "(a machine whose speed drifts then slows no engine more than another)")
      ->check(CLI::Range(1, 100));
  app.add_option("--threads", o.threads,
                 "Threads of crumple's physics rows (WorldSettings::threads; 0: the hardware's)")
      ->check(CLI::Range(0, 256));
  app.add_option("--thread-counts", o.threadCounts,
                 "Thread counts of the scaling rows (the 4000 and 10000 piles; --quick: the small pile)")
      ->check(CLI::Range(1, 256))
      ->delimiter(',');
  cli::addVersion(app, "crumple-bench");
}

struct PhysicsCase {
  std::string name;
  SceneSpec spec;
};
PhysicsCase pileCase(int nx, int nz) { return {"pile_" + std::to_string(nx * nz * 10) + "boxes", pile(nx, nz, 10)}; }
std::string threadsName(const PhysicsCase& c, int t) { return c.name + "/threads:" + std::to_string(t); }

// The physics rows: each case in each engine.
std::vector<PhysicsCase> registerPhysics(const Options& o) {
  const int levels = o.quick ? 6 : 20, tori = o.quick ? 20 : 200, heap = o.quick ? 60 : 500;
  std::vector<PhysicsCase> cases = {
      {"pyramid" + std::to_string(levels) + "_" + std::to_string(levels * (levels + 1) / 2) + "boxes", pyramid(levels)},
      o.quick ? pileCase(4, 3) : pileCase(10, 10)};
  if (!o.quick) {
    cases.push_back(pileCase(20, 20));
    cases.push_back(pileCase(40, 25));
  }
  cases.push_back({"heap_" + std::to_string(heap) + "mixed", heapScene(heap)});
  cases.push_back({"tori_" + std::to_string(tori) + "meshes", toriScene(tori)});
  cases.push_back({"chains_" + std::to_string(o.quick ? 2 : 10) + "x20links", chainScene(o.quick ? 2 : 10, 20)});
  for (const auto& c : cases) {
    benchmark::RegisterBenchmark(("physics/crumple/" + c.name).c_str(), crumplePhysics, c.spec, c.name, o.threads)
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
  return cases;
}

// Scaling: the big piles on each thread count (crumple only).
std::vector<PhysicsCase> registerScaling(const Options& o) {
  std::vector<PhysicsCase> scaling;
  if (o.quick) {
    scaling.push_back(pileCase(4, 3));
  } else {
    scaling.push_back(pileCase(20, 20));
    scaling.push_back(pileCase(40, 25));
  }
  for (const auto& c : scaling)
    for (int t : o.threadCounts)
      benchmark::RegisterBenchmark(("physics/crumple_threads/" + threadsName(c, t)).c_str(), crumplePhysics, c.spec,
                                   threadsName(c, t), t)
          ->Iterations(gSteps)
          ->Unit(benchmark::kMillisecond);
  return scaling;
}

// The GPU rows: deformation on each path and rasteriser, a busy step's batch, frames with features off in turn.
void registerGpu(const Options& o) {
  for (int size : {256, 512, 1024, 2048}) {
    for (deform::Path path : {deform::Path::Gather, deform::Path::Scatter, deform::Path::Readback})
      benchmark::RegisterBenchmark((std::string("deform/") + deform::pathName(path)).c_str(), deformBench, path,
                                   deform::AddressRaster::Auto)
          ->Arg(size)
          ->Iterations(o.quick ? 3 : 20)
          ->Unit(benchmark::kMillisecond);
    // The gather with its address pass rasterised by each (DeformOptions::addressRaster; the row above: Auto).
    // --quick: up to 512 (the compute path on a software rasteriser takes seconds an event at 2048).
    if (o.quick && size > 512) continue;
    for (auto raster : {deform::AddressRaster::Compute, deform::AddressRaster::Fragment})
      benchmark::RegisterBenchmark(("deform/gather_" + std::string(deform::addressRasterName(raster))).c_str(),
                                   deformBench, deform::Path::Gather, raster)
          ->Arg(size)
          ->Iterations(o.quick ? 3 : 20)
          ->Unit(benchmark::kMillisecond);
  }
  // A busy step's batch: 100 events in one step at address map 1024, with each rasteriser.
  for (auto raster : {deform::AddressRaster::Compute, deform::AddressRaster::Fragment})
    benchmark::RegisterBenchmark(
        ("deform/gather_" + std::string(deform::addressRasterName(raster)) + "_100events").c_str(),
        deformBatchBench, o.quick ? 10 : 100, raster)
        ->Arg(1024)
        ->Iterations(o.quick ? 1 : 3)
        ->Unit(benchmark::kMillisecond);
  for (const auto& [name, off] : std::vector<std::pair<std::string, std::string>>{
           {"pom", ""}, {"no_parallax", "parallax"}, {"no_ibl", "ibl"}, {"no_aa", "aa"}, {"msaa", "+msaa"},
           {"displace", "+displace"}, {"simplified", "+simplified"}, {"sandbox_336x189", "sandbox"},
           {"forward_shading", "+forward"}, {"compute_shading", "+compute"}})
    benchmark::RegisterBenchmark(("render/" + std::string(off == "sandbox" ? "" : "1280x720/") + name).c_str(),
                                 renderBench, off)
        ->Iterations(o.quick ? 2 : 10)
        ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("render/1280x720/visibility_pass", visibilityBench)
      ->Iterations(o.quick ? 2 : 10)
      ->Unit(benchmark::kMillisecond);
}

// Runs the registered rows (--filter, --repetitions interleaved); false when the filter matched none.
bool runRows(const Options& o, const char* program, Collector& collector) {
  std::vector<char*> args = {const_cast<char*>(program)};
  std::string filterArg = "--benchmark_filter=" + o.filter;
  if (!o.filter.empty()) args.push_back(filterArg.data());
  std::string repetitionsArg = "--benchmark_repetitions=" + std::to_string(o.repetitions);
  std::string interleave = "--benchmark_enable_random_interleaving=true";
  if (o.repetitions > 1) {
    args.push_back(repetitionsArg.data());
    args.push_back(interleave.data());
  }
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  return benchmark::RunSpecifiedBenchmarks(&collector) != 0;
}

// What the figures were measured on and against: the CPU, and each peer's build.
void printMachine() {
  std::printf("\n== machine and peers ==\n");
  std::ifstream cpu("/proc/cpuinfo");
  std::string line, model = "unknown";
  while (std::getline(cpu, line))
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  std::printf("cpu: %s, %u hardware threads\n", model.c_str(), std::thread::hardware_concurrency());
  std::string sets;
  for (const std::string& set : crumpleInstructionSets()) sets += (sets.empty() ? "" : " ") + set;
#ifdef CRUMPLE_BENCH_LTO
  const char* lto = " with link-time optimisation";
#else
  const char* lto = "";
#endif
  std::printf("crumple %s: its physics library at -O3%s (CMake build type %s), instructions: %s (never FMA)\n",
              crumple::versionString(), lto, CRUMPLE_BENCH_BUILD_TYPE, sets.c_str());
  std::printf("bullet: Debian's libbullet-dev, btSequentialImpulseConstraintSolver, one thread\n");
  if (joltBuilt()) {
    std::printf("jolt: %s, one thread\n", joltConfiguration().c_str());
    for (const std::string& w : joltWarnings()) std::printf("WARNING: %s\n", w.c_str());
    std::string beyond;
    bool fused = false;
    for (const std::string& set : instructionSetsBeyondCrumple(joltConfiguration())) {
      if (set == "FMADD") fused = true;
      else beyond += " " + set;
    }
    if (!beyond.empty())
      std::printf("WARNING: Jolt uses instruction sets crumple was not built with:%s; for the same ones configure "
                  "crumple with -DCMAKE_CXX_FLAGS=-march=x86-64-v3 (tools/bench-vs-jolt.sh does where the CPU has them)\n",
                  beyond.c_str());
    if (fused)
      std::printf("note: Jolt fuses multiply-adds (FMADD); crumple never does, on purpose: every build steps the same "
                  "bits (docs/architecture.md, Determinism)\n");
  }
}

// The physics ratios: ms per step in each engine, their end states, crumple's stages.
void printPhysics(const std::vector<PhysicsCase>& cases, Collector& collector) {
  for (const auto& c : cases) {
    const double a = collector.fastest("physics/crumple/" + c.name), b = collector.fastest("physics/bullet/" + c.name);
    if (std::isnan(a) && std::isnan(b)) continue;  // filtered out
    std::printf("physics %-22s crumple %8.3f ms/step  bullet %8.3f ms/step  crumple/bullet %6.2fx\n", c.name.c_str(), a,
                b, a / b);
    const double j = collector.fastest("physics/jolt/" + c.name);
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
      // (Two builds that step the same bits end in the same hash: a change meant to leave the physics as it was is
      // checked here.)
      if (gEndHash.count(c.name))
        std::printf("        crumple end state hash %016llx\n", static_cast<unsigned long long>(gEndHash[c.name]));
    }
  }
}

// The scaling rows: each thread count's ms per step and speedup, and whether all ended in the same bits.
void printScaling(const std::vector<PhysicsCase>& scaling, const std::vector<int>& threadCounts,
                  Collector& collector) {
  for (const auto& c : scaling) {
    const double one = collector.fastest("physics/crumple_threads/" + threadsName(c, threadCounts.front()));
    bool sameBits = true;
    int measured = 0;
    for (int t : threadCounts) {
      const double a = collector.fastest("physics/crumple_threads/" + threadsName(c, t));
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
}

// The deformation ratios: the paths at each address map size, the address pass's rasterisers, the busy batch.
void printDeform(Collector& collector) {
  auto ms = [&](const std::string& k) { return collector.fastest(k); };
  auto gpu = [&](const std::string& k) { return collector.counter(k, "gpu_ms"); };
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
}

// The render ratios: each feature against the frame with everything on.
void printRender(Collector& collector) {
  auto ms = [&](const std::string& k) { return collector.fastest(k); };
  const double p = ms("render/1280x720/pom"), f = ms("render/1280x720/no_parallax");
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
  const double fg = collector.counter("render/1280x720/forward_shading", "gpu_ms"),
               cg = collector.counter("render/1280x720/compute_shading", "gpu_ms");
  if (!std::isnan(fw) && !std::isnan(cw))
    std::printf("render  1280x720   shaded in compute %8.3f ms/frame (GPU %7.3f)  in the fragment stage %8.3f ms/frame "
                "(GPU %7.3f)  compute/fragment %6.2fx (GPU %6.2fx)\n",
                cw, cg, fw, fg, cw / fw, cg / fg);
  if (!std::isnan(sandboxView))
    std::printf("render  sandbox view 336x189 (960x540 x 0.35, simplified)  %8.3f ms/frame  (%.1f frames/s of rendering)\n",
                sandboxView, 1000.0 / sandboxView);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "crumple-bench: crumple vs Bullet (and Jolt, if built with CRUMPLE_JOLT_DIR) (physics), gather vs scatter vs "
      "read-back (deformation), POM on/off (render); prints ms per step/deformation/frame and the ratios."};
  Options o;
  addOptions(app, o);
  if (const auto rc = cli::parse(app, "crumple-bench", argc, argv)) return *rc;
  if (o.strictPeers && joltBuilt() && !joltWarnings().empty()) {
    std::printf("jolt: %s\n", joltConfiguration().c_str());
    for (const std::string& w : joltWarnings()) std::printf("WARNING: %s\n", w.c_str());
    std::fprintf(stderr, "crumple-bench: error: --strict-peers: Jolt's build would slow its rows (WARNING above); "
                         "build it as tools/build-jolt.sh does\n");
    return 1;
  }
  gSteps = o.quick ? 24 : 240;
  if (o.quick) gWarmUp = 0;
  const std::vector<PhysicsCase> cases = registerPhysics(o), scaling = registerScaling(o);
  std::unique_ptr<gl::GlContext> gl;
  std::unique_ptr<GpuRows> gpuRows;
  if (!o.noGl) {
    gl = gl::createHeadlessContext({true, false});
    std::printf("GL: %s\n", gl->description().c_str());
    std::printf("deform: the gather's address pass is rasterised by %s here (DeformOptions::addressRaster auto)\n",
                deform::addressRasterName(deform::resolveAddressRaster(
                    deform::AddressRaster::Auto, reinterpret_cast<const char*>(glGetString(GL_RENDERER)))));
    gpuRows = std::make_unique<GpuRows>();
    registerGpu(o);
  }
  Collector collector;
  if (!runRows(o, argv[0], collector)) {
    std::fprintf(stderr, "crumple-bench: --filter '%s' matches no benchmark\n", o.filter.c_str());
    return 2;
  }
  printMachine();
  std::printf("\n== ratios ==\n");
  printPhysics(cases, collector);
  printScaling(scaling, o.threadCounts, collector);
  if (o.timeline)
    for (const auto& c : cases)
      if (!std::isnan(collector.fastest("physics/crumple/" + c.name)))
        physicsTimeline(c.name, c.spec, o.threads, o.quick ? 6 : 20);
  printDeform(collector);
  printRender(collector);
  if (o.deformPhases && gpuRows) deformProfile(o.quick ? 3 : 20);
  if (o.renderParts && gpuRows) renderProfile(o.quick ? 3 : 20);
  return 0;
}
