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

using namespace crumple;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

struct App {
  Scene scene;
  std::string scenePath;  // empty: the built-in highway
  Overrides overrides;    // --set, applied to every scene loaded
  std::vector<std::string> sceneChoices;  // the picker: scene files beside the current one
  std::string status;     // the panel's last message (a scene loaded or saved, or why not)
  char saveAs[512] = "";
  std::unique_ptr<Simulation> sim;
  std::unique_ptr<render::Renderer> renderer;
  bool paused = false, stepOnce = false, follow = true, autopilot = false;
  float orbitYaw = 0.6f, orbitPitch = 0.35f, orbitDistance = 12.0f;
  glm::vec3 orbitTarget{0};
  double physicsMs = 0, deformMs = 0, renderMs = 0;
  long shots = 0;
  // The 3D view renders at quality.scale times the window's size and is scaled up to it; automatic by
  // default (render/auto_quality.h: the scale, then FXAA and self-shadowing, follow the frame time).
  render::AutoQuality quality;

  void reset() {
    sim = std::make_unique<Simulation>(scene, true);
    for (auto& v : sim->vehicles()) v.manual = !autopilot;
    if (scene.cameras.empty() && carBody() < 0) {
      // The orbit starts where a camera-less scene's default camera looks from (its moving bodies framed).
      const CameraDesc c = defaultCamera(*sim);
      const glm::dvec3 d = c.position - c.target;
      orbitTarget = glm::vec3(c.target);
      orbitDistance = static_cast<float>(std::clamp(glm::length(d), 2.0, 80.0));
      orbitYaw = static_cast<float>(std::atan2(d.z, d.x));
      orbitPitch = static_cast<float>(std::asin(std::clamp(d.y / glm::length(d), -1.0, 1.0)));
    }
  }

  // The scene picker: loads another scene (the --set overrides applied) and starts it; a bad one is reported
  // in the panel and the current scene stays.
  void load(const std::string& path);

  int carBody() { return sim->vehicles().empty() ? -1 : sim->vehicles().front().body; }

  render::View view() {
    render::View v;
    const int car = carBody();
    if (follow && car >= 0) {
      const glm::dmat4 m = sim->model(car);
      const glm::vec3 pos = glm::vec3(m[3]);
      const glm::vec3 fwd =
          glm::normalize(glm::vec3(m * glm::dvec4(1, 0, 0, 0)) * glm::vec3(1, 0, 1) + glm::vec3(1e-4f, 0, 0));
      v.eye = pos - fwd * 8.0f + glm::vec3(0, 3.5f, 0);
      v.target = pos + fwd * 2.0f;
    } else {
      if (car >= 0) orbitTarget = glm::vec3(sim->model(car)[3]);
      v.target = orbitTarget;
      v.eye = orbitTarget + orbitDistance * glm::vec3(std::cos(orbitPitch) * std::cos(orbitYaw), std::sin(orbitPitch),
                                                      std::cos(orbitPitch) * std::sin(orbitYaw));
    }
    if (!follow && !scene.cameras.empty() && car < 0) {
      v = cameraView(scene.cameras.front(), sim.get());
    }
    v.fovDegrees = 50;
    return v;
  }
};


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

// The panel's first lines: time, the stages' times, what was drawn, the car's speed.
void panelStatus(App& app) {
  ImGui::Text("t = %.2f s   step %ld", app.sim->world().time(), app.sim->steps());
  ImGui::Text("physics %.2f ms  deform %.2f ms  render %.2f ms", app.physicsMs, app.deformMs, app.renderMs);
  if (gl::GpuTimer* t = app.sim->renderTimer(); t && t->measured() > 0) {
    // The GPU's own time (timer queries, read a few frames behind): the CPU times above only issue the work.
    app.sim->gpuTimes(false);
    const Timings& tm = app.sim->timings();
    ImGui::Text("GPU: render %.2f ms a frame, deform %.2f ms a deformation", tm.renderGpuMs / t->measured(),
                tm.deformations ? tm.deformGpuMs / tm.deformations : 0.0);
  }
  ImGui::Text("%.1f fps", ImGui::GetIO().Framerate);
  ImGui::Text("view %d x %d (scale %.2f%s)", app.renderer->width(), app.renderer->height(), app.quality.scale,
              app.quality.enabled ? ", auto" : "");
  const render::RendererStats& rs = app.renderer->stats();
  ImGui::Text("bodies drawn %d (%d outside the view), shadow casters drawn %d", rs.drawn, rs.culled, rs.shadowCasters);
  ImGui::Text("collisions %zu  deformations %ld", app.sim->events().size(), app.sim->timings().deformations);
  if (!app.sim->vehicles().empty())
    ImGui::Text("speed %.1f km/h", app.sim->vehicles().front().vehicle.speed(app.sim->world()) * 3.6);
}

