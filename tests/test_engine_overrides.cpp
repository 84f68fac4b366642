// Overrides (--set KEY=VALUE, Python's overrides=, crumple-sweep): key paths by index and by name, values as
// JSON, and every path that does not exist refused with the key path named.
#include <doctest/doctest.h>

#include <chrono>
#include <string>

#include <crumple/engine/overrides.h>
#include <crumple/engine/scene.h>

using namespace crumple;
using json = nlohmann::json;

namespace {
const char* kScene = R"({
  "format": "crumple-scene/1", "name": "t", "timestep": 0.004, "duration": 1,
  "materials": {"clay": {"density": 1800, "restitution": 0.2, "kappa": 0.1, "thickness": 0.05},
                "a.b": {"density": 1000}},
  "bodies": [
    {"name": "plate", "shape": {"type": "box", "size": [2, 0.2, 2]}, "material": "clay", "static": true,
     "position": [0, -0.1, 0], "bump_map": {"resolution": 128}},
    {"name": "ball", "shape": {"type": "sphere", "radius": 0.25}, "material": "clay", "position": [0, 0.6, 0],
     "velocity": [0, -6, 0]},
    {"name": "3", "shape": {"type": "sphere", "radius": 0.1}, "material": "a.b", "position": [3, 0.6, 0]}
  ],
  "joints": [{"type": "ball", "a": "ball", "b": "3", "anchor": [1.5, 0.6, 0]}],
  "cameras": [{"position": [2, 1.5, 2], "target": [0, 0, 0]}]
})";

Scene load(const Overrides& o) { return parseScene(kScene, "t.json", ".", o); }

