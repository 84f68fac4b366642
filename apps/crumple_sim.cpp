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
}  // namespace

int main(int argc, char** argv) {
  // From the start: a signal while the scene loads ends the run at once (nothing is written before the loop).
  installSignalHandlers();
  CLI::App app{
      "crumple-sim: run a crumple scene headless and write its outputs (summary.json, events.jsonl, "
      "heightmaps/, normalmaps/, frames/)."};
  std::string scenePath, outDir, deformPath, trace, size = "960x540", exportFormat, video, videoCamera;
  std::string antialias = "fxaa", shading = "auto";
  double duration = -1, fps = 30;
  long steps = -1;
  int gpu = -1, threads = -1;
  std::vector<std::string> sets;
  bool renderFrames = false, quiet = false, verbose = false, animate = false;
  bool displace = false;
  app.add_option("scene", scenePath,
                 "Scene file (JSON). Without one, the built-in default scene (sphere into plate) runs.");
  app.add_option("--out,-o", outDir, "Output folder (default: out/<scene name>). Written atomically.");
  app.add_option("--duration", duration, "Simulated seconds, overriding the scene's duration")
      ->check(CLI::Range(1e-6, 1e6));
  app.add_option("--steps", steps, "Number of steps, overriding duration")->check(CLI::Range(1L, 100000000L));
  app.add_option("--deform-path", deformPath,
                 "gather (default: every texel of a dent gathers its depth on the GPU, no gaps), scatter (the paper's "
                 "update on the GPU) or readback (the paper's path: address maps read back, CPU scatter)")
      ->check(CLI::IsMember({"gather", "scatter", "readback", "gpu"}));
  app.add_flag("--render", renderFrames, "Write frames/<camera>_<frame>.png for every camera of the scene");
  app.add_option("--size", size, "Frame size WxH for --render")->default_val("960x540");
  app.add_flag("--displace", displace,
               "Draw every camera with displacement (dents change silhouettes; tessellation shaders), as a camera's "
               "\"displace\": true does for that camera");
  app.add_option("--antialias", antialias,
                 "Antialiasing of the rendered frames: fxaa (default: an FXAA pass over each frame), msaa (4 "
                 "samples a pixel, resolved; slower on a CPU rasteriser) or none")
      ->check(CLI::IsMember({"fxaa", "msaa", "none"}))
      ->capture_default_str();
  app.add_option("--shading", shading,
                 "Where the rendered frames' pixels are shaded: auto (default: compute on GPUs whose graphics stages "
                 "run on a few multiprocessors, such as NVIDIA's H100, else fragment), fragment (as the items are "
                 "drawn) or compute (from a visibility buffer, once a pixel; not with MSAA or displacement)")
      ->check(CLI::IsMember({"auto", "fragment", "compute"}))
      ->capture_default_str();
  app.add_option("--fps", fps, "Frames per simulated second for --render")
      ->check(CLI::Range(0.01, 1000.0))
      ->default_val(30);
  app.add_option("--set", sets,
                 "KEY=VALUE: change a value of the scene before it is checked (repeatable). KEY is a key path as "
                 "the errors write it (materials.clay.kappa, bodies[ball].velocity), VALUE is JSON")
      ->allow_extra_args(false);
  app.add_option("--gpu", gpu,
                 "Use this EGL device (0 = the first hardware GPU; default: CRUMPLE_EGL_DEVICE, else the first GPU, "
                 "else software)")
      ->check(CLI::Range(0, 1023));
  app.add_option("--threads", threads,
                 "Threads of the physics step, overriding the scene's threads (0: the hardware's); the results are "
                 "the same bits for every count")
      ->check(CLI::Range(0, 256));
  app.add_option("--trace", trace, "Write every body's state per step to this CSV file");
  auto* exportOption = app.add_option("--export", exportFormat,
                 "gltf: also write export/scene.gltf (every body at its final pose, its atlas, normal and height maps)")
      ->check(CLI::IsMember({"gltf"}));
  auto* animateOption = app.add_flag("--animate", animate,
                                     "With --export gltf: animate the export with the bodies' motion, a key frame per "
                                     "--fps frame, so a glTF viewer plays the run");
  animateOption->needs(exportOption);
  app.add_option("--video", video,
                 "Encode one camera's frames into this video file (e.g. run.mp4) with ffmpeg; implies --render");
  app.add_option("--video-camera", videoCamera, "The camera for --video (default: the scene's first camera)");
  app.add_flag("--quiet,-q", quiet, "Only errors");
  app.add_flag("--verbose,-v", verbose, "Debug messages (GL debug output included)");
  app.set_version_flag("--version", std::string("crumple-sim ") + versionString());
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;  // bad command-line input is bad input: exit 2
  }

  setLogLevel(quiet ? LogLevel::Error : verbose ? LogLevel::Debug : LogLevel::Info);
  std::string ffmpeg;
  if (!videoCamera.empty() && video.empty()) {
    std::cerr << "crumple-sim: error: --video-camera needs --video\n";
    return 2;
  }
  if (!video.empty()) {
    ffmpeg = findOnPath("ffmpeg");
    if (ffmpeg.empty()) {
      std::cerr << "crumple-sim: error: --video needs ffmpeg (apt-get install ffmpeg)\n";
      return 2;
    }
    const fs::path parent = fs::absolute(video).parent_path();
    if (!fs::is_directory(parent)) {
      std::cerr << "crumple-sim: error: " << video << ": --video: the folder " << parent.string()
                << " does not exist\n";
      return 2;
    }
    renderFrames = true;
  }
  int width = 0, height = 0;
  if (std::sscanf(size.c_str(), "%dx%d", &width, &height) != 2 || width < 16 || height < 16 || width > 8192 ||
      height > 8192) {
    std::cerr << "crumple-sim: --size must be WxH with sides in [16, 8192], got '" << size << "'\n";
    return 2;
  }
  try {
    Overrides overrides;
    for (const std::string& s : sets) overrides.push_back(parseOverride(s));
    Scene scene = scenePath.empty() ? parseScene(builtinSceneText(), "<built-in default scene>",
                                                 fs::current_path().string(), overrides)
                                    : loadScene(scenePath, overrides);
    if (deformPath == "gather" || deformPath == "gpu") scene.deformation.options.path = deform::Path::Gather;
    if (deformPath == "scatter") scene.deformation.options.path = deform::Path::Scatter;
    if (deformPath == "readback") scene.deformation.options.path = deform::Path::Readback;
    if (duration > 0) scene.duration = duration;
    if (threads >= 0) scene.threads = threads;
    const long totalSteps = steps > 0 ? steps : std::max(1L, std::lround(scene.duration / scene.timestep));
    if (outDir.empty()) outDir = "out/" + scene.name;
    // --video: the camera whose frames are encoded (checked before the run).
    if (!video.empty()) {
      if (videoCamera.empty()) videoCamera = scene.cameras.empty() ? "default" : scene.cameras.front().name;
      bool known = scene.cameras.empty() && videoCamera == "default";
      for (const auto& c : scene.cameras) known = known || c.name == videoCamera;
      if (!known)
        throw SceneError(scenePath.empty() ? scene.file : scenePath, "cameras",
                         "--video-camera: no camera named '" + quoteText(videoCamera) + "'");
    }
    OutputWriter writer(outDir);
    GltfAnimation animation;
    writer.setExportGltf(exportFormat == "gltf", animate ? &animation : nullptr);

    bool needGl = renderFrames;
    for (const auto& b : scene.bodies) needGl = needGl || b.bumpMap.present;
    std::unique_ptr<gl::GlContext> gl;
    if (needGl) {
      try {
        gl::HeadlessOptions glOptions;
        glOptions.debug = verbose;
        glOptions.device = gpu;
        gl = gl::createHeadlessContext(glOptions);
      } catch (const gl::ContextError& e) {
        std::cerr << "crumple-sim: " << e.what() << "\n";
        return 1;
      }
      logInfo("GL: ", gl->description());
    }
    Simulation sim(scene, gl != nullptr);
    // Loaded: from here a signal is noted and the loop stops at the next step, removing the staging folder.
    gLoading = 0;
    writer.begin();
    std::unique_ptr<render::Renderer> renderer;
    const fs::path framesDir = fs::path(writer.staging()) / "frames";
    if (renderFrames) {
      if (scene.cameras.empty()) logInfo("--render: the scene has no cameras; a default view frames its moving bodies");
      renderer = std::make_unique<render::Renderer>(width, height);
      renderer->settings().displace = displace;
      renderer->settings().antialias = render::antialiasNamed(antialias);
      renderer->settings().shading = shading == "compute"    ? render::Shading::Compute
                                     : shading == "fragment" ? render::Shading::Forward
                                                             : render::Shading::Auto;
      fs::create_directories(framesDir);
    }
    auto interrupted = [&](long step) {
      writer.abandon();
      std::cerr << "\ncrumple-sim: interrupted at step " << step << ": nothing written\n";
      return 130;
    };
    std::ofstream traceFile;
    if (!trace.empty()) {
      traceFile.open(trace);
      if (!traceFile) throw SceneError(trace, "", "--trace: cannot be opened for writing");
      traceFile << "step,time,body,x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz\n";
      traceFile.precision(10);
    }
    const bool tty = !quiet && isatty(STDERR_FILENO);
    const long frameEvery = std::max(1L, std::lround(1.0 / (fps * scene.timestep)));
    long frame = 0;
    // Without cameras: one framing the moving bodies and where they will dent, fixed at the start.
    const CameraDesc fallbackCamera = defaultCamera(sim);
    auto renderFrame = [&]() {
      std::vector<CameraDesc> cams = scene.cameras;
      if (cams.empty()) cams.push_back(fallbackCamera);
      for (const auto& cam : cams) {
        char name[64];
        std::snprintf(name, sizeof name, "_%05ld.png", frame);
        drawFrame(sim, *renderer, cameraView(cam, &sim));
        renderer->savePng((framesDir / (cam.name + name)).string());
      }
      ++frame;
      ++sim.timings().frames;
    };
    if (renderer) renderFrame();
    if (animate) animation.record(sim);
    for (long s = 1; s <= totalSteps; ++s) {
      if (gInterrupted) return interrupted(s - 1);
      sim.step();
      if (renderer && s % frameEvery == 0) renderFrame();
      if (animate && (s % frameEvery == 0 || s == totalSteps)) animation.record(sim);
      if (traceFile.is_open()) {
        for (const auto& b : sim.bodies()) {
          const RigidBody& rb = sim.world().body(b.index);
          const glm::dvec3 o = rb.origin();
          traceFile << s << "," << sim.world().time() << "," << b.name << "," << o.x << "," << o.y << "," << o.z << ","
                    << rb.q.w << "," << rb.q.x << "," << rb.q.y << "," << rb.q.z << "," << rb.v.x << "," << rb.v.y
                    << "," << rb.v.z << "," << rb.w.x << "," << rb.w.y << "," << rb.w.z << "\n";
        }
      }
      if (tty && (s % 16 == 0 || s == totalSteps)) {
        const int width = 30, filled = static_cast<int>(width * s / totalSteps);
        std::fprintf(stderr, "\r[%.*s%*s] %3ld%%  step %ld/%ld  collisions %zu", filled,
                     "##############################", width - filled, "", 100 * s / totalSteps, s, totalSteps,
                     sim.events().size());
        if (s == totalSteps) std::fprintf(stderr, "\n");
      }
    }
    if (gInterrupted) return interrupted(totalSteps);
    writer.write(sim);
    if (!video.empty()) {
      // Into a temporary file beside it (same extension: ffmpeg picks the format from it), renamed when done.
      const fs::path target = fs::absolute(video);
      const fs::path tmp = target.parent_path() / ("." + target.stem().string() + ".partial-" +
                                                   std::to_string(::getpid()) + target.extension().string());
      const double frameRate = 1.0 / (static_cast<double>(frameEvery) * scene.timestep);
      std::vector<std::string> args = {ffmpeg, "-nostdin", "-y", "-loglevel", "error", "-framerate",
                                        std::to_string(frameRate), "-i",
                                        (framesDir / (videoCamera + "_%05d.png")).string()};
      std::string ext = target.extension().string();
      for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (ext == ".mp4" || ext == ".mov" || ext == ".mkv")  // H.264 needs even sides; yuv420p plays everywhere
        args.insert(args.end(), {"-c:v", "libx264", "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"});
      args.push_back(tmp.string());
      const int rc = runProgram(args);
      std::error_code ec;
      if (rc != 0) {
        fs::remove(tmp, ec);
        throw std::runtime_error("--video: ffmpeg " + (rc < 0 ? std::string("could not be run") :
                                                        "exited with status " + std::to_string(rc)) +
                                 " encoding " + video);
      }
      fs::rename(tmp, target, ec);
      if (ec) {
        fs::remove(tmp, ec);
        throw std::runtime_error(video + ": cannot write the video: " + ec.message());
      }
    }
    writer.commit();
    if (!quiet) {
      long sides = 0;
      for (const auto& r : sim.events()) sides += r.side[0].deformed + r.side[1].deformed;
      std::printf("crumple-sim: %s: %ld steps (%.3f s), %zu collisions, %ld deformations (%ld sides); wrote %s\n",
                  scene.name.c_str(), sim.steps(), sim.world().time(), sim.events().size(), sim.timings().deformations,
                  sides, outDir.c_str());
    }
    return 0;
  } catch (const SceneError& e) {
    std::cerr << "crumple-sim: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "crumple-sim: failed: " << capText(escapeInvalidUtf8(e.what()), 1000) << "\n";
    return 1;
  }
}
