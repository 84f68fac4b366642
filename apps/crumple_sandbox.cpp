// crumple-sandbox: drive a car into guard rails and watch the dents form.
// A GLFW window with the parallax-occlusion renderer and an imgui panel.
// Keys: W/S or Up/Down throttle and brake/reverse, A/D or Left/Right steer,
// Space hand-brake, C follow/orbit camera, P pause, N step, R reset, F12 screenshot,
// 1-5 debug views (shaded, height, normal, address map, wireframe), M parallax mode.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include <epoxy/gl.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include <crumple/engine/scene_view.h>
#include <crumple/engine/builtin_scenes.h>
#include <crumple/engine/output_writer.h>
#include <crumple/engine/overrides.h>
#include <crumple/engine/simulation.h>
#include <crumple/core/log.h>
#include <crumple/core/version.h>
#include <crumple/render/auto_quality.h>
#include <crumple/gl/capture.h>
#include <crumple/gl/context.h>
#include <crumple/render/renderer.h>

#include "cli.h"
#include "sandbox_app.h"

using namespace crumple;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using namespace crumple::sandbox;

namespace crumple::sandbox {

// Loads `path` (empty: the built-in highway) with the --set overrides.
Scene loadAppScene(const std::string& path, const Overrides& overrides) {
  if (!path.empty()) return loadScene(path, overrides);
  if (!overrides.empty())
    throw SceneError("<built-in>", "", "--set needs a scene file (the built-in highway takes no overrides)");
  return builtinHighway();
}

// The scene files in the current scene's folder (the shipped scenes/ when the sandbox was started on one).
std::vector<std::string> sceneChoices(const std::string& current) {
  std::vector<std::string> out;
  if (current.empty()) return out;
  std::error_code ec;
  const fs::path dir = fs::absolute(current, ec).parent_path();
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().extension() == ".json") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

// The scene as the panel has it now: its file (or the built-in text) with every value the panel edits set, mesh
// and image paths made to work from the new file's folder (the built-in's meshes are copied beside it). Written
// to a temporary file and renamed: a failed save leaves no half-written file.
void saveScene(const App& app, const std::string& target) {
  const std::string text = app.scenePath.empty() ? builtinSceneText("highway") : [&] {
    std::ifstream f(app.scenePath, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  }();
  nlohmann::json doc = nlohmann::json::parse(text);
  const std::string file = app.scenePath.empty() ? "<built-in>" : app.scenePath;
  applyOverrides(doc, app.overrides, file);
  Overrides edits;
  auto num = [](double v) {
    std::ostringstream os;
    os.precision(17);
    os << v;
    return os.str();
  };
  for (const auto& [name, m] : app.sim->sceneMaterials()) {
    const std::string key = "materials[" + nlohmann::json(name).dump() + "].";
    edits.push_back({key + "kappa", num(m.kappa)});
    edits.push_back({key + "restitution", num(m.restitution)});
    edits.push_back({key + "thickness", num(m.thickness)});
  }
  const DeformationSettings& d = app.sim->scene().deformation;
  edits.push_back({"deformation.bump_depth", num(d.bumpDepth)});
  edits.push_back({"deformation.bump_depth_collide", num(d.bumpDepthCollide)});
  edits.push_back({"deformation.address_map", std::to_string(d.options.addressMap)});
  edits.push_back({"deformation.path", nlohmann::json(deform::pathName(d.options.path)).dump()});
  edits.push_back({"deformation.crater_rims", d.options.craterRims ? "true" : "false"});
  edits.push_back({"deformation.impulse_floor", num(d.impulseFloor)});
  edits.push_back({"deformation.normal_mapped_normals", d.normalMappedNormals ? "true" : "false"});
  applyOverrides(doc, edits, file);
  const fs::path out = fs::absolute(target);
  const fs::path dir = out.parent_path();
  fs::create_directories(dir);
  for (size_t i = 0; i < app.scene.bodies.size() && i < doc["bodies"].size(); ++i) {
    const BodyDesc& b = app.scene.bodies[i];
    auto relocate = [&](const std::string& resolved) {
      if (!app.scenePath.empty()) return fs::relative(resolved, dir).string();
      fs::create_directories(dir / "assets");
      const fs::path copy = dir / "assets" / fs::path(resolved).filename();
      fs::copy_file(resolved, copy, fs::copy_options::overwrite_existing);
      return ("assets" / fs::path(resolved).filename()).string();
    };
    if (b.shape.type == "mesh") doc["bodies"][i]["shape"]["file"] = relocate(b.shape.file);
    if (!b.bumpMap.image.empty()) doc["bodies"][i]["bump_map"]["image"] = relocate(b.bumpMap.image);
  }
  const fs::path tmp = out.string() + ".partial";
  {
    std::ofstream f(tmp);
    f << doc.dump(1) << "\n";
    if (!f) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, out);
}

void App::load(const std::string& path) {
  try {
    Scene next = loadAppScene(path, overrides);
    scene = std::move(next);
    scenePath = path;
    reset();
    status = "loaded " + (path.empty() ? std::string("the built-in highway") : path);
  } catch (const std::exception& e) {
    status = std::string("not loaded: ") + e.what();
  }
}

}  // namespace crumple::sandbox

namespace {

void drive(App& app, GLFWwindow* w) {
  if (app.autopilot) return;
  for (auto& v : app.sim->vehicles()) {
    auto key = [&](int a, int b) { return glfwGetKey(w, a) == GLFW_PRESS || glfwGetKey(w, b) == GLFW_PRESS; };
    VehicleControls c;
    const double speed = v.vehicle.speed(app.sim->world());
    if (key(GLFW_KEY_W, GLFW_KEY_UP)) c.throttle = 1;
    if (key(GLFW_KEY_S, GLFW_KEY_DOWN)) {
      if (speed > 0.5)
        c.brake = 1;
      else
        c.throttle = -0.5;
    }
    if (key(GLFW_KEY_A, GLFW_KEY_LEFT)) c.steer += 1;
    if (key(GLFW_KEY_D, GLFW_KEY_RIGHT)) c.steer -= 1;
    c.handbrake = glfwGetKey(w, GLFW_KEY_SPACE) == GLFW_PRESS;
    v.manual = true;
    v.controls = c;
  }
}

// The command line.
struct Options {
  std::string scenePath, screenshot, outDir, saveScenePath, renderScale = "auto", antialias = "fxaa";
  long frames = 0;
  int width = 1280, height = 720;
  bool autopilot = false, quiet = false;
  std::vector<std::string> sets;
};

void addOptions(CLI::App& cli, Options& o) {
  cli.add_option("scene", o.scenePath, "Scene file; without one, the built-in highway scene");
  cli::addSets(cli, o.sets);
  cli.add_option("--save-scene", o.saveScenePath,
                 "On exit, write the scene as the panel has it (materials, deformation settings) to this file");
  cli.add_option("--frames", o.frames, "Run this many frames (1/60 s of simulation each), then exit")
      ->check(CLI::Range(0L, 10000000L));
  cli.add_flag("--autopilot", o.autopilot, "Drive by the scene's vehicle script (a drive into the rails)");
  cli.add_option("--screenshot", o.screenshot, "Write the last frame to this PNG on exit");
  cli.add_option("--out", o.outDir, "Write crumple-sim's outputs (summary, events, maps) here on exit");
  cli.add_option("--width", o.width, "Window width")->check(CLI::Range(64, 8192));
  cli.add_option("--height", o.height, "Window height")->check(CLI::Range(64, 8192));
  cli::addQuiet(cli, o.quiet);
  cli::addAntialias(cli, o.antialias,
                    "fxaa (default: an FXAA pass over the 3D view), msaa (4 samples a pixel; on a GPU) or none");
  cli.add_option("--render-scale", o.renderScale,
                 "The 3D view's resolution as a fraction of the window's (0.25 to 1), or 'auto': while a frame takes "
                 "over 30 ms (software GL) the scale falls to 0.35, then FXAA and parallax self-shadowing are shed, then "
                 "the scale falls on to 0.25; below 18 ms each comes back in reverse order")
      ->capture_default_str();
  cli::addVersion(cli, "crumple-sandbox");
}

// The window's loop: input, fixed steps, the 3D view, the panel and screenshots, a frame at a time; and what it
// measured.
class WindowLoop {
 public:
  WindowLoop(App& app, gl::WindowContext& window, const Options& o)
      : app_(app), window_(window), o_(o),
        stepsPerFrame_(std::max(1, static_cast<int>(std::lround(kFrameTime / app.scene.timestep)))) {}
  // Until the window closes or --frames are done.
  void run() {
    loopStart_ = frameStart_ = secondHalf_ = last_ = Clock::now();
    while (!window_.shouldClose() && (o_.frames == 0 || frame_ < o_.frames)) {
      window_.pollEvents();
      input();
      advance();
      int fw = 0, fh = 0;
      drawView(fw, fh);
      drawPanel(fw, fh);
      window_.swapBuffers();
      ++frame_;
      if (o_.frames && frame_ == o_.frames / 2) secondHalf_ = Clock::now();
    }
  }
  void report() const {
    const double loopSeconds = std::chrono::duration<double>(Clock::now() - loopStart_).count();
    // --frames runs: the frame rate over the second half too (the automatic scale has settled by then).
    const double lateSeconds = std::chrono::duration<double>(Clock::now() - secondHalf_).count();
    char late[64] = "";
    if (o_.frames >= 20 && frame_ == o_.frames && lateSeconds > 0)
      std::snprintf(late, sizeof late, " (%.1f over the second half)", (o_.frames - o_.frames / 2) / lateSeconds);
    auto perFrame = [&](double ms) { return frame_ ? ms / double(frame_) : 0.0; };
    const render::AutoQuality& q = app_.quality;
    std::printf(
        "crumple-sandbox: %ld frames, %ld steps, %zu collisions, %ld deformations; a frame: physics %.1f ms, "
        "deformation %.1f, render %.1f (view scale %.2f%s at the end), the rest (panel, upscale, swap) %.1f; "
        "%.1f fps%s\n",
        frame_, app_.sim->steps(), app_.sim->events().size(), app_.sim->timings().deformations,
        perFrame(physicsTotal_), perFrame(deformTotal_), perFrame(renderTotal_), q.scale,
        q.shed() == 2 ? ", FXAA and self-shadowing shed" : q.shed() == 1 ? ", FXAA shed" : "",
        perFrame(loopSeconds * 1e3 - physicsTotal_ - deformTotal_ - renderTotal_),
        loopSeconds > 0 ? frame_ / loopSeconds : 0.0, late);
  }

