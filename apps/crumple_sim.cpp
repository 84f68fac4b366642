// crumple-sim: batch runs of scene files. Writes the outputs docs/outputs.md
// describes. Exit status: 0 success, 2 bad input, 1 failure,
// 130 interrupted (SIGINT or SIGTERM: the partial output is removed, nothing is replaced).
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <crumple/engine/builtin_scenes.h>
#include <crumple/engine/output_writer.h>
#include <crumple/engine/overrides.h>
#include <crumple/engine/simulation.h>
#include <crumple/core/log.h>
#include <crumple/core/version.h>
#include <crumple/gl/context.h>
#include <crumple/engine/scene_view.h>
#include <crumple/render/renderer.h>

#include "cli.h"

using namespace crumple;
namespace fs = std::filesystem;

namespace {
// SIGINT and SIGTERM. While the run loads (the scene, its meshes and images, the GL context, the atlases) nothing
// has been written yet: the process ends at once with 130, whatever it is waiting for. Once the staging folder
// exists the signal is noted and the run stops at the next step, removing the folder.
volatile std::sig_atomic_t gInterrupted = 0;
volatile std::sig_atomic_t gLoading = 1;
extern "C" void onSignal(int) {
  if (gLoading) {
    static const char message[] = "\ncrumple-sim: interrupted while loading: nothing written\n";
    const ssize_t ignored = ::write(STDERR_FILENO, message, sizeof message - 1);
    (void)ignored;
    ::_exit(130);
  }
  gInterrupted = 1;
}

void installSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = onSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

// The first executable `name` on PATH, or empty.
std::string findOnPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::string dir = end > start ? dirs.substr(start, end - start) : ".";
    const std::string candidate = dir + "/" + name;
    if (::access(candidate.c_str(), X_OK) == 0 && !fs::is_directory(candidate)) return candidate;
    start = end + 1;
  }
  return "";
}

// Runs a program (no shell) and waits for it; returns its exit status, or -1 when it could not run.
int runProgram(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (::posix_spawn(&pid, args[0].c_str(), nullptr, nullptr, argv.data(), environ) != 0) return -1;
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}


// The command line.
struct Options {
  std::string scenePath, outDir, deformPath, trace, size = "960x540", exportFormat, video, videoCamera;
  std::string antialias = "fxaa", shading = "auto";
  double duration = -1, fps = 30;
  long steps = -1;
  int gpu = -1, threads = -1;
  std::vector<std::string> sets;
  bool renderFrames = false, quiet = false, verbose = false, animate = false, displace = false;
  int width = 0, height = 0;  // of --size
  std::string ffmpeg;         // the program --video runs
};

