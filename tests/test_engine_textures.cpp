// Procedural surface textures: the material keys texture and texture_scale, and their errors.
#include <doctest/doctest.h>

#include <string>

#include <crumple/engine/scene.h>

using namespace crumple;

namespace {
std::string sceneWith(const std::string& materialKeys) {
  return R"({"format": "crumple-scene/1", "name": "t",
    "materials": {"road": {"density": 2400)" +
         materialKeys + R"(}},
    "bodies": [{"name": "ground", "shape": {"type": "box", "size": [4, 0.2, 4]}, "material": "road", "static": true}]})";
}
}  // namespace

TEST_CASE("material textures: keys, defaults and errors naming the key path") {
  const Scene plain = parseScene(sceneWith(""), "t.json", ".");
  CHECK(plain.materials.at("road").texture == "none");
  CHECK(plain.materials.at("road").textureScale == 1.0f);
  for (const char* kind : {"asphalt", "concrete", "clay", "none"}) {
    const Scene s =
        parseScene(sceneWith(std::string(", \"texture\": \"") + kind + "\", \"texture_scale\": 2.5"), "t.json", ".");
    CHECK(s.materials.at("road").texture == kind);
    CHECK(s.materials.at("road").textureScale == doctest::Approx(2.5));
  }
  struct Bad {
    std::string keys, path, reason;
  };
  const Bad bad[] = {
      {", \"texture\": \"marble\"", "materials.road.texture",
       "unknown texture 'marble' (expected asphalt, concrete, clay or none)"},
      {", \"texture\": 3", "materials.road.texture", "must be a string"},
      {", \"texture\": \"Asphalt\"", "materials.road.texture", "unknown texture 'Asphalt'"},
      {", \"texture_scale\": 0", "materials.road.texture_scale", "must be in [0.01, 100]"},
      {", \"texture_scale\": 1000", "materials.road.texture_scale", "must be in [0.01, 100]"},
      {", \"texture_scale\": \"big\"", "materials.road.texture_scale", "must be a number"},
  };
  for (const Bad& b : bad) {
    CAPTURE(b.keys);
    try {
      parseScene(sceneWith(b.keys), "t.json", ".");
      FAIL("accepted");
    } catch (const SceneError& e) {
      CHECK(e.keyPath == b.path);
      CHECK(e.reason.find(b.reason) != std::string::npos);
    }
  }
}