 private:
  static constexpr double kFrameTime = 1.0 / 60.0;
  // True on the frame a key goes down.
  bool pressed(int key) {
    const bool down = glfwGetKey(window_.window(), key) == GLFW_PRESS;
    const bool edge = down && !prevKeys_[key];
    prevKeys_[key] = down;
    return edge;
  }
  // Keys (not while the panel takes them), the car's controls, the orbit camera's mouse.
  void input() {
    if (!ImGui::GetIO().WantCaptureKeyboard) {
      if (pressed(GLFW_KEY_C)) app_.follow = !app_.follow;
      if (pressed(GLFW_KEY_P)) app_.paused = !app_.paused;
      if (pressed(GLFW_KEY_N)) app_.stepOnce = true;
      if (pressed(GLFW_KEY_R)) app_.reset();
      if (pressed(GLFW_KEY_M)) {
        auto& p = app_.renderer->settings().parallax;
        p = static_cast<render::ParallaxMode>((static_cast<int>(p) + 1) % 3);
      }
      for (int k = 0; k < 5; ++k)
        if (pressed(GLFW_KEY_1 + k)) app_.renderer->settings().debug = static_cast<render::DebugView>(k);
      drive(app_, window_.window());
    }
    if (!app_.follow && ImGui::IsMouseDragging(ImGuiMouseButton_Left) && !ImGui::GetIO().WantCaptureMouse) {
      const ImVec2 d = ImGui::GetIO().MouseDelta;
      app_.orbitYaw += d.x * 0.005f;
      app_.orbitPitch = std::clamp(app_.orbitPitch + d.y * 0.005f, -0.1f, 1.5f);
    }
    if (!ImGui::GetIO().WantCaptureMouse)
      app_.orbitDistance = std::clamp(app_.orbitDistance - ImGui::GetIO().MouseWheel, 2.0f, 80.0f);
    for (auto& v : app_.sim->vehicles()) v.manual = !app_.autopilot;
  }
  // Fixed steps: in --frames runs exactly one frame's worth; interactively, real time.
  void advance() {
    const auto now = Clock::now();
    accumulator_ += o_.frames ? kFrameTime : std::min(0.1, std::chrono::duration<double>(now - last_).count());
    last_ = now;
    int steps = 0;
    if (app_.paused) {
      accumulator_ = 0;
      if (app_.stepOnce) steps = 1;
    } else {
      steps = static_cast<int>(accumulator_ / app_.scene.timestep);
      if (o_.frames) steps = stepsPerFrame_;
      accumulator_ -= steps * app_.scene.timestep;
    }
    app_.stepOnce = false;
    const double p0 = app_.sim->timings().physicsMs, d0 = app_.sim->timings().deformMs;
    for (int s = 0; s < steps; ++s) app_.sim->step();
    physicsTotal_ += app_.sim->timings().physicsMs - p0;
    deformTotal_ += app_.sim->timings().deformMs - d0;
    if (steps) {
      app_.physicsMs = (app_.sim->timings().physicsMs - p0) / steps;
      app_.deformMs = app_.sim->timings().deformMs - d0;
    }
  }
  // The 3D view at the quality's scale, scaled up into the window (fw x fh).
  void drawView(int& fw, int& fh) {
    window_.framebufferSize(fw, fh);
    const int sw = std::max(1, static_cast<int>(std::lround(fw * app_.quality.scale)));
    const int sh = std::max(1, static_cast<int>(std::lround(fh * app_.quality.scale)));
    if (fw > 0 && fh > 0) app_.renderer->resize(sw, sh);
    if (app_.sim->deformer()) app_.renderer->settings().addressMap = app_.sim->deformer()->lastAddressMap().id();
    app_.quality.apply(app_.renderer->settings());
    app_.renderMs = drawFrame(*app_.sim, *app_.renderer, app_.view());
    ++app_.sim->timings().frames;
    glBlitNamedFramebuffer(app_.renderer->framebuffer(), 0, 0, 0, sw, sh, 0, 0, fw, fh, GL_COLOR_BUFFER_BIT,
                           sw == fw && sh == fh ? GL_NEAREST : GL_LINEAR);
    const auto frameEnd = Clock::now();
    app_.quality.frame(std::chrono::duration<double, std::milli>(frameEnd - frameStart_).count());
    frameStart_ = frameEnd;
    renderTotal_ += app_.renderMs;
  }
  // The panel over the view; a screenshot on F12 (and of the last frame with --screenshot).
  void drawPanel(int fw, int fh) {
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    panel(app_);
    ImGui::Render();
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    const bool last = o_.frames && frame_ + 1 == o_.frames;
    if (pressed(GLFW_KEY_F12) || (last && !o_.screenshot.empty())) {
      const std::string path =
          last && !o_.screenshot.empty() ? o_.screenshot : "crumple-shot-" + std::to_string(app_.shots++) + ".png";
      gl::captureToPng(0, fw, fh, path);
      logInfo("screenshot: ", path);
    }
  }

