// crumple-bench's GPU rows: deformations on each path and rasteriser, frames of the highway with each renderer
// feature off in turn, and the per-phase profiles.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <glm/gtc/matrix_transform.hpp>
#include <map>
#include <memory>
#include <string>

#include <crumple/deform/deformer.h>
#include <crumple/engine/builtin_scenes.h>
#include <crumple/engine/primitives.h>
#include <crumple/engine/scene_view.h>
#include <crumple/engine/simulation.h>
#include <crumple/gl/gpu_timer.h>
#include <crumple/gl/objects.h>
#include <crumple/gl/program.h>
#include <crumple/render/renderer.h>

#include "bench_rows.h"

namespace crumple::bench {

namespace {
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
}  // namespace


// Wall time per event (glFinish after each), and the GPU's time (gpu_ms: timer queries around the event).
// A GPU idles at a low clock (an H200 at 345 MHz) and takes a while under load to ramp up: each GPU row first runs
// its work, untimed, for gWarmUp seconds (0 with --quick).
double gWarmUp = 0.3;
namespace {
template <typename F>
void warmUp(F&& work) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(gWarmUp);
  do {
    work();
    glFinish();
  } while (std::chrono::steady_clock::now() < end);
}
}  // namespace


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
namespace {

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
}  // namespace


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
namespace {

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
}  // namespace


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
  // The dented maps' way back to the physics (dents felt): the texels changed, logged by the GPU behind a fence a
  // step after the dent, then taken in (the tiles that changed, the lookups' triangles). Beside it the same scene
  // with its dents visual only: the physics' cost of feeling them (the two runs part at the first dent felt, so
  // their collisions differ too).
  for (const bool feel : {true, false}) {
    Scene scene = builtinHighway();
    scene.deformation.feelDents = feel;
    Simulation sim(scene, true);
    for (int s = 0; s < 900; ++s) sim.step();
    const Timings& t = sim.timings();
    const double each = t.dentReads ? 1.0 / static_cast<double>(t.dentReads) : 0.0;
    if (feel)
      std::printf("transfer  highway, 900 steps, dents felt: %ld maps taken in (%ld texels logged, %ld maps read "
                  "whole), %.3f ms each taking in (%.3f ms of it blocked on the fence), %ld deformations, %.3f ms a "
                  "step of physics\n",
                  t.dentReads, t.dentTexels, t.dentFullReads, t.dentReadMs * each, t.dentWaitMs * each,
                  t.deformations, t.physicsMs / static_cast<double>(sim.steps()));
    else
      std::printf("transfer  highway, 900 steps, dents not felt: %ld deformations, %.3f ms a step of physics\n",
                  t.deformations, t.physicsMs / static_cast<double>(sim.steps()));
  }
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
  if (r.settings().displace) sim.updateCreaseBevels();  // (as drawFrame does before a displaced frame)
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

GpuRows::GpuRows() { gDeformStage = new DeformStage(); }
GpuRows::~GpuRows() {
  delete gDeformStage;
  gDeformStage = nullptr;
}

}  // namespace crumple::bench