void addOptions(CLI::App& app, Options& o) {
  app.add_option("scene", o.scenePath,
                 "Scene file (JSON). Without one, the built-in default scene (sphere into plate) runs.");
  app.add_option("--out,-o", o.outDir, "Output folder (default: out/<scene name>). Written atomically.");
  app.add_option("--duration", o.duration, "Simulated seconds, overriding the scene's duration")
      ->check(CLI::Range(1e-6, 1e6));
  app.add_option("--steps", o.steps, "Number of steps, overriding duration")->check(CLI::Range(1L, 100000000L));
  app.add_option("--deform-path", o.deformPath,
                 "gather (default: every texel of a dent gathers its depth on the GPU, no gaps), scatter (the paper's "
                 "update on the GPU) or readback (the paper's path: address maps read back, CPU scatter)")
      ->check(CLI::IsMember({"gather", "scatter", "readback", "gpu"}));
  app.add_flag("--render", o.renderFrames, "Write frames/<camera>_<frame>.png for every camera of the scene");
  app.add_option("--size", o.size, "Frame size WxH for --render")->default_val("960x540");
  app.add_flag("--displace", o.displace,
               "Draw every camera with displacement (dents change silhouettes; tessellation shaders), as a camera's "
               "\"displace\": true does for that camera");
  cli::addAntialias(app, o.antialias,
                    "Antialiasing of the rendered frames: fxaa (default: an FXAA pass over each frame), msaa (4 "
                    "samples a pixel, resolved; slower on a CPU rasteriser) or none");
  app.add_option("--shading", o.shading,
                 "Where the rendered frames' pixels are shaded: auto (default: compute on GPUs whose graphics stages "
                 "run on a few multiprocessors, such as NVIDIA's H100, else fragment), fragment (as the items are "
                 "drawn) or compute (from a visibility buffer, once a pixel; not with MSAA or displacement)")
      ->check(CLI::IsMember({"auto", "fragment", "compute"}))
      ->capture_default_str();
  app.add_option("--fps", o.fps, "Frames per simulated second for --render")
      ->check(CLI::Range(0.01, 1000.0))
      ->default_val(30);
  cli::addSets(app, o.sets);
  app.add_option("--gpu", o.gpu,
                 "Use this EGL device (0 = the first hardware GPU; default: CRUMPLE_EGL_DEVICE, else the first GPU, "
                 "else software)")
      ->check(CLI::Range(0, 1023));
  app.add_option("--threads", o.threads,
                 "Threads of the physics step, overriding the scene's threads (0: the hardware's); the results are "
                 "the same bits for every count")
      ->check(CLI::Range(0, 256));
  app.add_option("--trace", o.trace, "Write every body's state per step to this CSV file");
  auto* exportOption =
      app.add_option("--export", o.exportFormat,
                     "gltf: also write export/scene.gltf (every body at its final pose, its atlas, normal and height "
                     "maps)")
          ->check(CLI::IsMember({"gltf"}));
  app.add_flag("--animate", o.animate,
               "With --export gltf: animate the export with the bodies' motion, a key frame per --fps frame, so a "
               "glTF viewer plays the run")
      ->needs(exportOption);
  app.add_option("--video", o.video,
                 "Encode one camera's frames into this video file (e.g. run.mp4) with ffmpeg; implies --render");
  app.add_option("--video-camera", o.videoCamera, "The camera for --video (default: the scene's first camera)");
  cli::addQuiet(app, o.quiet);
  app.add_flag("--verbose,-v", o.verbose, "Debug messages (GL debug output included)");
  cli::addVersion(app, "crumple-sim");
}

// What the options cannot say alone (--video's program and folder, --size): empty when they hold, else the error.
std::string checkOptions(Options& o) {
  if (!o.videoCamera.empty() && o.video.empty()) return "--video-camera needs --video";
  if (!o.video.empty()) {
    o.ffmpeg = findOnPath("ffmpeg");
    if (o.ffmpeg.empty()) return "--video needs ffmpeg (apt-get install ffmpeg)";
    const fs::path parent = fs::absolute(o.video).parent_path();
    if (!fs::is_directory(parent))
      return o.video + ": --video: the folder " + parent.string() + " does not exist";
    o.renderFrames = true;
  }
  if (std::sscanf(o.size.c_str(), "%dx%d", &o.width, &o.height) != 2 || o.width < 16 || o.height < 16 ||
      o.width > 8192 || o.height > 8192)
    return "--size must be WxH with sides in [16, 8192], got '" + o.size + "'";
  return "";
}

// The scene as the options change it (--set, --deform-path, --duration, --threads; --video-camera checked).
Scene loadRunScene(Options& o) {
  const Overrides overrides = cli::overridesOf(o.sets);
  Scene scene = o.scenePath.empty() ? parseScene(builtinSceneText(), "<built-in default scene>",
                                                 fs::current_path().string(), overrides)
                                    : loadScene(o.scenePath, overrides);
  if (o.deformPath == "gather" || o.deformPath == "gpu") scene.deformation.options.path = deform::Path::Gather;
  if (o.deformPath == "scatter") scene.deformation.options.path = deform::Path::Scatter;
  if (o.deformPath == "readback") scene.deformation.options.path = deform::Path::Readback;
  if (o.duration > 0) scene.duration = o.duration;
  if (o.threads >= 0) scene.threads = o.threads;
  if (o.outDir.empty()) o.outDir = "out/" + scene.name;
  if (!o.video.empty()) {  // the camera whose frames are encoded
    if (o.videoCamera.empty()) o.videoCamera = scene.cameras.empty() ? "default" : scene.cameras.front().name;
    bool known = scene.cameras.empty() && o.videoCamera == "default";
    for (const auto& c : scene.cameras) known = known || c.name == o.videoCamera;
    if (!known)
      throw SceneError(o.scenePath.empty() ? scene.file : o.scenePath, "cameras",
                       "--video-camera: no camera named '" + quoteText(o.videoCamera) + "'");
  }
  return scene;
}