// The message of the SceneError that loading with `o` throws ("" when none).
std::string error(const Overrides& o) {
  try {
    load(o);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("overrides: KEY=VALUE splits at the first '=' outside brackets") {
  CHECK(parseOverride("a.b=1") == Override{"a.b", "1"});
  CHECK(parseOverride("x=a=b") == Override{"x", "a=b"});
  CHECK(parseOverride("bodies[\"a=]b\"].velocity=[0,1,0]") == Override{"bodies[\"a=]b\"].velocity", "[0,1,0]"});
  CHECK_THROWS_WITH_AS(parseOverride("nothing"), "--set: nothing: expected KEY=VALUE (no '=' found)", SceneError);
  CHECK_THROWS_AS(parseOverride("=1"), SceneError);
}

TEST_CASE("overrides: values are JSON, or a plain word as a string") {
  CHECK(overrideValue("f", "k", "[0,-8,0]") == json::array({0, -8, 0}));
  CHECK(overrideValue("f", "k", "0.25") == json(0.25));
  CHECK(overrideValue("f", "k", "true") == json(true));
  CHECK(overrideValue("f", "k", "\"scatter\"") == json("scatter"));
  CHECK(overrideValue("f", "k", "scatter") == json("scatter"));
  CHECK(overrideValue("f", "k", "{\"a\": 1}") == json{{"a", 1}});
  CHECK_THROWS_WITH_AS(overrideValue("f", "k", "[0,-8,0"), doctest::Contains("f: k: the value '[0,-8,0' is not valid JSON"),
                       SceneError);
  CHECK_THROWS_AS(overrideValue("f", "k", "1.2.3"), SceneError);
  CHECK_THROWS_AS(overrideValue("f", "k", ""), SceneError);
}

TEST_CASE("overrides: paths by index and by name reach the scene") {
  const Scene base = load({});
  CHECK(base.bodies[1].velocity.y == doctest::Approx(-6));
  CHECK(load({{"bodies[ball].velocity", "[0,-8,0]"}}).bodies[1].velocity.y == doctest::Approx(-8));
  CHECK(load({{"bodies[1].velocity[1]", "-9"}}).bodies[1].velocity.y == doctest::Approx(-9));
  CHECK(load({{"materials.clay.kappa", "0.2"}}).materials.at("clay").kappa == doctest::Approx(0.2));
  CHECK(load({{"materials[\"a.b\"].density", "2000"}}).materials.at("a.b").density == doctest::Approx(2000));
  CHECK(load({{"bodies[\"3\"].position", "[4,0.6,0]"}}).bodies[2].position.x == doctest::Approx(4));
  CHECK(load({{"bodies[plate].bump_map.resolution", "256"}}).bodies[0].bumpMap.resolution == 256);
  // Optional keys and blocks the file leaves out.
  CHECK(load({{"deformation.address_map", "1024"}}).deformation.options.addressMap == 1024);
  CHECK(load({{"bodies[ball].bump_map.resolution", "64"}}).bodies[1].bumpMap.present);
  CHECK(load({{"duration", "0.25"}}).duration == doctest::Approx(0.25));
  CHECK(load({{"deformation.path", "scatter"}}).deformation.options.path == deform::Path::Scatter);
  // Default names: joints and cameras without one.
  CHECK(load({{"cameras[camera0].fov", "30"}}).cameras[0].fov == doctest::Approx(30));
  CHECK(load({{"joints[joint0].anchor", "[1,0.6,0]"}}).joints.size() == 1);
  // In order: the last wins.
  CHECK(load({{"duration", "0.25"}, {"duration", "0.5"}}).duration == doctest::Approx(0.5));
  // A new material may be set whole.
  CHECK(load({{"materials.iron", "{\"density\": 7800}"}}).materials.count("iron") == 1);
}

TEST_CASE("overrides: a path that does not exist is bad input naming it") {
  CHECK(error({{"bodies[bal].velocity", "[0,-8,0]"}}) ==
        "t.json: bodies[bal].velocity: no body is named 'bal' (bodies: plate, ball, 3)");
  CHECK(error({{"bodies[7].velocity", "[0,-8,0]"}}) == "t.json: bodies[7].velocity: bodies has 3 entries: no [7] (0 to 2)");
  CHECK(error({{"bodies[ball].velocty", "[0,-8,0]"}}) ==
        "t.json: bodies[1].velocty: unknown key (set by the override bodies[ball].velocty)");
  CHECK(error({{"deformaton.address_map", "1024"}}) ==
        "t.json: deformaton: unknown key (set by the override deformaton.address_map)");
  CHECK(error({{"materials.iron.kappa", "0.1"}}) ==
        "t.json: materials.iron.kappa: no material is named 'iron' (materials: a.b, clay)");
  CHECK(error({{"cameras[main].fov", "30"}}) == "t.json: cameras[main].fov: no camera is named 'main' (cameras: camera0)");
  CHECK(error({{"bodies[ball].velocity.x", "1"}}).find("bodies[1].velocity is an array") != std::string::npos);
  CHECK(error({{"duration.x", "1"}}).find("duration is a number, not an object") != std::string::npos);
  CHECK(error({{"bodies[ball", "1"}}).find("bodies[ball: bad key path: an unclosed '['") != std::string::npos);
  CHECK(error({{"bodies..x", "1"}}).find("bad key path") != std::string::npos);
  // A value the loader refuses says which override set it.
  CHECK(error({{"materials.clay.restitution", "1.5"}}) ==
        "t.json: materials.clay.restitution: must be in [0, 1], got 1.5 (set by the override materials.clay.restitution)");
  CHECK(error({{"bodies[ball].shape", "{\"type\": \"sphere\", \"radyus\": 1}"}}) ==
        "t.json: bodies[1].shape.radyus: unknown key (set by the override bodies[ball].shape)");
  // Errors that are not about an override are the loader's own.
  CHECK(error({{"duration", "0.5"}}) == "");
  try {
    parseScene("{\"bodies\": 3", "m.json", ".", {{"duration", "1"}});
    FAIL("no error");
  } catch (const SceneError& e) {
    CHECK(std::string(e.what()).find("m.json: malformed JSON at line 1") == 0);
  }
}

TEST_CASE("overrides: applyOverrides returns the paths as the loader writes them") {
  json doc = json::parse(kScene);
  const auto paths = applyOverrides(doc, {{"bodies[ball].velocity", "[0,-8,0]"}, {"cameras[camera0].fov", "20"}}, "t.json");
  CHECK(paths == std::vector<std::string>{"bodies[1].velocity", "cameras[0].fov"});
  CHECK(doc["bodies"][1]["velocity"] == json::array({0, -8, 0}));
  CHECK(doc["cameras"][0]["fov"] == json(20));
}

TEST_CASE("overrides: key paths are bounded (64 parts, 1024 characters) and read in one pass") {
  // 65 parts: refused for its parts, before any object is made for them.
  std::string parts = "a";
  for (int i = 1; i < 65; ++i) parts += ".a";
  REQUIRE(error({{parts, "1"}}) == "t.json: " + parts + ": bad key path: more than 64 parts");
  std::string brackets = "bodies";
  for (int i = 0; i < 64; ++i) brackets += "[0]";
  CHECK(error({{brackets, "1"}}).find("bad key path: more than 64 parts") != std::string::npos);
  // 64 parts are a path like any other (here one the scene does not have).
  std::string sixtyFour = "a";
  for (int i = 1; i < 64; ++i) sixtyFour += ".a";
  CHECK(error({{sixtyFour, "1"}}).find("unknown key") != std::string::npos);
  // Over 1024 characters: refused for its length, quoted in the message.
  const std::string longKey = "bodies[" + std::string(2000, 'x') + "].velocity";
  CHECK(error({{longKey, "1"}}) == "t.json: bodies[" + std::string(23, 'x') + "...(1957 characters)..." +
                                       std::string(20, 'x') +
                                       "].velocity: bad key path: longer than 1024 characters (2017)");
  // The fuzzer's key: 60000 dotted parts (memory grew with its square). Now refused at once, in a short message.
  std::string huge = "a";
  for (int i = 1; i < 60000; ++i) huge += ".a";
  const auto t0 = std::chrono::steady_clock::now();
  const std::string hugeError = error({{huge, "1"}});
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 0.5);
  CHECK(hugeError.find("bad key path: longer than 1024 characters (119999)") != std::string::npos);
  CHECK(hugeError.size() < 200);
}

TEST_CASE("overrides: a key or a value that is not UTF-8 is bad input, quoted escaped") {
  CHECK_THROWS_WITH_AS(load({{"bodies[ball].name", "ball\xff"}}),
                       "t.json: bodies[ball].name: the value 'ball\\xFF' is not valid UTF-8", SceneError);
  CHECK_THROWS_WITH_AS(load({{"name", "\"\xc3\""}}),
                       doctest::Contains("t.json: name: the value '\"\\xC3\"' is not valid UTF-8"), SceneError);
  CHECK_THROWS_WITH_AS(load({{"bodies[b\xe9].velocity", "[0,1,0]"}}),
                       "t.json: bodies[b\\xE9].velocity: bad key path: not valid UTF-8", SceneError);
  // A long value is quoted: its start and end.
  const std::string longValue = "[" + std::string(5000, '1');
  CHECK(error({{"duration", longValue}}).find("the value '[" + std::string(29, '1') + "...(4941 characters)...") !=
        std::string::npos);
}
