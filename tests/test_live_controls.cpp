// The sandbox's panel changes a running simulation through these same calls:
// each material and deformation control must change the next dent.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <functional>

#include <crumple/engine/scene_view.h>
#include <crumple/engine/simulation.h>
#include "gl_fixture.h"

using namespace crumple;

namespace {

struct Dent {
  gl::Image map;
  double volume = 0;  // sum of (0.5 - h) over dented texels, map units
  int raised = 0;     // texels above 0.5
};

// Runs `scene` for `seconds` with `control` applied after the first step (as
// the panel does, live) and returns body `body`'s height map.
// `edit`: a change of the scene before it starts.
Dent run(const std::string& sceneName, const std::string& body, double seconds,
         const std::function<void(Simulation&)>& control, const std::function<void(Scene&)>& edit = nullptr) {
  test::glContext();
  const std::string dir = std::string(CRUMPLE_SCENES);
  Scene scene = loadScene(dir + "/" + sceneName + ".json");
  if (edit) edit(scene);
  Simulation sim(scene, true);
  sim.step();
  if (control) control(sim);
  const long steps = std::lround(seconds / scene.timestep);
  for (long i = 1; i < steps; ++i) sim.step();
  Dent d;
  for (const BodyRuntime& b : sim.bodies())
    if (b.name == body) d.map = b.surface->downloadHeight();
  REQUIRE(d.map.width > 0);
  for (float v : d.map.pixels) {
    if (v < 0.5f) d.volume += 0.5 - v;
    d.raised += v > 0.5f;
  }
  return d;
}

bool sameMap(const Dent& a, const Dent& b) { return a.map.pixels == b.map.pixels; }

// The simulation's deformation options with one change (as the panel makes them).
template <class Change>
deform::DeformOptions with(Simulation& sim, Change change) {
  deform::DeformOptions o = sim.deformationSettings().options;
  change(o);
  return o;
}

}  // namespace

TEST_CASE("every material and deformation control of the sandbox changes the next dent") {
  // A steel ball thrown onto a clay plate (the built-in default scene).
  const std::string s = "sphere-into-plate";
  const double t = 0.4;  // past the first impact
  const Dent base = run(s, "plate", t, nullptr);
  REQUIRE(base.volume > 10);
  auto material = [](const char* name) {
    return [name](Simulation& sim) -> Material& { return sim.sceneMaterials().at(name); };
  };
  SUBCASE("thickness") {
    const Dent d = run(s, "plate", t, [&](Simulation& sim) { material("clay")(sim).thickness *= 2; });
    CHECK(d.volume > base.volume * 1.5);
  }
  SUBCASE("kappa") {
    const Dent d = run(s, "plate", t, [&](Simulation& sim) { material("clay")(sim).kappa *= 2; });
    CHECK(d.volume > base.volume * 1.1);
  }
  SUBCASE("restitution (the yield threshold, equation 4)") {
    const Dent d = run(s, "plate", t, [&](Simulation& sim) { sim.setRestitution("clay", 0.9); });
    CHECK_FALSE(sameMap(d, base));
  }
  SUBCASE("k (bump depth): the same dent in metres is deeper in map units when k is smaller") {
    const Dent d = run(s, "plate", t, [&](Simulation& sim) { sim.setBumpDepths(0.05, 0.02); });
    CHECK(d.volume > base.volume * 1.5);
  }
  SUBCASE("address map") {
    const Dent d = run(s, "plate", t,
                       [&](Simulation& sim) { sim.setDeformOptions(with(sim, [](auto& o) { o.addressMap = 64; })); });
    CHECK_FALSE(sameMap(d, base));
    CHECK(d.volume == doctest::Approx(base.volume).epsilon(0.05));  // accuracy, not the dent, changes
  }
  SUBCASE("path") {
    const Dent d = run(s, "plate", t, [&](Simulation& sim) {
      sim.setDeformOptions(with(sim, [](auto& o) { o.path = deform::Path::Scatter; }));
    });
    CHECK_FALSE(sameMap(d, base));
  }
  SUBCASE("crater rims") {
    CHECK(base.raised == 0);
    const Dent d = run(s, "plate", t,
                       [&](Simulation& sim) { sim.setDeformOptions(with(sim, [](auto& o) { o.craterRims = true; })); });
    CHECK(d.raised > 20);
  }
  SUBCASE("impulse floor") {
    const Dent d = run(s, "plate", t, [&](Simulation& sim) { sim.deformationSettings().impulseFloor = 1e9; });
    CHECK(d.volume == 0.0);
  }
}