// --video: `frames` (<camera>_%05d.png) encoded with ffmpeg into a temporary file beside the video (the same
// extension: ffmpeg picks the format from it), renamed when done.
void encodeVideo(const Options& o, const fs::path& framesDir, double frameRate) {
  const fs::path target = fs::absolute(o.video);
  const fs::path tmp = target.parent_path() / ("." + target.stem().string() + ".partial-" +
                                               std::to_string(::getpid()) + target.extension().string());
  std::vector<std::string> args = {o.ffmpeg, "-nostdin", "-y", "-loglevel", "error", "-framerate",
                                    std::to_string(frameRate), "-i",
                                    (framesDir / (o.videoCamera + "_%05d.png")).string()};
  std::string ext = target.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".mp4" || ext == ".mov" || ext == ".mkv")  // H.264 needs even sides; yuv420p plays everywhere
    args.insert(args.end(), {"-c:v", "libx264", "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"});
  args.push_back(tmp.string());
  const int rc = runProgram(args);
  std::error_code ec;
  if (rc != 0) {
    fs::remove(tmp, ec);
    throw std::runtime_error("--video: ffmpeg " +
                             (rc < 0 ? std::string("could not be run") : "exited with status " + std::to_string(rc)) +
                             " encoding " + o.video);
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw std::runtime_error(o.video + ": cannot write the video: " + ec.message());
  }
}

// What the loop writes besides the outputs: the frames (--render), the trace (--trace), the progress line.
class Recorder {
 public:
  Recorder(const Options& o, Simulation& sim, const Scene& scene, const fs::path& framesDir)
      : o_(o), sim_(sim), scene_(scene), framesDir_(framesDir), fallbackCamera_(defaultCamera(sim)) {
    if (o.renderFrames) {
      if (scene.cameras.empty()) logInfo("--render: the scene has no cameras; a default view frames its moving bodies");
      renderer_ = std::make_unique<render::Renderer>(o.width, o.height);
      renderer_->settings().displace = o.displace;
      renderer_->settings().antialias = render::antialiasNamed(o.antialias);
      renderer_->settings().shading = o.shading == "compute"    ? render::Shading::Compute
                                      : o.shading == "fragment" ? render::Shading::Forward
                                                                : render::Shading::Auto;
      fs::create_directories(framesDir);
    }
    if (!o.trace.empty()) {
      trace_.open(o.trace);
      if (!trace_) throw SceneError(o.trace, "", "--trace: cannot be opened for writing");
      trace_ << "step,time,body,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz\n";
      trace_.precision(10);
    }
  }
  bool rendering() const { return renderer_ != nullptr; }
  // Every camera's frame (without cameras: one framing the moving bodies and where they will dent, fixed at the
  // start).
  void renderFrame() {
    std::vector<CameraDesc> cams = scene_.cameras;
    if (cams.empty()) cams.push_back(fallbackCamera_);
    for (const auto& cam : cams) {
      char name[64];
      std::snprintf(name, sizeof name, "_%05ld.png", frame_);
      drawFrame(sim_, *renderer_, cameraView(cam, &sim_));
      renderer_->savePng((framesDir_ / (cam.name + name)).string());
    }
    ++frame_;
    ++sim_.timings().frames;
  }
  void traceStep(long step) {
    if (!trace_.is_open()) return;
    for (const auto& b : sim_.bodies()) {
      const RigidBody& rb = sim_.world().body(b.index);
      const glm::dvec3 p = rb.origin();
      trace_ << step << "," << sim_.world().time() << "," << b.name << "," << p.x << "," << p.y << "," << p.z << ","
             << rb.q.w << "," << rb.q.x << "," << rb.q.y << "," << rb.q.z << "," << rb.v.x << "," << rb.v.y << ","
             << rb.v.z << "," << rb.w.x << "," << rb.w.y << "," << rb.w.z << "\n";
    }
  }
  // The progress line, on a terminal.
  void progress(long step, long total) const {
    if (!tty_ || (step % 16 != 0 && step != total)) return;
    const int width = 30, filled = static_cast<int>(width * step / total);
    std::fprintf(stderr, "\r[%.*s%*s] %3ld%%  step %ld/%ld  collisions %zu", filled, "##############################",
                 width - filled, "", 100 * step / total, step, total, sim_.events().size());
    if (step == total) std::fprintf(stderr, "\n");
  }