  App& app_;
  gl::WindowContext& window_;
  const Options& o_;
  const int stepsPerFrame_;
  double accumulator_ = 0;
  long frame_ = 0;
  Clock::time_point last_, loopStart_, frameStart_, secondHalf_;
  double physicsTotal_ = 0, deformTotal_ = 0, renderTotal_ = 0;  // ms over the loop
  bool prevKeys_[512] = {};
};

// The window, the loop, then what is asked on exit (--save-scene, --out, the report).
int run(App& app, const Options& o) {
  std::unique_ptr<OutputWriter> writer;
  if (!o.outDir.empty()) writer = std::make_unique<OutputWriter>(o.outDir);
  gl::WindowOptions wo;
  wo.width = o.width;
  wo.height = o.height;
  wo.title = "crumple sandbox: " + app.scene.name;
  wo.vsync = o.frames == 0;
  wo.debug = false;
  gl::WindowContext window(wo);
  logInfo("GL: ", window.description());
  app.reset();
  app.renderer = std::make_unique<render::Renderer>(o.width, o.height);
  app.quality.antialias = render::antialiasNamed(o.antialias);
  app.renderer->settings().simplified = true;  // interactive: large meshes drawn simplified (panel)
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui_ImplGlfw_InitForOpenGL(window.window(), true);
  ImGui_ImplOpenGL3_Init("#version 450");
  WindowLoop loop(app, window, o);
  loop.run();
  if (!o.saveScenePath.empty()) {
    saveScene(app, o.saveScenePath);
    logInfo("scene saved: ", o.saveScenePath);
  }
  if (writer) {
    writer->write(*app.sim);
    writer->commit();
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  if (!o.quiet) loop.report();
  app.sim.reset();
  app.renderer.reset();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"crumple-sandbox: drive a car into guard rails and watch the dents form (GLFW window, imgui panel)."};
  Options o;
  addOptions(cli, o);
  if (const auto rc = cli::parse(cli, "crumple-sandbox", argc, argv)) return *rc;
  setLogLevel(o.quiet ? LogLevel::Error : LogLevel::Info);
  App app;
  if (o.renderScale != "auto") {
    char* end = nullptr;
    const double value = std::strtod(o.renderScale.c_str(), &end);
    if (end == o.renderScale.c_str() || *end != '\0' || !(value >= 0.25 && value <= 1.0)) {
      std::cerr << "crumple-sandbox: error: --render-scale: expected a number in [0.25, 1] or 'auto', got '"
                << o.renderScale << "'\n";
      return 2;
    }
    app.quality.scale = static_cast<float>(value);
    app.quality.enabled = false;
  }
  try {
    app.overrides = cli::overridesOf(o.sets);
    app.scene = loadAppScene(o.scenePath, app.overrides);
    app.scenePath = o.scenePath;
    app.sceneChoices = sceneChoices(o.scenePath);
  } catch (const SceneError& e) {
    std::cerr << "crumple-sandbox: error: " << e.what() << "\n";
    return 2;
  }
  app.autopilot = o.autopilot;
  try {
    return run(app, o);
  } catch (const SceneError& e) {
    std::cerr << "crumple-sandbox: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "crumple-sandbox: failed: " << e.what() << "\n";
    return 1;
  }
}