// The scene picker and saving the scene as the panel has it.
void panelScene(App& app) {
  if (!ImGui::CollapsingHeader("Scene")) return;
  const std::string current = app.scenePath.empty() ? "highway (built-in)" : fs::path(app.scenePath).filename().string();
  if (ImGui::BeginCombo("scene", current.c_str())) {
    if (ImGui::Selectable("highway (built-in)", app.scenePath.empty())) app.load("");
    for (const std::string& choice : app.sceneChoices)
      if (ImGui::Selectable(fs::path(choice).filename().string().c_str(), choice == app.scenePath)) app.load(choice);
    ImGui::EndCombo();
  }
  ImGui::InputText("save as", app.saveAs, sizeof app.saveAs);
  if (ImGui::Button("Save scene") && app.saveAs[0]) {
    try {
      saveScene(app, app.saveAs);
      app.status = std::string("saved ") + app.saveAs;
    } catch (const std::exception& e) {
      app.status = std::string("not saved: ") + e.what();
    }
  }
  if (!app.status.empty()) ImGui::TextWrapped("%s", app.status.c_str());
}

// Each material's kappa, restitution and thickness.
void panelMaterials(App& app) {
  if (!ImGui::CollapsingHeader("Materials", ImGuiTreeNodeFlags_DefaultOpen)) return;
  for (auto& [name, m] : app.sim->sceneMaterials()) {
    ImGui::PushID(name.c_str());
    ImGui::Text("%s", name.c_str());
    float kappa = static_cast<float>(m.kappa), eps = static_cast<float>(m.restitution),
          t = static_cast<float>(m.thickness);
    if (ImGui::SliderFloat("kappa", &kappa, 0.0f, 0.001f, "%.6f", ImGuiSliderFlags_Logarithmic)) m.kappa = kappa;
    if (ImGui::SliderFloat("eps", &eps, 0.0f, 1.0f)) app.sim->setRestitution(name, eps);
    if (ImGui::SliderFloat("thickness", &t, 0.001f, 1.0f)) m.thickness = t;
    ImGui::PopID();
  }
}

// The deformation's bump depths, address map, path and switches.
void panelDeformation(App& app) {
  if (!ImGui::CollapsingHeader("Deformation", ImGuiTreeNodeFlags_DefaultOpen)) return;
  auto& d = app.sim->deformationSettings();
  float k = static_cast<float>(d.bumpDepth), kc = static_cast<float>(d.bumpDepthCollide);
  bool changed = ImGui::SliderFloat("k (bump depth)", &k, 0.01f, 0.3f);
  changed |= ImGui::SliderFloat("k' (collide)", &kc, 0.0f, 0.1f);
  if (changed) app.sim->setBumpDepths(k, kc);
  static const int sizes[] = {256, 512, 1024, 2048};
  int current = 0;
  deform::DeformOptions o = d.options;
  for (int i = 0; i < 4; ++i)
    if (sizes[i] == o.addressMap) current = i;
  bool optionsChanged = false;
  if (ImGui::Combo("address map", &current,
                   "256\0"
                   "512\0"
                   "1024\0"
                   "2048\0")) {
    o.addressMap = sizes[current];
    optionsChanged = true;
  }
  int path = static_cast<int>(o.path);
  if (ImGui::Combo("path", &path, "gather\0scatter\0readback\0")) {
    o.path = static_cast<deform::Path>(path);
    optionsChanged = true;
  }
  bool bumpNormals = d.normalMappedNormals;
  if (ImGui::Checkbox("normal-mapped collision normals", &bumpNormals)) app.sim->setNormalMappedNormals(bumpNormals);
  optionsChanged |= ImGui::Checkbox("crater rims", &o.craterRims);
  if (optionsChanged) app.sim->setDeformOptions(o);
  float floor = static_cast<float>(d.impulseFloor);
  if (ImGui::SliderFloat("impulse floor", &floor, 0.0f, 5000.0f)) d.impulseFloor = floor;
}