 private:
  const Options& o_;
  Simulation& sim_;
  const Scene& scene_;
  fs::path framesDir_;
  CameraDesc fallbackCamera_;
  std::unique_ptr<render::Renderer> renderer_;
  std::ofstream trace_;
  long frame_ = 0;
  bool tty_ = !o_.quiet && isatty(STDERR_FILENO);
};

// The run: the scene loaded, stepped, its outputs written (exit status as main's).
int run(Options& o) {
  Scene scene = loadRunScene(o);
  const long totalSteps = o.steps > 0 ? o.steps : std::max(1L, std::lround(scene.duration / scene.timestep));
  OutputWriter writer(o.outDir);
  GltfAnimation animation;
  writer.setExportGltf(o.exportFormat == "gltf", o.animate ? &animation : nullptr);
  bool needGl = o.renderFrames;
  for (const auto& b : scene.bodies) needGl = needGl || b.bumpMap.present;
  std::unique_ptr<gl::GlContext> gl;
  if (needGl) {
    try {
      gl::HeadlessOptions glOptions;
      glOptions.debug = o.verbose;
      glOptions.device = o.gpu;
      gl = gl::createHeadlessContext(glOptions);
    } catch (const gl::ContextError& e) {
      std::cerr << "crumple-sim: failed: " << e.what() << "\n";
      return 1;
    }
    logInfo("GL: ", gl->description());
  }
  Simulation sim(scene, gl != nullptr);
  // Loaded: from here a signal is noted and the loop stops at the next step, removing the staging folder.
  gLoading = 0;
  writer.begin();
  const fs::path framesDir = fs::path(writer.staging()) / "frames";
  Recorder recorder(o, sim, scene, framesDir);
  auto interrupted = [&](long step) {
    writer.abandon();
    std::cerr << "\ncrumple-sim: interrupted at step " << step << ": nothing written\n";
    return 130;
  };
  const long frameEvery = std::max(1L, std::lround(1.0 / (o.fps * scene.timestep)));
  if (recorder.rendering()) recorder.renderFrame();
  if (o.animate) animation.record(sim);
  for (long s = 1; s <= totalSteps; ++s) {
    if (gInterrupted) return interrupted(s - 1);
    sim.step();
    if (recorder.rendering() && s % frameEvery == 0) recorder.renderFrame();
    if (o.animate && (s % frameEvery == 0 || s == totalSteps)) animation.record(sim);
    recorder.traceStep(s);
    recorder.progress(s, totalSteps);
  }
  if (gInterrupted) return interrupted(totalSteps);
  writer.write(sim);
  if (!o.video.empty()) encodeVideo(o, framesDir, 1.0 / (static_cast<double>(frameEvery) * scene.timestep));
  writer.commit();
  if (!o.quiet) {
    long sides = 0;
    for (const auto& r : sim.events()) sides += r.side[0].deformed + r.side[1].deformed;
    std::printf("crumple-sim: %s: %ld steps (%.3f s), %zu collisions, %ld deformations (%ld sides); wrote %s\n",
                scene.name.c_str(), sim.steps(), sim.world().time(), sim.events().size(), sim.timings().deformations,
                sides, o.outDir.c_str());
  }
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  // From the start: a signal while the scene loads ends the run at once (nothing is written before the loop).
  installSignalHandlers();
  CLI::App app{
      "crumple-sim: run a crumple scene headless and write its outputs (summary.json, events.jsonl, "
      "heightmaps/, normalmaps/, frames/)."};
  Options o;
  addOptions(app, o);
  if (const auto rc = cli::parse(app, "crumple-sim", argc, argv)) return *rc;
  setLogLevel(o.quiet ? LogLevel::Error : o.verbose ? LogLevel::Debug : LogLevel::Info);
  if (const std::string error = checkOptions(o); !error.empty()) {
    std::cerr << "crumple-sim: error: " << error << "\n";
    return 2;
  }
  try {
    return run(o);
  } catch (const SceneError& e) {
    std::cerr << "crumple-sim: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "crumple-sim: failed: " << capText(escapeInvalidUtf8(e.what()), 1000) << "\n";
    return 1;
  }
}
