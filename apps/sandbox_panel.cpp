// crumple-sandbox's panel (imgui): what runs and how fast, the scene picker, and the materials', deformation's and
// renderer's settings, each section a function.
#include <filesystem>
#include <string>

#include <imgui.h>

#include <crumple/gl/gpu_timer.h>

#include "sandbox_app.h"

namespace crumple::sandbox {

namespace fs = std::filesystem;

namespace {
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

}  // namespace

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

}  // namespace crumple::sandbox