// The renderer's parallax mode, view, light, antialiasing, shadows and scale.
void panelRenderer(App& app) {
  if (!ImGui::CollapsingHeader("Renderer", ImGuiTreeNodeFlags_DefaultOpen)) return;
  auto& s = app.renderer->settings();
  int mode = static_cast<int>(s.parallax), debug = static_cast<int>(s.debug);
  if (ImGui::Combo("parallax", &mode, "occlusion\0offset limited (paper)\0none\0"))
    s.parallax = static_cast<render::ParallaxMode>(mode);
  if (ImGui::Combo("view", &debug, "shaded\0height map\0normal map\0address map\0wireframe\0"))
    s.debug = static_cast<render::DebugView>(debug);
  bool iblOn = s.ibl;
  if (ImGui::Checkbox("sky light (IBL)", &iblOn)) s.ibl = iblOn;
  ImGui::SameLine();
  int aa = static_cast<int>(app.quality.antialias);
  ImGui::SetNextItemWidth(110);
  if (ImGui::Combo("antialiasing", &aa, "none\0FXAA\0MSAA 4x\0"))
    app.quality.antialias = static_cast<render::Antialias>(aa);
  ImGui::SliderFloat("exposure", &s.exposure, 0.1f, 3.0f, "%.2f", ImGuiSliderFlags_Logarithmic);
  ImGui::Checkbox("shadows", &s.shadows);
  ImGui::SameLine();
  ImGui::Checkbox("self-shadowing", &app.quality.wantSelfShadow);
  ImGui::Checkbox("simplified meshes", &s.simplified);
  if (ImGui::IsItemHovered())
    ImGui::SetTooltip("Draw large meshes with fewer triangles (at most 3 mm off the surface; dents stay in the maps)");
  ImGui::SliderInt("max steps", &s.maxSteps, 8, 128);
  if (ImGui::SliderFloat("render scale", &app.quality.scale, 0.25f, 1.0f)) app.quality.enabled = false;
  ImGui::SameLine();
  ImGui::Checkbox("auto", &app.quality.enabled);
  if (app.quality.shed() > 0)
    ImGui::TextDisabled("auto: %s shed to keep the frame rate", app.quality.shed() > 1 ? "FXAA and self-shadowing" : "FXAA");
}

void panel(App& app) {
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(330, 0), ImGuiCond_FirstUseEver);
  // Small windows (automated runs) start with the panel folded, out of the picture.
  ImGui::SetNextWindowCollapsed(app.renderer->width() < 800, ImGuiCond_FirstUseEver);
  ImGui::Begin("crumple");
  panelStatus(app);
  if (ImGui::Button(app.paused ? "Run" : "Pause")) app.paused = !app.paused;
  ImGui::SameLine();
  if (ImGui::Button("Step")) app.stepOnce = true;
  ImGui::SameLine();
  if (ImGui::Button("Reset")) app.reset();
  ImGui::SameLine();
  panelScene(app);
  ImGui::Checkbox("Autopilot", &app.autopilot);
  ImGui::Checkbox("Follow camera (C)", &app.follow);
  panelMaterials(app);
  panelDeformation(app);
  panelRenderer(app);
  ImGui::End();
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
  if (const auto rc = cli::parse(cli, argc, argv)) return *rc;
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