TEST_CASE("k' and normal-mapped collision normals change the print of a patterned stamp") {
  // A bronze box whose map carries raised spots strikes a plaster wall (figure 7).
  const std::string s = "pattern-box";
  const double t = 0.5;
  const Dent base = run(s, "wall", t, nullptr);
  REQUIRE(base.volume > 10);
  SUBCASE("k' (bump depth used in collisions): the spots reach deeper where dents are not felt") {
    // (A body whose dents are felt has k' = k: the next dent is cut from where the physics put the bodies.)
    auto paint = [](Scene& scene) {
      scene.deformation.feelDents = false;
      for (BodyDesc& b : scene.bodies) b.feelDents = false;
    };
    auto deeper = [](Simulation& sim) { sim.setBumpDepths(0.1, 0.08); };
    const Dent before = run(s, "wall", t, nullptr, paint);
    const Dent d = run(s, "wall", t, deeper, paint);
    CHECK(d.volume > before.volume * 1.05);
    const Dent felt = run(s, "wall", t, deeper);
    CHECK(sameMap(felt, base));
  }
  SUBCASE("normal-mapped collision normals") {
    const Dent d = run(s, "wall", t, [&](Simulation& sim) { sim.setNormalMappedNormals(true); });
    CHECK_FALSE(sameMap(d, base));
  }
}

TEST_CASE("a camera that follows a body keeps its offset from it, in world axes or turned with its heading") {
  test::glContext();
  Scene scene = loadScene(std::string(CRUMPLE_SCENES) + "/sphere-into-plate.json");
  CameraDesc world, heading;
  world.follow = heading.follow = "ball";
  world.position = heading.position = {-2, 1, 0.5};
  world.target = heading.target = {1, 0, 0};
  heading.followHeading = true;
  Simulation sim(scene, true);
  for (int i = 0; i < 60; ++i) sim.step();  // the ball has fallen, bounced and spun
  const RigidBody& ball = sim.world().body(sim.bodies()[1].index);
  const render::View v = cameraView(world, &sim);
  CHECK(glm::length(glm::dvec3(v.eye) - (ball.x + world.position)) < 1e-5);
  CHECK(glm::length(glm::dvec3(v.target) - (ball.x + world.target)) < 1e-5);
  // With the heading: the offset turns with the body's x projected on the ground, its height kept.
  const render::View h = cameraView(heading, &sim);
  const glm::dvec3 offset = glm::dvec3(h.eye) - ball.x;
  CHECK(offset.y == doctest::Approx(1.0).epsilon(1e-5));
  CHECK(glm::length(offset) == doctest::Approx(glm::length(heading.position)).epsilon(1e-5));
  glm::dvec3 fwd = glm::mat3_cast(ball.q) * glm::dvec3(1, 0, 0);
  fwd.y = 0;
  fwd = glm::normalize(fwd);
  CHECK(glm::dot(glm::dvec3(offset.x, 0, offset.z), fwd) == doctest::Approx(-2.0).epsilon(1e-4));
  // A fixed camera stays where the scene put it.
  const render::View f = cameraView(scene.cameras.front(), &sim);
  CHECK(glm::length(glm::dvec3(f.eye) - scene.cameras.front().position) < 1e-5);
}
