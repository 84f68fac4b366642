// hello-dent: a steel ball thrown onto a clay plate leaves a dent in the plate's height map.
// Dents are computed on the GPU, so this needs an OpenGL 4.5 context; without a GPU, Mesa's llvmpipe
// gives one (EGL, no window, no display).
#include <algorithm>
#include <cstdio>
#include <exception>

#include <crumple/engine/scene.h>
#include <crumple/engine/simulation.h>
#include <crumple/gl/context.h>

// A scene in crumple's scene format (the same JSON that crumple-sim reads from a file).
const char* kScene = R"({
  "format": "crumple-scene/1",
  "name": "hello-dent",
  "timestep": 0.0041666667,
  "duration": 0.5,
  "materials": {
    "clay":  {"density": 1800, "restitution": 0.2,  "friction": 0.8, "kappa": 0.00006, "thickness": 0.05},
    "steel": {"density": 7800, "restitution": 0.95, "friction": 0.4, "kappa": 0.00006, "thickness": 0.01}
  },
  "bodies": [
    {"name": "plate", "shape": {"type": "box", "size": [2, 0.2, 2]}, "material": "clay",
     "static": true, "position": [0, -0.1, 0], "bump_map": {"resolution": 256}},
    {"name": "ball", "shape": {"type": "sphere", "radius": 0.25}, "material": "steel",
     "position": [0, 0.6, 0], "velocity": [0, -6, 0], "bump_map": {"resolution": 128}}
  ]
})";

int main() {
  try {
    const crumple::Scene scene = crumple::parseScene(kScene, "hello-dent", ".");
    const auto gl = crumple::gl::createHeadlessContext();  // current from here on
    std::printf("GL: %s\n", gl->description().c_str());

    crumple::Simulation sim(scene, /*gl=*/true);
    while (sim.world().time() < scene.duration) sim.step();
    std::printf("%ld steps, %zu collisions\n", sim.steps(), sim.events().size());

    // Height maps hold 0.5 where the surface is flat and 0 at the deepest dent the bump depth k allows.
    for (const crumple::BodyRuntime& body : sim.bodies()) {
      if (body.name != "plate") continue;
      const crumple::gl::Image height = body.surface->downloadHeight();
      const float lowest = *std::min_element(height.pixels.begin(), height.pixels.end());
      const long dented = std::count_if(height.pixels.begin(), height.pixels.end(), [](float v) { return v < 0.499f; });
      const double depth = (0.5 - lowest) * body.surface->bumpDepth();
      std::printf("the plate's dent: %.1f mm deep, %ld texels\n", depth * 1000, dented);
      return depth > 0.001 ? 0 : 1;
    }
    return 1;
  } catch (const crumple::SceneError& e) {  // bad scene text: names the key path
    std::fprintf(stderr, "hello-dent: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {  // no OpenGL 4.5 context, for one
    std::fprintf(stderr, "hello-dent: %s\n", e.what());
    return 1;
  }
}
