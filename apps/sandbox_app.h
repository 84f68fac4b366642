// crumple-sandbox's state (App) and what its parts share: the scene loaded and saved (crumple_sandbox.cpp), the
// panel (sandbox_panel.cpp).
#pragma once
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include <crumple/engine/overrides.h>
#include <crumple/engine/scene.h>
#include <crumple/engine/scene_view.h>
#include <crumple/engine/simulation.h>
#include <crumple/render/auto_quality.h>
#include <crumple/render/renderer.h>

namespace crumple::sandbox {

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
Scene loadAppScene(const std::string& path, const Overrides& overrides);
// The scene files in the current scene's folder (the shipped scenes/ when the sandbox was started on one).
std::vector<std::string> sceneChoices(const std::string& current);
// The scene as the panel has it now, written to `target`.
void saveScene(const App& app, const std::string& target);
// The imgui panel: times, the scene picker, materials, deformation and renderer settings.
void panel(App& app);

}  // namespace crumple::sandbox
