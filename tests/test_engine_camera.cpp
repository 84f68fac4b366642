// The default camera of a scene without cameras frames its moving bodies and where they will dent.
#include <doctest/doctest.h>

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

#include <crumple/engine/scene_view.h>
#include <crumple/engine/simulation.h>

using namespace crumple;

namespace {
// A ground, a wall, an imported car mesh driving at the wall from far away and a ball falling beside it.
const char* kScene = R"({
  "format": "crumple-scene/1", "name": "no-cameras", "duration": 3.0,
  "materials": {"steel": {"density": 7800}, "clay": {"density": 1500}},
  "bodies": [
    {"name": "ground", "shape": {"type": "box", "size": [80, 0.4, 80]}, "material": "clay", "static": true,
     "position": [0, -0.2, 0]},
    {"name": "wall", "shape": {"type": "box", "size": [0.5, 2, 6]}, "material": "clay", "static": true,
     "position": [0, 1, 0]},
    {"name": "car", "shape": {"type": "mesh", "file": "assets/car.obj"}, "material": "steel",
     "position": [-30, 0.8, 2], "velocity": [14, 0, 0]},
    {"name": "ball", "shape": {"type": "sphere", "radius": 0.4}, "material": "steel", "position": [-6, 4, -5]}
  ]
})";

// Where a world point lands in normalised device coordinates of `view` at `aspect` (w > 1: behind the eye).
glm::vec4 project(const render::View& view, float aspect, const glm::dvec3& p) {
  const glm::mat4 m = glm::perspective(glm::radians(view.fovDegrees), aspect, view.zNear, view.zFar) *
                      glm::lookAt(view.eye, view.target, view.up);
  const glm::vec4 c = m * glm::vec4(glm::vec3(p), 1.0f);
  return c.w > 0 ? glm::vec4(glm::vec3(c) / c.w, 0.0f) : glm::vec4(0, 0, 0, 2.0f);
}
bool inside(const glm::vec4& ndc) {
  return ndc.w == 0 && std::abs(ndc.x) < 1 && std::abs(ndc.y) < 1 && ndc.z > -1 && ndc.z < 1;
}
}  // namespace

TEST_CASE("default camera: a scene without cameras is framed on its moving bodies and where they will dent") {
  const Scene scene = parseScene(kScene, "no-cameras.json", CRUMPLE_SCENES);
  REQUIRE(scene.cameras.empty());
  Simulation sim(scene, false);
  const CameraDesc cam = defaultCamera(sim);
  CHECK(cam.name == "default");
  const render::View view = cameraView(cam, &sim);
  // A 3/4 view from above: the eye higher than the target, looking down about 30 degrees.
  const glm::vec3 d = glm::normalize(view.target - view.eye);
  MESSAGE("eye " << view.eye.x << " " << view.eye.y << " " << view.eye.z << ", target " << view.target.x << " "
                 << view.target.y << " " << view.target.z << ", looking down " << glm::degrees(std::asin(-d.y))
                 << " degrees");
  CHECK(std::asin(-d.y) == doctest::Approx(glm::radians(30.0)).epsilon(0.01));
  const render::View old = cameraView(CameraDesc{}, &sim);  // the view scenes without cameras had before
  int oldInside = 0;
  for (float aspect : {16.0f / 9.0f, 1.5f}) {
    for (const BodyRuntime& b : sim.bodies()) {
      const RigidBody& rb = sim.world().body(b.index);
      if (rb.isStatic) continue;
      CAPTURE(b.name);
      CAPTURE(aspect);
      CHECK(inside(project(view, aspect, rb.x)));
      oldInside += inside(project(old, aspect, rb.x));
    }
    // Where the car will dent (the wall's face in its path) and the ball (the ground under it).
    CHECK(inside(project(view, aspect, {-0.25, 1.0, 2.0})));
    CHECK(inside(project(view, aspect, {-6, 0, -5})));
  }
  CHECK(oldInside < 4);  // the old fixed view missed some of them
  // Fixed at the start: the same scene gives the same camera, and it does not look from inside a body.
  Simulation again(scene, false);
  const CameraDesc cam2 = defaultCamera(again);
  CHECK(cam2.position == cam.position);
  CHECK(cam2.target == cam.target);
  CHECK(cam.position.y > 2.0);
}

TEST_CASE("default camera: a scene of static bodies only is framed whole") {
  const Scene scene = parseScene(R"({"format": "crumple-scene/1", "name": "still",
    "materials": {"m": {}},
    "bodies": [{"name": "a", "shape": {"type": "box", "size": [2, 1, 2]}, "material": "m", "static": true,
                "position": [10, 0.5, 0]},
               {"name": "b", "shape": {"type": "sphere", "radius": 1}, "material": "m", "static": true,
                "position": [-10, 1, 0]}]})",
                                 "still.json", CRUMPLE_SCENES);
  Simulation sim(scene, false);
  const render::View view = cameraView(defaultCamera(sim), &sim);
  CHECK(inside(project(view, 16.0f / 9.0f, {10, 0.5, 0})));
  CHECK(inside(project(view, 16.0f / 9.0f, {-10, 1, 0})));
}
