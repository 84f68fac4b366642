// crumple-sim end to end: outputs of the contract, exit codes, atomic output
// folders, determinism, a user's glTF model as a mesh body.
#include <doctest/doctest.h>

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <glm/glm.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include <crumple/core/version.h>
#include "dent_metrics.h"
#include <crumple/gl/image.h>

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {
// One folder per test process: two suites running at once must not share files.
const fs::path kTmp = fs::temp_directory_path() / ("crumple_sim_tests_" + std::to_string(::getpid()));

int runSim(const std::string& args, std::string* output = nullptr) {
  fs::create_directories(kTmp);
  // In the sanitizer build, LeakSanitizer's tracer itself crashes now and then (signal 11, exit 1) at the exit
  // of a process whose llvmpipe threads are still up; crumple-sim's runs keep the address and undefined-behaviour
  // checks (leaks are checked in the suites that run in-process).
  static const bool once = [] {
    const char* asan = std::getenv("ASAN_OPTIONS");
    const std::string options = std::string(asan ? asan : "") + (asan ? ":" : "") + "detect_leaks=0";
    setenv("ASAN_OPTIONS", options.c_str(), 1);
    return true;
  }();
  (void)once;
  const fs::path log = kTmp / "log.txt";
  const std::string cmd = std::string(CRUMPLE_SIM) + " " + args + " > " + log.string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  if (output) {
    std::ifstream f(log);
    std::stringstream ss;
    ss << f.rdbuf();
    *output = ss.str();
  }
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

fs::path writeScene(const std::string& name, const std::string& text) {
  fs::create_directories(kTmp);
  const fs::path p = kTmp / name;
  std::ofstream(p) << text;
  return p;
}

// A shell prefix that caps a run's memory at 2 GB (what a run that read too much would pass), except under
// AddressSanitizer, whose shadow memory alone is terabytes of address space (the run is then bounded by its time).
#if defined(__SANITIZE_ADDRESS__)
std::string memoryCap() { return ""; }  // (the sanitizer build: crumple-sim is built with it too)
#else
std::string memoryCap() { return "ulimit -v 2000000; "; }
#endif

bool noPartialFolders() {
  for (const auto& e : fs::directory_iterator(kTmp))
    if (e.path().filename().string().find(".partial-") != std::string::npos) return false;
  return true;
}
}  // namespace

TEST_CASE("the default scene writes every output of the contract and dents the plate") {
  const fs::path out = kTmp / "default";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim("--out " + out.string() + " --quiet", &log) == 0);
  CAPTURE(log);
  const json summary = json::parse(slurp(out / "summary.json"));
  CHECK(summary["steps"].get<int>() > 0);
  CHECK(summary["bodies"].size() == 2);
  for (const char* key : {"scene", "steps", "time", "bodies", "collisions", "deformations", "timings"})
    CHECK(summary.contains(key));
  for (const auto& b : summary["bodies"])
    for (const char* key : {"name", "position", "orientation", "linear_velocity", "angular_velocity"})
      CHECK(b.contains(key));
  CHECK(summary["deformations"].get<int>() >= 1);
  std::ifstream ev(out / "events.jsonl");
  std::string line;
  int lines = 0, dented = 0;
  while (std::getline(ev, line)) {
    const json e = json::parse(line);
    for (const char* key :
         {"t", "a", "b", "point", "normal", "penetration", "impulse_elastic", "impulse", "a_side", "b_side"})
      CHECK(e.contains(key));
    for (const char* key : {"threshold", "percent_deform", "deform_depth", "deformed", "texels_changed", "max_dent"})
      CHECK(e["a_side"].contains(key));
    if (e["a_side"]["texels_changed"].get<int>() > 0) ++dented;
    ++lines;
  }
  CHECK(lines == summary["collisions"].get<int>());
  CHECK(dented >= 1);
  const crumple::gl::Image plate = crumple::gl::readPng((out / "heightmaps" / "plate.png").string());
  float lowest = 1;
  for (float v : plate.pixels) lowest = std::min(lowest, v);
  CHECK(lowest < 0.45f);  // dented below flat (0.5)
  CHECK(crumple::gl::isPng16((out / "heightmaps" / "plate.png").string()));
  CHECK(fs::exists(out / "normalmaps" / "ball.png"));
}

TEST_CASE("bad input ends with exit 2, a message naming the key path, and no output folder") {
  const fs::path out = kTmp / "bad";
  fs::remove_all(out);
  const fs::path scene =
      writeScene("bad.json", R"({"bodies": [{"name": "x", "shape": {"type": "sphere", "radius": -1}, "material": "m"}],
      "materials": {"m": {}}})");
  std::string log;
  CHECK(runSim(scene.string() + " --out " + out.string(), &log) == 2);
  CHECK(log.find("bad.json") != std::string::npos);
  CHECK(log.find("bodies[0].shape.radius") != std::string::npos);
  CHECK_FALSE(fs::exists(out));
  CHECK(noPartialFolders());
  CHECK(runSim((kTmp / "missing.json").string() + " --out " + out.string(), &log) == 2);
  CHECK(log.find("no such file") != std::string::npos);
}

TEST_CASE("a broken glTF mesh body is bad input (exit 2)") {
  const fs::path gltf = kTmp / "broken.gltf";
  std::ofstream(gltf) << R"({"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}], "buffers": [{"byteLength": 36, "uri": "nowhere.bin"}]})";
  const fs::path scene = writeScene("gltf.json", R"({"materials": {"m": {}}, "bodies": [
      {"name": "thing", "shape": {"type": "mesh", "file": "broken.gltf"}, "material": "m"}]})");
  std::string log;
  CHECK(runSim(scene.string() + " --out " + (kTmp / "gltfout").string(), &log) == 2);
  CAPTURE(log);
  CHECK(log.find("bodies[0].shape.file") != std::string::npos);
  CHECK_FALSE(fs::exists(kTmp / "gltfout"));
}

TEST_CASE("the same scene twice gives bit-identical outputs") {
  const fs::path a = kTmp / "det_a", b = kTmp / "det_b";
  fs::remove_all(a);
  fs::remove_all(b);
  REQUIRE(runSim("--out " + a.string() + " --quiet --steps 200") == 0);
  REQUIRE(runSim("--out " + b.string() + " --quiet --steps 200") == 0);
  json sa = json::parse(slurp(a / "summary.json")), sb = json::parse(slurp(b / "summary.json"));
  sa.erase("timings");
  sb.erase("timings");
  CHECK(sa.dump() == sb.dump());
  CHECK(slurp(a / "events.jsonl") == slurp(b / "events.jsonl"));
  CHECK(slurp(a / "heightmaps" / "plate.png") == slurp(b / "heightmaps" / "plate.png"));
  CHECK(slurp(a / "heightmaps" / "ball.png") == slurp(b / "heightmaps" / "ball.png"));
}

TEST_CASE("the paper's read-back path gives the same height maps as its scatter on the GPU") {
  const fs::path a = kTmp / "path_scatter", b = kTmp / "path_readback";
  fs::remove_all(a);
  fs::remove_all(b);
  REQUIRE(runSim("--out " + a.string() + " --quiet --steps 120 --deform-path scatter") == 0);
  REQUIRE(runSim("--out " + b.string() + " --quiet --steps 120 --deform-path readback") == 0);
  CHECK(slurp(a / "heightmaps" / "plate.png") == slurp(b / "heightmaps" / "plate.png"));
}

TEST_CASE("the address pass rasterised by compute shaders gives the fragment stage's dents, the same bits twice") {
  const fs::path f = kTmp / "raster_fragment", c1 = kTmp / "raster_compute1", c2 = kTmp / "raster_compute2";
  for (const auto& p : {f, c1, c2}) fs::remove_all(p);
  REQUIRE(runSim("--out " + f.string() + " --quiet --steps 120 --set 'deformation.address_raster=\"fragment\"'") == 0);
  REQUIRE(runSim("--out " + c1.string() + " --quiet --steps 120 --set 'deformation.address_raster=\"compute\"'") == 0);
  REQUIRE(runSim("--out " + c2.string() + " --quiet --steps 120 --set 'deformation.address_raster=\"compute\"'") == 0);
  CHECK(slurp(c1 / "heightmaps" / "plate.png") == slurp(c2 / "heightmaps" / "plate.png"));
  CHECK(slurp(c1 / "events.jsonl") == slurp(c2 / "events.jsonl"));
  const crumple::gl::Image a = crumple::gl::readPng((f / "heightmaps" / "plate.png").string());
  const crumple::gl::Image b = crumple::gl::readPng((c1 / "heightmaps" / "plate.png").string());
  REQUIRE(a.pixels.size() == b.pixels.size());
  int dented = 0, apart = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    dented += a.pixels[i] < 0.49f;
    apart += std::abs(a.pixels[i] - b.pixels[i]) > 2.0f / 65535.0f;
  }
  MESSAGE("plate texels dented " << dented << ", apart by over 2 steps of 16 bits " << apart);
  CHECK(dented > 100);
  CHECK(apart <= dented / 100);
}

TEST_CASE("a user's OBJ model without texture coordinates dropped into a scene is dented") {
  // An octahedron-ish closed mesh with no uvs: the loader must build an atlas.
  std::ofstream(kTmp / "gem.obj") << "v 0 0.3 0\nv 0.3 0 0\nv 0 0 0.3\nv -0.3 0 0\nv 0 0 -0.3\nv 0 -0.3 0\n"
                                     "f 1 3 2\nf 1 4 3\nf 1 5 4\nf 1 2 5\nf 6 2 3\nf 6 3 4\nf 6 4 5\nf 6 5 2\n";
  const fs::path scene = writeScene("gem.json", R"({"duration": 0.6,
    "materials": {"soft": {"restitution": 0.1, "kappa": 0.001, "thickness": 0.2}, "hard": {"density": 8000, "restitution": 0.9, "kappa": 0.0}},
    "bodies": [
      {"name": "ground", "shape": {"type": "mesh", "file": "gem.obj", "scale": [6, 1, 6]}, "material": "soft", "static": true,
       "position": [0, -0.3, 0], "bump_map": {"resolution": 256}},
      {"name": "weight", "shape": {"type": "box", "size": [0.3, 0.3, 0.3]}, "material": "hard", "position": [0.2, 0.6, 0.1],
       "velocity": [0, -5, 0]}]})");
  const fs::path out = kTmp / "gem_out";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim(scene.string() + " --out " + out.string(), &log) == 0);
  CAPTURE(log);
  CHECK(log.find("automatic one-to-one atlas") != std::string::npos);
  const crumple::gl::Image h = crumple::gl::readPng((out / "heightmaps" / "ground.png").string());
  int dented = 0;
  for (float v : h.pixels) dented += v < 0.49f;
  CHECK(dented > 10);
}

TEST_CASE("every shipped scene runs headless and writes its outputs") {
  for (const auto& entry : fs::directory_iterator(CRUMPLE_SCENES)) {
    if (entry.path().extension() != ".json") continue;
    const std::string name = entry.path().stem().string();
    CAPTURE(name);
    const fs::path out = kTmp / ("scene_" + name);
    fs::remove_all(out);
    std::string log;
    REQUIRE(runSim(entry.path().string() + " --out " + out.string() + " --duration 0.5 --quiet", &log) == 0);
    CAPTURE(log);
    CHECK(fs::exists(out / "summary.json"));
    CHECK(fs::exists(out / "events.jsonl"));
    const json s = json::parse(slurp(out / "summary.json"));
    for (const auto& b : s["bodies"])
      for (int i = 0; i < 3; ++i) CHECK(std::isfinite(b["position"][i].get<double>()));
  }
}

TEST_CASE(
    "highway: the car hits the W-beam rail at ~20 degrees and 80 km/h; car and rail dented by over 1 cm, the car's "
    "dent has no gaps, the struck segment's posts are torn out and land on the ground") {
  const fs::path out = kTmp / "highway_full";
  fs::remove_all(out);
  std::string log;
  const std::string scene = std::string(CRUMPLE_SCENES) + "/highway.json";
  REQUIRE(runSim(scene + " --out " + out.string() + " --duration 3 --quiet", &log) == 0);
  CAPTURE(log);
  // The first hit: the car against a rail segment, at speed.
  std::ifstream ev(out / "events.jsonl");
  std::string line;
  REQUIRE(std::getline(ev, line));
  const json first = json::parse(line);
  const bool carIsA = first["a"] == "car";
  CHECK(first[carIsA ? "b" : "a"].get<std::string>().rfind("rail_left_", 0) == 0);
  // N s: a 1300 kg car's sideways momentum at 80 km/h, 20 degrees, against a rail welded to its posts and they to
  // the ground (the elastic impulse treats the welded assembly as the ground it is part of; the impulse the collision
  // step applies meets the 60 kg segment alone, and the welds pass the rest on).
  CHECK(first["impulse_elastic"].get<double>() > 3000);
  // Bump depths (k) from the scene: the car's own, the rails' the scene's.
  const json spec = json::parse(slurp(scene));
  double kCar = spec["deformation"]["bump_depth"].get<double>(), kRail = kCar;
  for (const auto& b : spec["bodies"])
    if (b["name"] == "car") kCar = b["bump_map"]["bump_depth"].get<double>();
  auto deepest = [](const crumple::gl::Image& h) {
    float lowest = 1;
    for (float v : h.pixels) lowest = std::min(lowest, v);
    return 0.5 - lowest;
  };
  const crumple::gl::Image car = crumple::gl::readPng((out / "heightmaps" / "car.png").string());
  double railDent = 0;
  for (const auto& f : fs::directory_iterator(out / "heightmaps"))
    if (f.path().filename().string().rfind("rail_", 0) == 0)
      railDent = std::max(railDent, deepest(crumple::gl::readPng(f.path().string())) * kRail);
  const crumple::gl::Image flat(car.width, car.height, 1, 0.5f);
  const auto c = crumple::test::dentContinuity(flat, car);
  MESSAGE("car dent " << deepest(car) * kCar << " m over " << c.dented << " texels, continuity " << c.continuity
                      << ", holes " << c.holeFraction() << "; rail dent " << railDent << " m");
  CHECK(deepest(car) * kCar >= 0.01);
  CHECK(railDent >= 0.01);
  CHECK(c.dented > 5000);
  CHECK(c.continuity >= 0.93);
  CHECK(c.holeFraction() < 0.01);
  // The hit tears the struck segment's posts out of the ground (their welds break in the hit's step or just after)
  // and the segment, dented, falls out of line; the next segments stand.
  std::ifstream ev2(out / "events.jsonl");
  std::vector<std::string> broken;
  double firstBreak = -1;
  while (std::getline(ev2, line)) {
    const json e = json::parse(line);
    if (e["type"] != "joint_break") continue;
    broken.push_back(e["joint"]);
    if (firstBreak < 0) firstBreak = e["t"].get<double>();
    CHECK(e["impulse"].get<double>() > 1000);  // the footings' break_impulse
  }
  CHECK(broken.size() >= 2);
  CHECK(std::find(broken.begin(), broken.end(), "footing_left_19") != broken.end());
  CHECK(firstBreak >= first["t"].get<double>());
  CHECK(firstBreak < first["t"].get<double>() + 0.05);
  const json s = json::parse(slurp(out / "summary.json"));
  std::map<std::string, json> bodies;
  for (const json& b : s["bodies"]) bodies[b["name"]] = b;
  // The torn segment lies across the rail's line (its length, along x when it stood, turned over 45 degrees), metres
  // from where it stood (centred at x = 38).
  const json& torn = bodies["rail_left_09"];
  const glm::dvec3 at(torn["position"][0].get<double>(), torn["position"][1].get<double>(),
                      torn["position"][2].get<double>());
  const double qy = torn["orientation"][2].get<double>(), qz = torn["orientation"][3].get<double>();  // [w, x, y, z]
  const double along = 1 - 2 * (qy * qy + qz * qz);  // x of the segment's length direction
  MESSAGE("torn segment at " << at.x << ", " << at.y << ", " << at.z << "; its length along the rail's line " << along);
  CHECK(std::abs(along) < std::cos(M_PI / 4));
  CHECK(glm::length(glm::dvec2(at.x, at.z) - glm::dvec2(38.0, -5.0)) > 1.0);
  CHECK(bodies["rail_left_10"]["position"][2].get<double>() == doctest::Approx(-5.0));   // a static neighbour
  double segmentDent = deepest(crumple::gl::readPng((out / "heightmaps" / "rail_left_09.png").string())) * kRail;
  CHECK(segmentDent >= 0.01);
  // What the car tears out and pushes aside lands on the ground (the verge beyond the road's edge), every body's
  // centre above the ground's top (y = 0): none falls away under the world.
  int movable = 0;
  for (const auto& [name, b] : bodies) {
    if (b["static"].get<bool>()) continue;
    CAPTURE(name);
    CHECK(b["position"][1].get<double>() > 0.0);
    ++movable;
  }
  CHECK(movable >= 5);  // the car, the loose segment and its three posts
}

TEST_CASE("arch: ten voussoirs on friction alone stand 10 s within 1 cm (convex manifolds, island solves)") {
  const std::string scene = std::string(CRUMPLE_SCENES) + "/arch.json";
  const fs::path out = kTmp / "arch";
  fs::remove_all(out);
  REQUIRE(runSim(scene + " --out " + out.string() + " --quiet") == 0);
  const json s = json::parse(slurp(out / "summary.json"));
  int voussoirs = 0;
  double drift = 0;
  for (const auto& b : s["bodies"]) {
    if (b["name"].get<std::string>().rfind("voussoir", 0) != 0) continue;
    ++voussoirs;  // each starts with its shape origin at the arch's centre, (0, 0, 0)
    drift = std::max(drift, glm::length(glm::dvec3(b["position"][0].get<double>(), b["position"][1].get<double>(),
                                                   b["position"][2].get<double>())));
  }
  MESSAGE("arch: largest voussoir drift " << drift * 1000 << " mm after " << s["time"].get<double>() << " s");
  CHECK(voussoirs == 10);
  CHECK(s["time"].get<double>() == doctest::Approx(10.0));
  CHECK(drift < 0.01);
}

TEST_CASE("card-house: fifteen cards of three storeys stand 10 s within 1 cm on friction alone") {
  // tools/make-card-house-scene.py writes the scene and says where each card starts.
  const std::string scene = std::string(CRUMPLE_SCENES) + "/card-house.json";
  const json start = json::parse(slurp(scene));
  const fs::path out = kTmp / "card-house";
  fs::remove_all(out);
  REQUIRE(runSim(scene + " --out " + out.string() + " --quiet") == 0);
  const json s = json::parse(slurp(out / "summary.json"));
  auto at = [](const json& p) { return glm::dvec3(p[0].get<double>(), p[1].get<double>(), p[2].get<double>()); };
  int cards = 0;
  double drift = 0;
  for (const auto& b : s["bodies"]) {
    const std::string name = b["name"].get<std::string>();
    if (name.rfind("card", 0) != 0) continue;
    ++cards;
    for (const auto& b0 : start["bodies"])
      if (b0["name"] == name) drift = std::max(drift, glm::length(at(b["position"]) - at(b0["position"])));
  }
  MESSAGE("card-house: largest card drift " << drift * 1000 << " mm after " << s["time"].get<double>() << " s");
  CHECK(cards == 15);
  CHECK(s["time"].get<double>() == doctest::Approx(10.0));
  CHECK(drift < 0.01);
}

TEST_CASE(
    "brick-wall: a running-bond wall stands until the car hits it; the car breaks through, is dented, the ends stand") {
  // Each block rests half on two blocks below: a face resting off-centre on
  // its supports. Before patch impulses such walls sagged by themselves.
  const std::string scene = std::string(CRUMPLE_SCENES) + "/brick-wall.json";
  const json spec = json::parse(slurp(scene));
  std::map<std::string, glm::dvec3> start;
  for (const auto& b : spec["bodies"])
    start[b["name"].get<std::string>()] = {b["position"][0].get<double>(), b["position"][1].get<double>(),
                                           b["position"][2].get<double>()};
  auto positions = [&](const fs::path& out) {
    std::map<std::string, glm::dvec3> at;
    const json s = json::parse(slurp(out / "summary.json"));
    for (const auto& b : s["bodies"])
      at[b["name"].get<std::string>()] = {b["position"][0].get<double>(), b["position"][1].get<double>(),
                                          b["position"][2].get<double>()};
    return at;
  };
  const fs::path before = kTmp / "brick_wall_before", after = kTmp / "brick_wall_after";
  fs::remove_all(before);
  fs::remove_all(after);
  REQUIRE(runSim(scene + " --out " + before.string() + " --duration 1 --quiet") == 0);
  double sag = 0;
  int blocks = 0;
  for (const auto& [name, p] : positions(before)) {
    if (name.rfind("block", 0) != 0) continue;
    ++blocks;
    sag = std::max(sag, glm::length(p - start[name]));
  }
  CHECK(blocks == 75);
  CHECK(sag < 0.01);  // 1 s standing: no block has moved 1 cm (the 0.5 mm gaps between courses settle)
  std::string log;
  CAPTURE(log);
  REQUIRE(runSim(scene + " --out " + after.string() + " --quiet", &log) == 0);
  // An end block stands when it is upright (turned less than 10 degrees) within 10 cm of its place: the hit
  // shoves the wall's ends by a few centimetres (how far is chaotic), it must not bring them down.
  std::map<std::string, double> turned;
  const json summary = json::parse(slurp(after / "summary.json"));
  for (const auto& b : summary["bodies"])
    turned[b["name"].get<std::string>()] = 2 * std::acos(std::min(1.0, std::abs(b["orientation"][0].get<double>())));
  int thrown = 0, endsStanding = 0, ends = 0;
  for (const auto& [name, p] : positions(after)) {
    if (name.rfind("block", 0) != 0) continue;
    const glm::dvec3 s0 = start[name];
    if (glm::length(p - s0) > 0.3) ++thrown;
    if (std::abs(s0.z) > 2.4) {  // the wall's outer metre at both ends
      ++ends;
      endsStanding += glm::length(p - s0) < 0.1 && turned[name] < glm::radians(10.0);
    }
  }
  MESSAGE("brick-wall: " << thrown << " blocks thrown, " << endsStanding << " of " << ends << " end blocks standing");
  CHECK(thrown >= 15);
  CHECK(endsStanding * 4 >= ends * 3);
  const crumple::gl::Image h = crumple::gl::readPng((after / "heightmaps" / "car.png").string());
  float lowest = 1;
  for (float v : h.pixels) lowest = std::min(lowest, v);
  CHECK(lowest < 0.49f);  // the car is dented
}

TEST_CASE("tank-tracks: resting contact leaves a track in the ground (figure 8) and the hit dents the bunker") {
  const fs::path out = kTmp / "tank_full";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim(std::string(CRUMPLE_SCENES) + "/tank-tracks.json --out " + out.string() + " --quiet", &log) == 0);
  const json s = json::parse(slurp(out / "summary.json"));
  CHECK(s["contact_deformations"].get<int>() >= 5);
  // The track: dented texels spread along the slide much farther than across it.
  const crumple::gl::Image g = crumple::gl::readPng((out / "heightmaps" / "ground.png").string());
  int x0 = g.width, x1 = -1, y0 = g.height, y1 = -1;
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x)
      if (g.at(x, y) < 0.49f) {
        x0 = std::min(x0, x);
        x1 = std::max(x1, x);
        y0 = std::min(y0, y);
        y1 = std::max(y1, y);
      }
  REQUIRE(x1 >= 0);
  const int along = std::max(x1 - x0, y1 - y0), across = std::min(x1 - x0, y1 - y0);
  MESSAGE("track extent in texels: " << along << " x " << across);
  CHECK(along > 2 * across);
  // The treads' grousers print a ladder: along the row through a track the
  // dents come and go with the grouser pitch, neither one solid groove nor noise.
  int bestRow = -1, bestCount = 0;
  for (int y = y0; y <= y1; ++y) {
    int count = 0;
    for (int x = x0; x <= x1; ++x) count += g.at(x, y) < 0.49f;
    if (count > bestCount) bestCount = count, bestRow = y;
  }
  std::vector<int> starts;
  for (int x = x0 + 1; x <= x1; ++x)
    if (g.at(x, bestRow) < 0.49f && !(g.at(x - 1, bestRow) < 0.49f)) starts.push_back(x);
  REQUIRE(starts.size() >= 10);
  std::vector<int> gaps;
  for (size_t i = 1; i < starts.size(); ++i) gaps.push_back(starts[i] - starts[i - 1]);
  std::sort(gaps.begin(), gaps.end());
  const int median = gaps[gaps.size() / 2];
  int regular = 0;
  for (int gap : gaps) regular += std::abs(gap - median) <= 2;
  MESSAGE("grouser prints: " << starts.size() << ", median spacing " << median << " texels, " << regular << " of "
                             << gaps.size() << " within 2 texels of it, row fill " << bestCount << " of "
                             << x1 - x0 + 1);
  CHECK(regular >= 0.8 * static_cast<double>(gaps.size()));
  CHECK(bestCount < 0.8 * (x1 - x0 + 1));
  // One spacing is one pitch (0.3 m): the track is the tank's path (start at
  // x = -2 to where it ends) plus its belts' length (5.1 m) long.
  double tankX = 0;
  for (const auto& body : s["bodies"])
    if (body["name"] == "tank") tankX = body["position"][0].get<double>();
  const double texelsPerMetre = along / (tankX + 2 + 5.1);
  MESSAGE("tank ended at x = " << tankX << ": " << texelsPerMetre << " texels per metre, pitch " << 0.3 * texelsPerMetre
                               << " texels");
  CHECK(std::abs(median - 0.3 * texelsPerMetre) < 0.15 * 0.3 * texelsPerMetre);
  const crumple::gl::Image b = crumple::gl::readPng((out / "heightmaps" / "bunker.png").string());
  float lowest = 1;
  for (float v : b.pixels) lowest = std::min(lowest, v);
  CHECK(lowest < 0.49f);
}

TEST_CASE("cow-drop: the cow lands on its four hooves and leaves four prints in the hooves' rectangle (figure 9)") {
  const fs::path out = kTmp / "cow";
  fs::remove_all(out);
  REQUIRE(runSim(std::string(CRUMPLE_SCENES) + "/cow-drop.json --out " + out.string() + " --duration 1 --quiet") == 0);
  const crumple::gl::Image g = crumple::gl::readPng((out / "heightmaps" / "ground.png").string());
  // Connected dents (8-neighbours) of at least a few texels.
  std::vector<int> label(g.pixels.size(), -1);
  std::vector<glm::dvec2> centres;
  std::vector<int> sizes;
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x) {
      if (!(g.at(x, y) < 0.49f) || label[static_cast<size_t>(y * g.width + x)] >= 0) continue;
      const int id = static_cast<int>(centres.size());
      std::vector<std::pair<int, int>> stack{{x, y}};
      label[static_cast<size_t>(y * g.width + x)] = id;
      glm::dvec2 sum(0);
      int n = 0;
      while (!stack.empty()) {
        auto [cx, cy] = stack.back();
        stack.pop_back();
        sum += glm::dvec2(cx, cy);
        ++n;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int nx = cx + dx, ny = cy + dy;
            if (nx < 0 || ny < 0 || nx >= g.width || ny >= g.height) continue;
            const size_t k = static_cast<size_t>(ny * g.width + nx);
            if (label[k] >= 0 || !(g.at(nx, ny) < 0.49f)) continue;
            label[k] = id;
            stack.push_back({nx, ny});
          }
      }
      centres.push_back(sum / double(n));
      sizes.push_back(n);
    }
  std::vector<glm::dvec2> prints;
  for (size_t i = 0; i < centres.size(); ++i)
    if (sizes[i] >= 5) prints.push_back(centres[i]);
  MESSAGE(centres.size() << " dents, " << prints.size() << " of 5 texels or more");
  REQUIRE(prints.size() == 4);
  // The hooves stand on a 0.98 m x 0.34 m rectangle (tools/make-assets.py):
  // sides and diagonals of the four prints in that proportion.
  std::vector<double> d;
  for (size_t i = 0; i < 4; ++i)
    for (size_t j = i + 1; j < 4; ++j) d.push_back(glm::length(prints[i] - prints[j]));
  std::sort(d.begin(), d.end());
  MESSAGE("print distances (texels): " << d[0] << " " << d[1] << " " << d[2] << " " << d[3] << " " << d[4] << " "
                                       << d[5]);
  CHECK(std::abs(d[0] - d[1]) < 0.1 * d[0]);   // the two short sides
  CHECK(std::abs(d[2] - d[3]) < 0.05 * d[2]);  // the two long sides
  CHECK(std::abs(d[4] - d[5]) < 0.05 * d[4]);  // the diagonals
  CHECK(d[2] / d[0] == doctest::Approx(0.98 / 0.34).epsilon(0.15));
  CHECK(d[4] == doctest::Approx(std::hypot(d[0], d[2])).epsilon(0.03));  // a rectangle
}

TEST_CASE("crate-drop: the shipped glTF crate keeps its textures in the render and is dented") {
  // Renders the scene's camera at the end of a short run and looks at the pixels inside the crate's silhouette
  // (a disc about its final centre, projected with the scene's camera): the file's base-colour texture shows plank
  // brown and the dark brace. The same run with the scene material's colour given (which replaces the file's
  // texture) has neither, so the counts tell the texture from a plain body.
  const json scene = json::parse(slurp(fs::path(CRUMPLE_SCENES) / "crate-drop.json"));
  const json& cam = scene["cameras"][0];
  const int W = 480, H = 270;
  struct Counts {
    int inside = 0, plank = 0, brace = 0;
  };
  auto run = [&](const std::string& extra, const std::string& tag) {
    const fs::path out = kTmp / ("crate_" + tag);
    fs::remove_all(out);
    REQUIRE(runSim(std::string(CRUMPLE_SCENES) + "/crate-drop.json --out " + out.string() +
                   " --render --fps 1 --size 480x270 --duration 1 --quiet" + extra) == 0);
    const json s = json::parse(slurp(out / "summary.json"));
    glm::vec3 centre(0);
    for (const auto& b : s["bodies"])
      if (b["name"] == "crate")
        centre = glm::vec3(b["position"][0].get<float>(), b["position"][1].get<float>(), b["position"][2].get<float>());
    const glm::vec3 eye(cam["position"][0].get<float>(), cam["position"][1].get<float>(), cam["position"][2].get<float>());
    const glm::vec3 target(cam["target"][0].get<float>(), cam["target"][1].get<float>(), cam["target"][2].get<float>());
    const float fov = glm::radians(cam["fov"].get<float>());
    // Pinhole projection of the camera (vertical fov, y up, looking from eye to target).
    const glm::vec3 f = glm::normalize(target - eye), r = glm::normalize(glm::cross(f, glm::vec3(0, 1, 0))),
                    u = glm::cross(r, f);
    const glm::vec3 d = centre - eye;
    const float z = glm::dot(d, f), k = 0.5f * H / std::tan(0.5f * fov);
    const float px = 0.5f * W + k * glm::dot(d, r) / z, py = 0.5f * H - k * glm::dot(d, u) / z;
    const float radius = 0.85f * k * 0.3f / glm::length(d);  // inside the crate's inscribed sphere (0.3 m)
    MESSAGE(tag << ": crate centre at pixel (" << px << ", " << py << "), disc radius " << radius);
    REQUIRE(radius > 10);
    std::vector<fs::path> frames;
    for (const auto& e : fs::directory_iterator(out / "frames")) frames.push_back(e.path());
    std::sort(frames.begin(), frames.end());
    REQUIRE(!frames.empty());
    const crumple::gl::Image img = crumple::gl::readPng(frames.back().string(), 3);
    REQUIRE(img.width == W);
    Counts c;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        if (std::hypot(x + 0.5f - px, y + 0.5f - py) > radius) continue;
        ++c.inside;
        const float R = img.at(x, y, 0), G = img.at(x, y, 1), B = img.at(x, y, 2);
        if (R > 0.4f && R > G + 0.08f && G > B + 0.05f) ++c.plank;  // lit planks: orange brown
        if (std::max({R, G, B}) < 0.2f && R > B + 0.02f) ++c.brace;  // the brace: dark brown, not grey
      }
    MESSAGE(tag << ": " << c.inside << " pixels in the disc, " << c.plank << " plank brown, " << c.brace
                << " brace dark");
    return std::make_pair(c, out);
  };
  const auto [textured, out] = run("", "file");
  CHECK(textured.plank > textured.inside / 4);
  CHECK(textured.brace > textured.inside / 50);
  const auto [plain, plainOut] = run(" --set 'materials.wood.color=[0.55,0.55,0.55]'", "plain");
  CHECK(plain.plank < plain.inside / 50);
  CHECK(plain.brace < plain.inside / 200);
  // The landing wrote the crate's height map, dented.
  const crumple::gl::Image h = crumple::gl::readPng((out / "heightmaps" / "crate.png").string());
  int dented = 0;
  for (float v : h.pixels) dented += v < 0.45f;
  MESSAGE(dented << " crate height-map texels dented");
  CHECK(dented > 100);
}

TEST_CASE(
    "bump-ramp: with normal-mapped collision normals a ball rolls down a slope that exists only in the bump map "
    "(figure 10)") {
  auto horizontalTravel = [&](bool on) {
    std::ifstream in(std::string(CRUMPLE_SCENES) + "/bump-ramp.json");
    std::stringstream ss;
    ss << in.rdbuf();
    std::string text = ss.str();
    if (!on) text.replace(text.find("\"normal_mapped_normals\": true"), 29, "\"normal_mapped_normals\": false");
    fs::create_directories(kTmp / "assets");
    fs::copy_file(fs::path(CRUMPLE_SCENES) / "assets" / "ramp.png", kTmp / "assets" / "ramp.png",
                  fs::copy_options::overwrite_existing);
    const fs::path scene = kTmp / ("bump_ramp_" + std::to_string(on) + ".json");
    std::ofstream(scene) << text;
    const fs::path out = kTmp / ("ramp_" + std::to_string(on));
    fs::remove_all(out);
    const int rc = runSim(scene.string() + " --out " + out.string() + " --duration 1.5 --quiet");
    REQUIRE(rc == 0);
    const json s = json::parse(slurp(out / "summary.json"));
    for (const auto& b : s["bodies"])
      if (b["name"] == "ball") return std::hypot(b["position"][0].get<double>(), b["position"][2].get<double>());
    return -1.0;
  };
  const double on = horizontalTravel(true), off = horizontalTravel(false);
  MESSAGE("ball travel: " << on << " m with normal-mapped normals, " << off << " m without");
  CHECK(on > 0.3);
  CHECK(off < 0.01);
}

TEST_CASE("a user's glTF model (binary buffer, node transform, no uvs) works end to end as a mesh body") {
  // A closed cube as glTF with an external .bin, translated by its node.
  const float p[24] = {-1, -1, -1, 1, -1, -1, 1, 1, -1, -1, 1, -1, -1, -1, 1, 1, -1, 1, 1, 1, 1, -1, 1, 1};
  const uint16_t idx[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                            3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
  {
    std::ofstream bin(kTmp / "cube.bin", std::ios::binary);
    bin.write(reinterpret_cast<const char*>(p), sizeof p);
    bin.write(reinterpret_cast<const char*>(idx), sizeof idx);
  }
  std::ofstream(kTmp / "cube.gltf") << R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"children": [1], "scale": [0.3, 0.3, 0.3]}, {"mesh": 0, "translation": [0, 1, 0]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "buffers": [{"byteLength": 168, "uri": "cube.bin"}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 96}, {"buffer": 0, "byteOffset": 96, "byteLength": 72}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3", "min": [-1,-1,-1], "max": [1,1,1]},
                  {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}]})";
  const fs::path scene = writeScene("cube_scene.json", R"({"duration": 1.0,
    "materials": {"soft": {"restitution": 0.1, "kappa": 0.0005, "thickness": 0.1}, "heavy": {"density": 7000, "restitution": 0.8, "kappa": 0}},
    "bodies": [
      {"name": "floor", "shape": {"type": "box", "size": [4, 0.2, 4]}, "material": "soft", "static": true, "position": [0, -0.1, 0],
       "bump_map": {"resolution": 256}},
      {"name": "cube", "shape": {"type": "mesh", "file": "cube.gltf"}, "material": "heavy", "position": [0, 0.5, 0],
       "velocity": [0, -4, 0], "bump_map": {"resolution": 128}}]})");
  const fs::path out = kTmp / "cube_out";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim(scene.string() + " --out " + out.string(), &log) == 0);
  CAPTURE(log);
  CHECK(log.find("automatic one-to-one atlas") != std::string::npos);
  const json s = json::parse(slurp(out / "summary.json"));
  for (const auto& b : s["bodies"])
    if (b["name"] == "cube") {
      // The node transform put the cube's mesh 0.3 m above its file origin: resting, the origin sits 0 m above the floor.
      CHECK(b["center_of_mass"][1].get<double>() == doctest::Approx(0.3).epsilon(0.05));
    }
  const crumple::gl::Image floor = crumple::gl::readPng((out / "heightmaps" / "floor.png").string());
  int dented = 0;
  for (float v : floor.pixels) dented += v < 0.49f;
  CHECK(dented > 50);
}

TEST_CASE("bad command lines and unusable output folders are bad input (exit 2), --help is not") {
  std::string log;
  CHECK(runSim("--steps -5 --out " + (kTmp / "x").string(), &log) == 2);
  CHECK(log.find("--steps") != std::string::npos);
  CHECK(runSim("--no-such-flag", &log) == 2);
  CHECK(runSim("--help", &log) == 0);
  CHECK(log.find("--deform-path") != std::string::npos);
  // A trace file that cannot be written is bad input too, and leaves no output behind.
  CHECK(runSim("--steps 5 --trace /nonexistent-dir/trace.csv --out " + (kTmp / "traced").string(), &log) == 2);
  CHECK(log.find("--trace") != std::string::npos);
  CHECK_FALSE(fs::exists(kTmp / "traced"));
  // An output path that is a file, or a folder of someone else's files, is refused untouched.
  std::ofstream(kTmp / "a_file") << "keep me";
  CHECK(runSim("--out " + (kTmp / "a_file").string(), &log) == 2);
  CHECK(slurp(kTmp / "a_file") == "keep me");
  fs::create_directories(kTmp / "someone_elses");
  std::ofstream(kTmp / "someone_elses" / "thesis.tex") << "precious";
  CHECK(runSim("--out " + (kTmp / "someone_elses").string(), &log) == 2);
  CHECK(slurp(kTmp / "someone_elses" / "thesis.tex") == "precious");
}

TEST_CASE("--version prints the library's version, the same as the headers'") {
  CHECK(std::string(crumple::versionString()) == CRUMPLE_VERSION_STRING);
  CHECK(crumple::version() == CRUMPLE_VERSION);
  std::string log;
  CHECK(runSim("--version", &log) == 0);
  CHECK(log == std::string("crumple-sim ") + CRUMPLE_VERSION_STRING + "\n");
}

TEST_CASE("a bad command-line option is bad input: exit 2 and one line 'crumple-sim: error: ...' naming it") {
  for (const char* args : {"--fps 0", "--steps 0", "--threads 300", "--export obj", "--deform-path foo", "--bogus",
                           "--animate --steps 1"}) {
    CAPTURE(args);
    std::string log;
    CHECK(runSim(args, &log) == 2);
    CHECK(log.rfind("crumple-sim: error: ", 0) == 0);
    CHECK(std::count(log.begin(), log.end(), '\n') == 1);
    CHECK(log.find("--help") != std::string::npos);
  }
  std::string log;
  CHECK(runSim("--help", &log) == 0);
  CHECK(log.find("--out") != std::string::npos);
}

TEST_CASE("an output folder is replaced only when crumple wrote everything in it; a user's file is never deleted") {
  std::string log;
  // The issue's case: any summary.json beside a user's file.
  const fs::path d = kTmp / "looks_like_output";
  fs::remove_all(d);
  fs::create_directories(d);
  std::ofstream(d / "summary.json") << "{}";
  std::ofstream(d / "keep.txt") << "x";
  CHECK(runSim("--steps 5 --out " + d.string(), &log) == 2);
  CHECK(log.find(".crumple-output") != std::string::npos);
  CHECK(slurp(d / "keep.txt") == "x");
  CHECK(slurp(d / "summary.json") == "{}");
  // crumple's own output is replaced; with a file of the user's added, it is not.
  const fs::path out = kTmp / "own_output";
  fs::remove_all(out);
  REQUIRE(runSim("--steps 5 --quiet --out " + out.string(), &log) == 0);
  const json marker = json::parse(slurp(out / ".crumple-output"));
  CHECK(std::find(marker["files"].begin(), marker["files"].end(), "heightmaps/plate.png") != marker["files"].end());
  CHECK(runSim("--steps 5 --quiet --out " + out.string(), &log) == 0);
  std::ofstream(out / "heightmaps" / "notes.txt") << "mine";
  CHECK(runSim("--steps 5 --quiet --out " + out.string(), &log) == 2);
  CHECK(log.find("heightmaps/notes.txt") != std::string::npos);
  CHECK(slurp(out / "heightmaps" / "notes.txt") == "mine");
  CHECK(noPartialFolders());
}

TEST_CASE("SIGTERM during a run removes the partial output and replaces nothing") {
  const fs::path out = kTmp / "interrupted";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim("--steps 5 --quiet --out " + out.string(), &log) == 0);
  const std::string before = slurp(out / "summary.json");
  // A long run, terminated after a second: exit 130, the previous output untouched, no staging folder left.
  const std::string cmd = "timeout --preserve-status -s TERM 3 " + std::string(CRUMPLE_SIM) + " " +
                          std::string(CRUMPLE_SCENES) + "/highway.json --duration 1000 --quiet --out " + out.string() +
                          " > " + (kTmp / "term.txt").string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  CAPTURE(slurp(kTmp / "term.txt"));
  CHECK(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 130);
  CHECK(slurp(out / "summary.json") == before);
  CHECK(noPartialFolders());
}

TEST_CASE("wrecking-ball: the ball on its cable dents the clay wall; the cable never stretches; runs are identical") {
  const fs::path a = kTmp / "wrecking_a", b = kTmp / "wrecking_b";
  fs::remove_all(a);
  fs::remove_all(b);
  const std::string scene = std::string(CRUMPLE_SCENES) + "/wrecking-ball.json";
  std::string log;
  REQUIRE(runSim(scene + " --out " + a.string() + " --duration 1.6 --quiet --trace " + (kTmp / "wb.csv").string(),
                 &log) == 0);
  REQUIRE(runSim(scene + " --out " + b.string() + " --duration 1.6 --quiet") == 0);
  const json s = json::parse(slurp(a / "summary.json"));
  REQUIRE(s["joints"].size() == 1);
  CHECK(s["joints"][0]["name"] == "cable");
  CHECK(s["joints"][0]["type"] == "distance");
  CHECK(s["joints"][0]["broken"] == false);
  CHECK(s["joints"][0]["distance"].get<double>() <= 6.0 + 1e-3);
  // The swing's hit on the wall: one collision line, typed, with a dent of several centimetres in the wall.
  std::istringstream ev(slurp(a / "events.jsonl"));
  std::string line;
  double wallDent = 0;
  int collisions = 0;
  while (std::getline(ev, line)) {
    const json e = json::parse(line);
    CHECK(e["type"] == "collision");
    ++collisions;
    if (e["a"] == "wall") wallDent = std::max(wallDent, e["a_side"]["max_dent"].get<double>());
    if (e["b"] == "wall") wallDent = std::max(wallDent, e["b_side"]["max_dent"].get<double>());
  }
  CHECK(collisions >= 1);
  MESSAGE("wall dent " << wallDent * 100 << " cm");
  CHECK(wallDent > 0.03);
  json sa = s, sb = json::parse(slurp(b / "summary.json"));
  sa.erase("timings");
  sb.erase("timings");
  CHECK(sa.dump() == sb.dump());
  CHECK(slurp(a / "events.jsonl") == slurp(b / "events.jsonl"));
  CHECK(slurp(a / "heightmaps" / "wall.png") == slurp(b / "heightmaps" / "wall.png"));
}

TEST_CASE("a breakable weld breaks under a hit: a joint_break line in events.jsonl; a keyframed body ends on its path") {
  const fs::path scene = writeScene("weld.json", R"({
  "format": "crumple-scene/1", "name": "weld", "timestep": 0.0041666667, "duration": 1.0,
  "materials": {"steel": {"density": 7800, "restitution": 0.5, "friction": 0.4, "kappa": 0, "thickness": 0.01}},
  "deformation": {"enabled": false},
  "bodies": [
    {"name": "sign", "shape": {"type": "box", "size": [0.6, 0.4, 0.05]}, "material": "steel", "position": [0, 2, 0],
     "mass": 4},
    {"name": "ball", "shape": {"type": "sphere", "radius": 0.1}, "material": "steel", "position": [0, 2, -1],
     "velocity": [0, 0.98, 6]},
    {"name": "strong", "shape": {"type": "box", "size": [0.6, 0.4, 0.05]}, "material": "steel",
     "position": [3, 2, 0], "mass": 4},
    {"name": "lift", "shape": {"type": "box", "size": [1, 0.1, 1]}, "material": "steel", "position": [6, 0, 0],
     "kinematic": true, "group": "machines",
     "path": [{"t": 0, "position": [6, 0, 0]}, {"t": 0.5, "position": [6, 1, 0], "orientation": [0, 90, 0]}]},
    {"name": "ghost", "shape": {"type": "sphere", "radius": 0.2}, "material": "steel", "position": [6, 2, 0],
     "group": "ghosts"}
  ],
  "joints": [
    {"name": "weak_weld", "type": "fixed", "b": "sign", "anchor": [0, 2.2, 0], "break_impulse": 20},
    {"name": "strong_weld", "type": "fixed", "a": null, "b": "strong", "anchor": [3, 2.2, 0], "break_impulse": 1e6}
  ],
  "no_collide": [["machines", "ghosts"]]
})");
  const fs::path out = kTmp / "weld_out";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim(scene.string() + " --out " + out.string() + " --quiet", &log) == 0);
  CAPTURE(log);
  std::istringstream ev(slurp(out / "events.jsonl"));
  std::string line;
  int breaks = 0;
  double hitTime = -1, breakTime = -1;
  while (std::getline(ev, line)) {
    const json e = json::parse(line);
    if (e["type"] == "joint_break") {
      ++breaks;
      CHECK(e["joint"] == "weak_weld");
      CHECK(e["impulse"].get<double>() > 20);
      breakTime = e["t"].get<double>();
    } else {
      CHECK(e["type"] == "collision");
      if (hitTime < 0 && (e["a"] == "sign" || e["b"] == "sign")) hitTime = e["t"].get<double>();
    }
  }
  CHECK(breaks == 1);
  CHECK(breakTime >= hitTime);
  CHECK(breakTime < hitTime + 0.01);  // in the hit's step
  const json s = json::parse(slurp(out / "summary.json"));
  CHECK(s["joint_breaks"] == 1);
  std::map<std::string, json> joints, bodies;
  for (const json& j : s["joints"]) joints[j["name"]] = j;
  for (const json& b : s["bodies"]) bodies[b["name"]] = b;
  CHECK(joints["weak_weld"]["broken"] == true);
  CHECK(joints["strong_weld"]["broken"] == false);
  CHECK(bodies["sign"]["position"][1].get<double>() < 1.0);          // it fell once free
  CHECK(bodies["strong"]["position"][1].get<double>() == doctest::Approx(2.0).epsilon(0.001));  // held
  // The lift followed its path to the last key and stays there (held after it).
  CHECK(bodies["lift"]["kinematic"] == true);
  CHECK(bodies["lift"]["position"][1].get<double>() == doctest::Approx(1.0).epsilon(1e-6));
  CHECK(std::abs(bodies["lift"]["orientation"][2].get<double>()) == doctest::Approx(std::sqrt(0.5)).epsilon(1e-6));
  // The ghost, in a group that does not collide with the lift's, fell through it.
  CHECK(bodies["ghost"]["position"][1].get<double>() < 0);
}

TEST_CASE(
    "car-doors: the sedan hits a post; both door latches break in the hit's step, the doors swing open on their "
    "hinges within their limits, stay above the ground, and the car is dented") {
  const fs::path out = kTmp / "car_doors";
  const fs::path trace = kTmp / "car_doors.csv";
  fs::remove_all(out);
  const std::string scene = std::string(CRUMPLE_SCENES) + "/car-doors.json";
  std::string log;
  REQUIRE(runSim(scene + " --out " + out.string() + " --duration 2 --quiet --trace " + trace.string(), &log) == 0);
  CAPTURE(log);
  const json spec = json::parse(slurp(scene));
  std::map<std::string, json> specJoints;
  for (const json& j : spec["joints"]) specJoints[j["name"]] = j;
  // The hit on the post, then a break of each latch in that step, each asked for more than its break impulse.
  std::istringstream ev(slurp(out / "events.jsonl"));
  std::string line;
  double hitTime = -1;
  std::map<std::string, double> breakTime, asked;
  while (std::getline(ev, line)) {
    const json e = json::parse(line);
    if (e["type"] == "collision") {
      if (hitTime < 0 && (e["a"] == "post" || e["b"] == "post")) {
        hitTime = e["t"].get<double>();
        const json& carSide = e["a"] == "car" ? e["a_side"] : e["b_side"];
        CHECK(carSide["deformed"] == true);
      }
    } else {
      REQUIRE(e["type"] == "joint_break");
      const std::string joint = e["joint"];
      CAPTURE(joint);
      CHECK(joint.rfind("latch_", 0) == 0);  // never a hinge
      CHECK(e["impulse"].get<double>() > specJoints[joint]["break_impulse"].get<double>());
      breakTime[joint] = e["t"].get<double>();
      asked[joint] = e["impulse"].get<double>();
    }
  }
  REQUIRE(hitTime > 0);
  REQUIRE(breakTime.size() == 2);
  for (const auto& [joint, t] : breakTime) {
    CAPTURE(joint);
    CHECK(t >= hitTime);
    CHECK(t < hitTime + 0.01);
  }
  // Every step: each door's turn relative to the car about its hinge axis stays within the limits [0, 75]
  // degrees (a hair of slack: limits are enforced by impulses), and its lowest point (the sill, 0.2 m below
  // the door's origin on the hinge) stays above the ground.
  struct Pose {
    double y = 0;
    double q[4] = {1, 0, 0, 0};  // w, x, y, z
  };
  std::ifstream tr(trace);
  REQUIRE(std::getline(tr, line));  // header
  std::map<std::string, Pose> pose;
  std::map<std::string, double> lo{{"left", 1e9}, {"right", 1e9}}, hi{{"left", -1e9}, {"right", -1e9}}, last;
  double lowestDoor = 1e9;
  int steps = 0;
  auto hingeAngle = [](const Pose& car, const Pose& door, double axisY) {
    // q_rel = conj(q_car) q_door; its turn about the car-frame axis (0, axisY, 0).
    const double aw = car.q[0], ax = -car.q[1], ay = -car.q[2], az = -car.q[3];
    const double bw = door.q[0], bx = door.q[1], by = door.q[2], bz = door.q[3];
    const double w = aw * bw - ax * bx - ay * by - az * bz;
    const double y = aw * by - ax * bz + ay * bw + az * bx;
    return 2 * std::atan2(y * axisY, w) * 180 / M_PI;
  };
  auto endOfStep = [&] {
    for (const auto& [side, axisY] : {std::pair<std::string, double>{"left", 1.0}, {"right", -1.0}}) {
      const double a = hingeAngle(pose["car"], pose["door_" + side], axisY);
      lo[side] = std::min(lo[side], a);
      hi[side] = std::max(hi[side], a);
      last[side] = a;
      lowestDoor = std::min(lowestDoor, pose["door_" + side].y - 0.2);
    }
    ++steps;
  };
  std::string step;
  int badRows = 0;
  while (std::getline(tr, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    if (f.size() != 16) {
      ++badRows;
      continue;
    }
    if (!step.empty() && f[0] != step) endOfStep();
    step = f[0];
    Pose& p = pose[f[2]];
    p.y = std::stod(f[4]);
    for (int i = 0; i < 4; ++i) p.q[i] = std::stod(f[6 + i]);
  }
  endOfStep();
  CHECK(badRows == 0);
  CHECK(steps == 480);
  const json s = json::parse(slurp(out / "summary.json"));
  std::map<std::string, json> joints;
  for (const json& j : s["joints"]) joints[j["name"]] = j;
  for (const std::string side : {"left", "right"}) {
    CAPTURE(side);
    const json& hinge = joints["hinge_" + side];
    const json& latch = joints["latch_" + side];
    MESSAGE("door " << side << ": hinge angle in [" << lo[side] << ", " << hi[side] << "] deg, ends at " << last[side]
                    << " (summary " << hinge["angle"] << "); the hit asked " << asked["latch_" + side]
                    << " N s of its latch");
    CHECK(lo[side] > -0.5);
    CHECK(hi[side] < 75.5);
    CHECK(last[side] > 40);  // swung open, not ajar
    CHECK(hinge["broken"] == false);
    CHECK(hinge["angle"].get<double>() == doctest::Approx(last[side]).epsilon(0.01));
    CHECK(latch["broken"] == true);
  }
  CHECK(lowestDoor > 0.1);
  // The car's front is dented by the post: several centimetres deep.
  double kCar = spec["deformation"]["bump_depth"].get<double>();
  for (const auto& b : spec["bodies"])
    if (b["name"] == "car") kCar = b["bump_map"]["bump_depth"].get<double>();
  const crumple::gl::Image car = crumple::gl::readPng((out / "heightmaps" / "car.png").string());
  float lowest = 1;
  for (float v : car.pixels) lowest = std::min(lowest, v);
  MESSAGE("car dent " << (0.5 - lowest) * kCar << " m");
  CHECK((0.5 - lowest) * kCar > 0.03);
}

TEST_CASE("soak: 200 mixed bodies on deformable ground for 2000 steps: no NaN, no energy gain, none below the floor, "
          "flat memory") {
  // Spheres, boxes, capsules and cylinders rain onto a clay floor that takes their prints.
  json scene = {{"format", "crumple-scene/1"}, {"name", "soak"}, {"duration", 10}};
  scene["materials"] = {
      {"clay", {{"density", 1800}, {"restitution", 0.2}, {"friction", 0.8}, {"kappa", 0.0005}, {"thickness", 0.05}}},
      {"wood", {{"density", 600}, {"restitution", 0.4}, {"friction", 0.6}, {"kappa", 0.0}, {"thickness", 0.05}}}};
  scene["deformation"] = {{"enabled", true}, {"address_map", 128}, {"impulse_floor", 20}};
  json bodies = json::array();
  bodies.push_back({{"name", "floor"},
                    {"shape", {{"type", "box"}, {"size", {12, 0.5, 12}}}},
                    {"material", "clay"},
                    {"static", true},
                    {"position", {0, -0.25, 0}},
                    {"bump_map", {{"resolution", 512}}}});
  for (int k = 0; k < 4; ++k) {  // walls: nothing rolls off the floor
    const double x = k < 2 ? (k == 0 ? -4.5 : 4.5) : 0, z = k < 2 ? 0 : (k == 2 ? -4.5 : 4.5);
    bodies.push_back({{"name", "wall" + std::to_string(k)},
                      {"shape", {{"type", "box"}, {"size", {k < 2 ? 0.4 : 9.4, 1.5, k < 2 ? 9.4 : 0.4}}}},
                      {"material", "wood"},
                      {"static", true},
                      {"position", {x, 0.75, z}}});
  }
  uint64_t state = 7;
  auto u = [&]() {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  };
  const char* types[] = {"sphere", "box", "capsule", "cylinder"};
  for (int i = 0; i < 200; ++i) {
    json shape = {{"type", types[i % 4]}};
    if (i % 4 == 1)
      shape["size"] = {0.2 + 0.3 * u(), 0.2 + 0.3 * u(), 0.2 + 0.3 * u()};
    else
      shape["radius"] = 0.1 + 0.1 * u();
    if (i % 4 >= 2) shape["height"] = 0.3;
    bodies.push_back({{"name", "b" + std::to_string(i)},
                      {"shape", shape},
                      {"material", "wood"},
                      {"position", {6 * u() - 3, 0.5 + 6 * u(), 6 * u() - 3}},
                      {"orientation", {360 * u(), 360 * u(), 360 * u()}}});
  }
  scene["bodies"] = bodies;
  const fs::path file = writeScene("soak.json", scene.dump());
  std::map<int, double> peak;
  for (int steps : {500, 2000}) {
    const fs::path out = kTmp / ("soak_" + std::to_string(steps));
    fs::remove_all(out);
    const fs::path trace = kTmp / ("soak_" + std::to_string(steps) + ".csv");
    std::string log;
    REQUIRE(runSim(file.string() + " --out " + out.string() + " --quiet --steps " + std::to_string(steps) +
                       (steps == 2000 ? " --trace " + trace.string() : ""),
                   &log) == 0);
    const json s = json::parse(slurp(out / "summary.json"));
    peak[steps] = s["timings"]["peak_rss_mb"].get<double>();
    if (steps != 2000) continue;
    std::map<std::string, double> mass;
    for (const json& b : s["bodies"])
      if (b.contains("mass")) mass[b["name"]] = b["mass"].get<double>();
    // Energy per step from the trace (translational kinetic + potential; rotation only adds to the start's zero).
    std::ifstream tr(trace);
    std::string line;
    std::getline(tr, line);
    std::map<long, double> energy;
    double lowest = 1e9;
    long rows = 0;
    while (std::getline(tr, line)) {
      std::vector<std::string> f;
      std::stringstream ls(line);
      for (std::string x; std::getline(ls, x, ',');) f.push_back(x);
      REQUIRE(f.size() >= 13);
      if (!mass.count(f[2])) continue;
      // (strtod: std::stod throws on a subnormal, which a velocity coming to rest can be)
      auto number = [](const std::string& x) { return std::strtod(x.c_str(), nullptr); };
      const double y = number(f[4]), vx = number(f[10]), vy = number(f[11]), vz = number(f[12]);
      REQUIRE(std::isfinite(y));
      REQUIRE(std::isfinite(vx + vy + vz));
      lowest = std::min(lowest, y);
      energy[std::stol(f[0])] += mass[f[2]] * (0.5 * (vx * vx + vy * vy + vz * vz) + 9.81 * y);
      ++rows;
    }
    CHECK(rows == 2000L * 200);
    const double e0 = energy.begin()->second;
    double maxGain = -1e300;
    for (const auto& [step, e] : energy) maxGain = std::max(maxGain, e - e0);
    MESSAGE("soak: energy at the first step " << e0 << " J, largest gain " << maxGain << " J, lowest centre " << lowest
                                              << " m, peak memory " << peak[500] << " MB after 500 steps, "
                                              << peak[2000] << " MB after 2000");
    CHECK(maxGain < 0.01 * e0);
    CHECK(lowest > 0.05);  // every centre above the floor (the smallest body's half size is 0.1)
    CHECK(s["deformations"].get<long>() > 0);
  }
  CHECK(peak[2000] < peak[500] * 1.1 + 20);  // memory does not grow with the steps
}

// --export gltf: read back with tinygltf's own loader (compiled here, external images loaded through stb_image:
// this test does not link crumple_engine, which compiles tinygltf without external images).
#include <stb/stb_image.h>
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_INCLUDE_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>

// The data of accessor `accessor` of a glTF model read back (tightly packed, as crumple writes them).
template <typename T>
const T* accessorData(const tinygltf::Model& model, int accessor) {
  const tinygltf::Accessor& a = model.accessors[static_cast<size_t>(accessor)];
  const tinygltf::BufferView& v = model.bufferViews[static_cast<size_t>(a.bufferView)];
  return reinterpret_cast<const T*>(model.buffers[static_cast<size_t>(v.buffer)].data.data() + v.byteOffset +
                                    a.byteOffset);
}

TEST_CASE("--export gltf writes every body at its final pose with its atlas, normal map and height map") {
  const fs::path out = kTmp / "export_gltf";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim(std::string(CRUMPLE_SCENES) + "/sphere-into-plate.json --out " + out.string() +
                     " --quiet --steps 60 --export gltf",
                 &log) == 0);
  CAPTURE(log);
  const json summary = json::parse(slurp(out / "summary.json"));
  const fs::path gltfPath = out / "export" / "scene.gltf";
  REQUIRE(fs::exists(gltfPath));
  // Inside the output folder: listed in its marker like every other file.
  const json marker = json::parse(slurp(out / ".crumple-output"));
  const std::vector<std::string> listed = marker["files"].get<std::vector<std::string>>();
  for (const char* f : {"export/scene.gltf", "export/scene.bin", "export/normalmaps/plate.png",
                        "export/heightmaps/plate.png", "export/normalmaps/ball.png", "export/heightmaps/ball.png"})
    CHECK(std::find(listed.begin(), listed.end(), f) != listed.end());

  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  const bool ok = loader.LoadASCIIFromFile(&model, &err, &warn, gltfPath.string());
  CAPTURE(err);
  CAPTURE(warn);
  REQUIRE(ok);
  CHECK(err.empty());
  CHECK(warn.empty());  // a missing image is a warning in tinygltf
  REQUIRE(model.scenes.size() == 1);
  REQUIRE(model.nodes.size() == summary["bodies"].size());
  CHECK(model.scenes[0].nodes.size() == model.nodes.size());
  for (size_t i = 0; i < model.nodes.size(); ++i) {
    const tinygltf::Node& node = model.nodes[i];
    const json& body = summary["bodies"][i];
    CAPTURE(node.name);
    CHECK(node.name == body["name"].get<std::string>());
    REQUIRE(node.translation.size() == 3);
    REQUIRE(node.rotation.size() == 4);
    for (int c = 0; c < 3; ++c) CHECK(node.translation[c] == doctest::Approx(body["position"][c].get<double>()).epsilon(1e-12));
    // glTF's rotation is (x, y, z, w); summary.json's orientation (w, x, y, z).
    for (int c = 0; c < 4; ++c)
      CHECK(node.rotation[c] == doctest::Approx(body["orientation"][(c + 1) % 4].get<double>()).epsilon(1e-12));
    REQUIRE(node.mesh >= 0);
    const tinygltf::Primitive& prim = model.meshes[static_cast<size_t>(node.mesh)].primitives.at(0);
    REQUIRE(prim.attributes.count("POSITION"));
    REQUIRE(prim.attributes.count("TEXCOORD_0"));
    const tinygltf::Accessor& uv = model.accessors[static_cast<size_t>(prim.attributes.at("TEXCOORD_0"))];
    CHECK(uv.count == model.accessors[static_cast<size_t>(prim.attributes.at("POSITION"))].count);
    CHECK(uv.type == TINYGLTF_TYPE_VEC2);
    // Every texture coordinate inside [0, 1]^2 (crumple's atlas, as it is: v = 0 at the image's first row).
    const float* uvs = accessorData<float>(model, prim.attributes.at("TEXCOORD_0"));
    size_t outside = 0;
    for (size_t k = 0; k < uv.count * 2; ++k) outside += !(uvs[k] >= 0.0f && uvs[k] <= 1.0f);
    CHECK(outside == 0);
    // The material: the normal map (loaded by tinygltf: the image was found) at the map's size.
    REQUIRE(prim.material >= 0);
    const tinygltf::Material& mat = model.materials[static_cast<size_t>(prim.material)];
    CHECK(mat.pbrMetallicRoughness.baseColorFactor.size() == 4);
    REQUIRE(mat.normalTexture.index >= 0);
    const tinygltf::Image& image =
        model.images[static_cast<size_t>(model.textures[static_cast<size_t>(mat.normalTexture.index)].source)];
    const crumple::gl::Image written = crumple::gl::readPng((out / "normalmaps" / (node.name + ".png")).string(), 3);
    CHECK(image.width == written.width);
    CHECK(image.height == written.height);
    REQUIRE(image.image.size() == static_cast<size_t>(image.width) * image.height * image.component);
    // Green inverted (crumple's green points down the image, glTF's up); red and blue as written.
    long mismatches = 0;
    for (size_t p = 0; p < static_cast<size_t>(image.width) * image.height; ++p)
      for (int c = 0; c < 3; ++c) {
        const int w = static_cast<int>(std::lround(written.pixels[p * 3 + c] * 255.0f));
        const int e = image.image[p * static_cast<size_t>(image.component) + c];
        mismatches += e != (c == 1 ? 255 - w : w);
      }
    CHECK(mismatches == 0);
    // TANGENT: crumple's own frame, so that a viewer bends the normals as crumple does. Per vertex, the tangent
    // lies along its triangles' dP/du and glTF's bitangent, cross(N, T) w, against dP/dv (it points up the image,
    // as the inverted green does).
    REQUIRE(prim.attributes.count("TANGENT"));
    REQUIRE(prim.attributes.count("NORMAL"));
    auto floats = [&](const char* attribute) { return accessorData<float>(model, prim.attributes.at(attribute)); };
    const tinygltf::Accessor& tangentAccessor = model.accessors[static_cast<size_t>(prim.attributes.at("TANGENT"))];
    CHECK(tangentAccessor.type == TINYGLTF_TYPE_VEC4);
    const float *tangent = floats("TANGENT"), *normal = floats("NORMAL"), *position = floats("POSITION");
    const tinygltf::Accessor& indexAccessor = model.accessors[static_cast<size_t>(prim.indices)];
    const uint32_t* index = accessorData<uint32_t>(model, prim.indices);
    auto vec3 = [](const float* p, size_t i) { return glm::dvec3(p[i * 3], p[i * 3 + 1], p[i * 3 + 2]); };
    size_t along = 0, against = 0, frames = 0;
    for (size_t t = 0; t + 2 < indexAccessor.count; t += 3) {
      const size_t i0 = index[t], i1 = index[t + 1], i2 = index[t + 2];
      const glm::dvec3 e1 = vec3(position, i1) - vec3(position, i0), e2 = vec3(position, i2) - vec3(position, i0);
      const glm::dvec2 d1(uvs[i1 * 2] - uvs[i0 * 2], uvs[i1 * 2 + 1] - uvs[i0 * 2 + 1]);
      const glm::dvec2 d2(uvs[i2 * 2] - uvs[i0 * 2], uvs[i2 * 2 + 1] - uvs[i0 * 2 + 1]);
      const double det = d1.x * d2.y - d1.y * d2.x;
      if (std::abs(det) < 1e-12) continue;
      const glm::dvec3 pu = glm::normalize((e1 * d2.y - e2 * d1.y) / det), pv = glm::normalize((e2 * d1.x - e1 * d2.x) / det);
      for (size_t v : {i0, i1, i2}) {
        const glm::dvec3 T(tangent[v * 4], tangent[v * 4 + 1], tangent[v * 4 + 2]);
        const glm::dvec3 B = glm::cross(vec3(normal, v), T) * static_cast<double>(tangent[v * 4 + 3]);
        CHECK(std::abs(glm::length(T) - 1) < 1e-4);
        CHECK(std::abs(tangent[v * 4 + 3]) == 1.0f);
        ++frames;
        along += glm::dot(T, pu) > 0.5;
        against += glm::dot(B, pv) < -0.5;
      }
    }
    CHECK(frames > 0);
    // (A vertex on a sharp edge inside a chart averages two faces: its frame is the average; nearly all agree.)
    CHECK(along > frames * 0.95);
    CHECK(against > frames * 0.95);
    // The height map: named in the extras, beside the .gltf, the same file as heightmaps/.
    REQUIRE(mat.extras.IsObject());
    REQUIRE(mat.extras.Has("crumple_height_map"));
    const std::string heightRel = mat.extras.Get("crumple_height_map").Get<std::string>();
    const fs::path heightPath = gltfPath.parent_path() / heightRel;
    REQUIRE(fs::exists(heightPath));
    CHECK(slurp(heightPath) == slurp(out / "heightmaps" / (node.name + ".png")));
    REQUIRE(mat.extras.Has("bump_depth"));
    CHECK(mat.extras.Get("bump_depth").GetNumberAsDouble() == doctest::Approx(0.1));
  }
  // Another format is bad input.
  CHECK(runSim("--out " + (kTmp / "export_bad").string() + " --quiet --export obj") == 2);
  CHECK(!fs::exists(kTmp / "export_bad"));
}

TEST_CASE("--export gltf bakes a procedural surface into base colour and roughness textures over the atlas") {
  // wrecking-ball: the wall is clay, the ground concrete (each with a map, so an atlas); the ball plain steel.
  const fs::path out = kTmp / "export_baked";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim(std::string(CRUMPLE_SCENES) + "/wrecking-ball.json --out " + out.string() +
                     " --quiet --steps 2 --export gltf",
                 &log) == 0);
  CAPTURE(log);
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  REQUIRE(loader.LoadASCIIFromFile(&model, &err, &warn, (out / "export" / "scene.gltf").string()));
  CHECK(warn.empty());
  auto srgbToLinear = [](double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); };
  struct Expect {
    const char* body;
    glm::dvec3 color;  // the scene's sRGB colour
    double roughness;
  };
  for (const Expect& e : {Expect{"wall", {0.72, 0.5, 0.36}, 0.75}, Expect{"ground", {0.35, 0.34, 0.32}, 0.95}}) {
    CAPTURE(e.body);
    const auto mat = std::find_if(model.materials.begin(), model.materials.end(),
                                  [&](const tinygltf::Material& m) { return m.name == e.body; });
    REQUIRE(mat != model.materials.end());
    const auto& pbr = mat->pbrMetallicRoughness;
    REQUIRE(pbr.baseColorTexture.index >= 0);
    REQUIRE(pbr.metallicRoughnessTexture.index >= 0);
    CHECK(pbr.baseColorFactor == std::vector<double>{1, 1, 1, 1});
    CHECK(pbr.roughnessFactor == 1.0);
    const tinygltf::Image& base =
        model.images[static_cast<size_t>(model.textures[static_cast<size_t>(pbr.baseColorTexture.index)].source)];
    const tinygltf::Image& mr =
        model.images[static_cast<size_t>(model.textures[static_cast<size_t>(pbr.metallicRoughnessTexture.index)].source)];
    REQUIRE(base.component >= 3);
    REQUIRE(mr.component >= 3);
    REQUIRE(base.width == mr.width);
    // Over the texels a chart covers (the rest black): the mean linear colour is the material's times an albedo of
    // about 1 (the procedural surface averages 1), and it varies (a surface, not a flat fill).
    glm::dvec3 sum(0);
    double lum = 0, lum2 = 0, rough = 0;
    size_t n = 0;
    for (size_t i = 0; i < static_cast<size_t>(base.width) * static_cast<size_t>(base.height); ++i) {
      const unsigned char* px = &base.image[i * static_cast<size_t>(base.component)];
      if (px[0] == 0 && px[1] == 0 && px[2] == 0) continue;
      const glm::dvec3 c(srgbToLinear(px[0] / 255.0), srgbToLinear(px[1] / 255.0), srgbToLinear(px[2] / 255.0));
      sum += c;
      const double l = c.r + c.g + c.b;
      lum += l;
      lum2 += l * l;
      rough += mr.image[i * static_cast<size_t>(mr.component) + 1] / 255.0;
      ++n;
    }
    REQUIRE(n > static_cast<size_t>(base.width * base.height) / 10);
    const glm::dvec3 mean = sum / double(n);
    for (int c = 0; c < 3; ++c) CHECK(mean[c] == doctest::Approx(srgbToLinear(e.color[c])).epsilon(0.15));
    const double meanLum = lum / double(n), spread = std::sqrt(std::max(0.0, lum2 / double(n) - meanLum * meanLum));
    CHECK(spread / meanLum > 0.02);
    CHECK(rough / double(n) == doctest::Approx(e.roughness).epsilon(0.12));
    CHECK(fs::exists(out / "export" / "textures" / (std::string(e.body) + "_base.png")));
  }
  // A material without a procedural surface keeps its factors alone.
  const auto ball = std::find_if(model.materials.begin(), model.materials.end(),
                                 [](const tinygltf::Material& m) { return m.name == "ball"; });
  REQUIRE(ball != model.materials.end());
  CHECK(ball->pbrMetallicRoughness.baseColorTexture.index < 0);
}

TEST_CASE("--export gltf --animate plays the run: every moving body's poses at the frames' times") {
  const fs::path out = kTmp / "export_animated";
  fs::remove_all(out);
  std::string log;
  // 60 steps at 240 Hz, --fps 30: key frames at steps 0, 8, ..., 56 and the last step.
  REQUIRE(runSim(std::string(CRUMPLE_SCENES) + "/sphere-into-plate.json --out " + out.string() +
                     " --quiet --steps 60 --export gltf --animate",
                 &log) == 0);
  CAPTURE(log);
  const json summary = json::parse(slurp(out / "summary.json"));
  const json scene = json::parse(slurp(fs::path(CRUMPLE_SCENES) / "sphere-into-plate.json"));
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  REQUIRE(loader.LoadASCIIFromFile(&model, &err, &warn, (out / "export" / "scene.gltf").string()));
  REQUIRE(model.animations.size() == 1);
  const tinygltf::Animation& anim = model.animations[0];
  CHECK(anim.name == "run");
  auto floats = [&](int accessor) {
    const tinygltf::Accessor& a = model.accessors[static_cast<size_t>(accessor)];
    const float* p = accessorData<float>(model, accessor);
    const int width = a.type == TINYGLTF_TYPE_SCALAR ? 1 : a.type == TINYGLTF_TYPE_VEC3 ? 3 : 4;
    return std::vector<float>(p, p + a.count * static_cast<size_t>(width));
  };
  // Only the bodies that move: the ball, not the static plate; a translation and a rotation channel.
  std::set<std::string> animated;
  for (const tinygltf::AnimationChannel& c : anim.channels) {
    const std::string name = model.nodes[static_cast<size_t>(c.target_node)].name;
    animated.insert(name + "." + c.target_path);
    const tinygltf::AnimationSampler& sampler = anim.samplers[static_cast<size_t>(c.sampler)];
    CHECK(sampler.interpolation == "LINEAR");
    const std::vector<float> times = floats(sampler.input);
    REQUIRE(times.size() == 9);
    CHECK(times.front() == 0.0f);
    CHECK(times[1] == doctest::Approx(8.0 / 240));
    CHECK(times.back() == doctest::Approx(60.0 / 240));
    const std::vector<float> values = floats(sampler.output);
    const tinygltf::Node& node = model.nodes[static_cast<size_t>(c.target_node)];
    const json* start = nullptr;
    for (const json& b : scene["bodies"])
      if (b["name"] == name) start = &b;
    REQUIRE(start);
    if (c.target_path == "translation") {
      // From where the scene puts it to where the run left it (the node's own pose).
      for (int k = 0; k < 3; ++k) {
        CHECK(values[static_cast<size_t>(k)] == doctest::Approx((*start)["position"][k].get<double>()).epsilon(1e-6));
        CHECK(values[values.size() - 3 + static_cast<size_t>(k)] == doctest::Approx(node.translation[static_cast<size_t>(k)]).epsilon(1e-6));
      }
    } else {
      REQUIRE(c.target_path == "rotation");
      for (int k = 0; k < 4; ++k)
        CHECK(std::abs(values[values.size() - 4 + static_cast<size_t>(k)]) == doctest::Approx(std::abs(node.rotation[static_cast<size_t>(k)])).epsilon(1e-6));
      for (size_t f = 4; f < values.size(); f += 4) {  // consecutive keys in one hemisphere: the short way round
        double dot = 0;
        for (size_t k = 0; k < 4; ++k) dot += double(values[f + k]) * values[f - 4 + k];
        CHECK(dot > 0);
      }
    }
  }
  CHECK(animated == std::set<std::string>{"ball.translation", "ball.rotation"});
  // --animate without --export is bad input.
  CHECK(runSim("--out " + (kTmp / "animate_bad").string() + " --quiet --animate") == 2);
  CHECK(!fs::exists(kTmp / "animate_bad"));
}

TEST_CASE("--export gltf carries a vehicle's wheels and tracks as nodes on its body, animated with it") {
  // tank-tracks: a tank on 8 road wheels with a belt and grousers on each side.
  const fs::path out = kTmp / "export_vehicle";
  fs::remove_all(out);
  std::string log;
  REQUIRE(runSim(std::string(CRUMPLE_SCENES) + "/tank-tracks.json --out " + out.string() +
                     " --quiet --steps 24 --export gltf --animate",
                 &log) == 0);
  CAPTURE(log);
  const json summary = json::parse(slurp(out / "summary.json"));
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  REQUIRE(loader.LoadASCIIFromFile(&model, &err, &warn, (out / "export" / "scene.gltf").string()));
  const size_t bodies = summary["bodies"].size();
  REQUIRE(model.nodes.size() == bodies + 8 + 2 + 2);
  const auto tank = std::find_if(model.nodes.begin(), model.nodes.end(),
                                 [](const tinygltf::Node& n) { return n.name == "tank"; });
  REQUIRE(tank != model.nodes.end());
  REQUIRE(tank->children.size() == 12);
  std::map<std::string, int> kinds;
  std::set<int> children(tank->children.begin(), tank->children.end());
  for (int c : tank->children) {
    const tinygltf::Node& part = model.nodes[static_cast<size_t>(c)];
    CAPTURE(part.name);
    CHECK(static_cast<size_t>(c) >= bodies);  // after the bodies' nodes, not roots of the scene
    CHECK(std::find(model.scenes[0].nodes.begin(), model.scenes[0].nodes.end(), c) == model.scenes[0].nodes.end());
    REQUIRE(part.mesh >= 0);
    const tinygltf::Primitive& prim = model.meshes[static_cast<size_t>(part.mesh)].primitives.at(0);
    CHECK(model.accessors[static_cast<size_t>(prim.attributes.at("POSITION"))].count > 0);
    REQUIRE(part.translation.size() == 3);
    // On the body: within a few metres of its origin, in its frame.
    CHECK(std::hypot(part.translation[0], part.translation[1], part.translation[2]) < 4.0);
    kinds[part.name.substr(5, part.name.find_last_not_of("0123456789") - 4)]++;
  }
  CHECK(kinds == std::map<std::string, int>{{"belt", 2}, {"grousers", 2}, {"wheel", 8}});
  // Each part node has its own channels in the animation, with the bodies' key times.
  REQUIRE(model.animations.size() == 1);
  std::map<int, int> channels;
  for (const tinygltf::AnimationChannel& c : model.animations[0].channels) channels[c.target_node]++;
  for (int c : tank->children) CHECK(channels[c] == 2);
}

TEST_CASE("--video without ffmpeg on PATH is bad input with a clear message") {
  const fs::path out = kTmp / "video_noffmpeg";
  fs::remove_all(out);
  fs::create_directories(kTmp / "empty_path");
  // An empty PATH: no ffmpeg whether or not the machine has one.
  const std::string cmd = "env PATH=" + (kTmp / "empty_path").string() + " " + std::string(CRUMPLE_SIM) + " --out " +
                          out.string() + " --render --video " + (kTmp / "v.mp4").string() + " > " +
                          (kTmp / "video.log").string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  const std::string log = slurp(kTmp / "video.log");
  CAPTURE(log);
  CHECK((WIFEXITED(rc) ? WEXITSTATUS(rc) : -1) == 2);
  CHECK(log.find("--video needs ffmpeg (apt-get install ffmpeg)") != std::string::npos);
  CHECK(!fs::exists(out));
  CHECK(!fs::exists(kTmp / "v.mp4"));
}

TEST_CASE("--video encodes the first camera's frames with ffmpeg (when installed)") {
  if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0) {
    MESSAGE("ffmpeg is not installed (apt-get install ffmpeg): --video's encoding is not tested");
    return;
  }
  const fs::path out = kTmp / "video", video = kTmp / "run.mp4";
  fs::remove_all(out);
  fs::remove(video);
  std::string log;
  REQUIRE(runSim("--out " + out.string() + " --quiet --steps 48 --size 64x48 --video " + video.string(), &log) == 0);
  CAPTURE(log);
  CHECK(fs::exists(out / "frames"));  // --video implies --render
  REQUIRE(fs::exists(video));
  CHECK(fs::file_size(video) > 0);
  CHECK(slurp(video).substr(4, 4) == "ftyp");  // an MP4 container
  CHECK(runSim("--out " + out.string() + " --quiet --steps 8 --video " + video.string() + " --video-camera nope") == 2);
}

TEST_CASE("--video hands ffmpeg the chosen camera's frames at the frame rate, into a file renamed when done") {
  // A stand-in ffmpeg on PATH that writes its arguments and the frames it was given into the output file.
  const fs::path bin = kTmp / "fake_ffmpeg_bin";
  fs::create_directories(bin);
  std::ofstream(bin / "ffmpeg") << "#!/bin/sh\n"
                                   "for a; do last=$a; done\n"
                                   "prev=; for a; do [ \"$prev\" = -i ] && in=$a; prev=$a; done\n"
                                   "{ printf '%s\\n' \"$@\"; echo FRAMES; ls \"$(dirname \"$in\")\"; } > \"$last\"\n";
  fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
  const std::string scene = writeScene("two_cams.json", R"({
    "format": "crumple-scene/1", "name": "two_cams", "timestep": 0.004166666666666667, "duration": 0.1,
    "materials": {"wood": {"density": 600}},
    "bodies": [{"name": "box", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]}, "material": "wood",
                "position": [0, 1, 0]}],
    "cameras": [{"name": "front", "position": [0, 1, 4], "target": [0, 1, 0]},
                {"name": "side", "position": [4, 1, 0], "target": [0, 1, 0]}]})").string();
  const fs::path out = kTmp / "video_fake", video = kTmp / "fake.mp4";
  fs::remove_all(out);
  fs::remove(video);
  const std::string cmd = "env PATH=" + bin.string() + ":/usr/bin:/bin " + std::string(CRUMPLE_SIM) + " " + scene +
                          " --out " + out.string() + " --quiet --steps 16 --size 32x32 --video " + video.string() +
                          " --video-camera side > " + (kTmp / "video_fake.log").string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  CAPTURE(slurp(kTmp / "video_fake.log"));
  REQUIRE((WIFEXITED(rc) ? WEXITSTATUS(rc) : -1) == 0);
  const std::string args = slurp(video);
  CAPTURE(args);
  CHECK(args.find("-framerate\n30.000000\n") != std::string::npos);  // 1 / (8 steps x 1/240 s)
  CHECK(args.find("/frames/side_%05d.png\n") != std::string::npos);
  CHECK(args.find("libx264") != std::string::npos);
  CHECK(args.find("side_00002.png") != std::string::npos);  // the frames were there when ffmpeg ran
  CHECK(fs::exists(out / "frames" / "front_00002.png"));     // --video implies --render
  for (const auto& e : fs::directory_iterator(kTmp))          // no temporary video left behind
    CHECK(e.path().filename().string().find(".fake.partial-") == std::string::npos);
  // A camera the scene does not have is bad input, before the run.
  fs::remove_all(out);
  const std::string bad = "env PATH=" + bin.string() + ":/usr/bin:/bin " + std::string(CRUMPLE_SIM) + " " + scene +
                          " --out " + out.string() + " --quiet --steps 16 --video " + video.string() +
                          " --video-camera nope > /dev/null 2>&1";
  const int badRc = std::system(bad.c_str());
  CHECK((WIFEXITED(badRc) ? WEXITSTATUS(badRc) : -1) == 2);
  CHECK(!fs::exists(out));
}

TEST_CASE("motion a crash makes runs to the end with every number finite: a cow on a spinning ground, a 1 kg car") {
  // Both ended with SIGSEGV (a NaN pose reached a distance field's grid) or wrote null positions.
  const std::string scenes = CRUMPLE_SCENES;
  const fs::path cow = kTmp / "spin-cow", car = kTmp / "light-car";
  CHECK(runSim(scenes + "/cow-drop.json --out " + cow.string() + " --quiet --steps 240 --set bodies[ground].static=false "
               "--set bodies[ground].kinematic=true --set 'bodies[ground].angular_velocity=[50,0,0]'") == 0);
  CHECK(runSim(scenes + "/highway.json --out " + car.string() + " --quiet --steps 240 --set 'bodies[car].mass=1'") == 0);
  for (const fs::path& dir : {cow, car}) {
    CAPTURE(dir.string());
    const nlohmann::json summary = nlohmann::json::parse(slurp(dir / "summary.json"));
    int numbers = 0;
    for (const auto& b : summary["bodies"])
      for (const char* key : {"position", "orientation", "linear_velocity", "angular_velocity"})
        for (const auto& x : b[key]) {
          REQUIRE(x.is_number());
          CHECK(std::isfinite(x.get<double>()));
          ++numbers;
        }
    CHECK(numbers > 10);
    // No event line carries a number that is not finite (null).
    CHECK(slurp(dir / "events.jsonl").find("null") == std::string::npos);
  }
}

namespace {
// A small scene without bump maps (no GL context): `extra` goes into its top level, `camera` is its camera's name.
std::string smallScene(const std::string& extra, const std::string& camera = "main") {
  return R"({"format": "crumple-scene/1", )" + extra + R"( "duration": 0.05,
    "materials": {"steel": {"density": 7800}},
    "bodies": [{"name": "floor", "shape": {"type": "box", "size": [2, 0.2, 2]}, "material": "steel", "static": true},
               {"name": "ball", "shape": {"type": "sphere", "radius": 0.1}, "material": "steel", "position": [0, 1, 0]}],
    "cameras": [{"name": ")" +
         camera + R"(", "position": [2, 1, 2], "target": [0, 0, 0]}]})";
}

// Runs `shellCommand` (stdout and stderr into the log) and returns its exit status (-1 when killed).
int runShell(const std::string& shellCommand, std::string* output) {
  const fs::path log = kTmp / "shell-log.txt";
  const int rc = std::system(("( " + shellCommand + " ) > " + log.string() + " 2>&1").c_str());
  *output = slurp(log);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

bool anyPathNamed(const fs::path& root, const std::string& name) {
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator(); ++it)
    if (it->path().filename() == name) return true;
  return false;
}
}  // namespace

TEST_CASE(
    "a scene's name makes out/<name>: '../../escaped', '..' or a long name is bad input (exit 2), nothing written") {
  const fs::path cwd = kTmp / "name_cwd" / "run";
  fs::remove_all(kTmp / "name_cwd");
  fs::create_directories(cwd);
  std::string log;
  writeScene("escaping.json", smallScene(R"("name": "../../escaped",)"));
  // Without --out the output folder is out/<name>: out/../../escaped is beside the working folder.
  CHECK(runShell("cd " + cwd.string() + " && " + CRUMPLE_SIM + " " + (kTmp / "escaping.json").string() + " --quiet",
                 &log) == 2);
  CHECK(log == "crumple-sim: error: " + (kTmp / "escaping.json").string() +
                   ": name: must not contain '/', '\\' or control characters (it names output files)\n");
  CHECK_FALSE(anyPathNamed(kTmp / "name_cwd", "escaped"));
  CHECK_FALSE(fs::exists(cwd / "out"));
  // A file named "...json" without a "name" would be the scene "..": out/.. is the working folder.
  writeScene("...json", smallScene(""));
  CHECK(runShell("cd " + cwd.string() + " && " + CRUMPLE_SIM + " " + (kTmp / "...json").string() + " --quiet", &log) ==
        2);
  CHECK(log.find(": name: the file name's '..', the scene's name without a \"name\", must not be '.' or '..'") !=
        std::string::npos);
  CHECK(fs::is_empty(cwd));
  // A name set on the command line is checked the same way.
  writeScene("named.json", smallScene(R"("name": "fine",)"));
  CHECK(runShell("cd " + cwd.string() + " && " + CRUMPLE_SIM + " " + (kTmp / "named.json").string() +
                     " --quiet --set 'name=\"../up\"'",
                 &log) == 2);
  CHECK(log.find("named.json: name: must not contain '/'") != std::string::npos);
  CHECK(fs::is_empty(cwd));
  // A good name runs into out/<name>.
  CHECK(runShell("cd " + cwd.string() + " && " + CRUMPLE_SIM + " " + (kTmp / "named.json").string() + " --quiet",
                 &log) == 0);
  CHECK(fs::exists(cwd / "out" / "fine" / "summary.json"));
}

TEST_CASE(
    "only regular files are read as scenes and meshes: a FIFO, /dev/zero or a 65 MiB scene is bad input at once") {
  std::string log;
  const fs::path fifo = kTmp / "fifo.json";
  fs::create_directories(kTmp);
  fs::remove(fifo);
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  // A FIFO used to block crumple-sim for good (SIGTERM ignored): `timeout -s KILL` ends such a run with -1.
  CHECK(runShell("timeout -s KILL 20 " + std::string(CRUMPLE_SIM) + " " + fifo.string() + " --out " +
                     (kTmp / "fifo_out").string(),
                 &log) == 2);
  CHECK(log ==
        "crumple-sim: error: " + fifo.string() + ": is a FIFO (named pipe), not a regular file: refusing to read it\n");
  // /dev/zero used to be read to 4 GB (here, in 2 GB of address space, to a failure, exit 1).
  CHECK(runShell(memoryCap() + "timeout -s KILL 20 " + std::string(CRUMPLE_SIM) + " /dev/zero --out " +
                     (kTmp / "zero_out").string(),
                 &log) == 2);
  CHECK(log == "crumple-sim: error: /dev/zero: is a character device, not a regular file: refusing to read it\n");
  // Over 64 MiB (sparse).
  const fs::path big = writeScene("big.json", "{}");
  fs::resize_file(big, std::uintmax_t(65) << 20);
  CHECK(runSim(big.string() + " --out " + (kTmp / "big_out").string(), &log) == 2);
  CHECK(log.find(big.string() + ": is larger than 64 MiB (68157440 bytes): refusing to read it") != std::string::npos);
  fs::remove(big);
  // A FIFO as a body's mesh: named for what it is, at the key path.
  const fs::path meshFifo = kTmp / "fifo.obj";
  fs::remove(meshFifo);
  REQUIRE(::mkfifo(meshFifo.c_str(), 0600) == 0);
  std::string scene = smallScene(R"("name": "fifo-mesh",)");
  const std::string ball = R"({"type": "sphere", "radius": 0.1})";
  scene.replace(scene.find(ball), ball.size(), R"({"type": "mesh", "file": "fifo.obj"})");
  writeScene("fifo-mesh.json", scene);
  CHECK(runShell("timeout -s KILL 20 " + std::string(CRUMPLE_SIM) + " " + (kTmp / "fifo-mesh.json").string() +
                     " --out " + (kTmp / "fifo_mesh_out").string(),
                 &log) == 2);
  CHECK(log.find("fifo-mesh.json: bodies[1].shape.file: " + meshFifo.string() + ": is a FIFO (named pipe)") !=
        std::string::npos);
  for (const char* out : {"fifo_out", "zero_out", "big_out", "fifo_mesh_out"}) CHECK_FALSE(fs::exists(kTmp / out));
  CHECK(noPartialFolders());
  fs::remove(fifo);
  fs::remove(meshFifo);
}

TEST_CASE("SIGTERM while a scene loads ends crumple-sim at once with 130 and writes nothing") {
  // A sheet of 97000 triangles without texture coordinates: its atlas takes crumple-sim many seconds to make.
  {
    std::ofstream obj(kTmp / "slow.obj");
    const int n = 220;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j)
        obj << "v " << double(i) / n << " " << 0.05 * std::sin(i * 0.7) * std::cos(j * 0.9) << " " << double(j) / n
            << "\n";
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const int a = i * (n + 1) + j + 1, b = a + 1, c = a + n + 2, d = a + n + 1;
        obj << "f " << a << " " << b << " " << c << "\nf " << a << " " << c << " " << d << "\n";
      }
  }
  std::string scene = smallScene(R"("name": "slow",)");
  const std::string floor = R"({"type": "box", "size": [2, 0.2, 2]})";
  scene.replace(scene.find(floor), floor.size(), R"({"type": "mesh", "file": "slow.obj"})");
  writeScene("slow.json", scene);
  const fs::path out = kTmp / "slow_out";
  fs::remove_all(out);
  const std::string sim = CRUMPLE_SIM, scenePath = (kTmp / "slow.json").string(), outPath = out.string(),
                    logPath = (kTmp / "slow-log.txt").string();
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    std::freopen(logPath.c_str(), "w", stderr);
    ::execl(sim.c_str(), sim.c_str(), scenePath.c_str(), "--out", outPath.c_str(), "--quiet",
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  ::kill(pid, SIGTERM);
  // It used to go on loading (the signal noted for the first step): many seconds more.
  const auto t0 = std::chrono::steady_clock::now();
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() - t0 > std::chrono::seconds(5)) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      FAIL("crumple-sim was still loading 5 s after SIGTERM");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  CAPTURE(slurp(logPath));
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 130);
  CHECK(slurp(logPath).find("crumple-sim: interrupted while loading: nothing written") != std::string::npos);
  CHECK_FALSE(fs::exists(out));
  CHECK(noPartialFolders());
}

namespace {
std::string firstLineOf(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  return line;
}

// This process's start time (/proc/self/stat's 22nd field).
std::string ownStartTime() {
  const std::string stat = firstLineOf("/proc/self/stat");
  std::istringstream fields(stat.substr(stat.rfind(')') + 1));
  std::string field;
  for (int i = 3; i <= 22; ++i) fields >> field;
  return field;
}

// A staging folder as a crumple-sim run makes it, with a file in it, and a marker naming `owner` (none: no marker).
void fakeStaging(const fs::path& dir, const json* owner) {
  fs::create_directories(dir / "heightmaps");
  std::ofstream(dir / "heightmaps" / "floor.png") << "png";
  if (owner)
    std::ofstream(dir / ".crumple-output")
        << json{{"format", "crumple-output/1"}, {"files", json::array()}, {"owner", *owner}};
}
}  // namespace

TEST_CASE(
    "a staging folder left by a killed run is removed by the next run to its folder; a live run's, or one "
    "without crumple's marker, never is") {
  const fs::path root = kTmp / "stale";
  fs::remove_all(root);
  fs::create_directories(root);
  const fs::path out = root / "run";
  std::string log;
  // A run killed outright while it writes: its staging folder stays behind.
  const std::string sim = CRUMPLE_SIM, scenePath = std::string(CRUMPLE_SCENES) + "/highway.json",
                    outPath = out.string();
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    std::freopen("/dev/null", "w", stderr);
    ::execl(sim.c_str(), sim.c_str(), scenePath.c_str(), "--duration", "1000", "--quiet", "--out", outPath.c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  fs::path killed;
  for (int i = 0; i < 1200 && killed.empty(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    for (const auto& e : fs::directory_iterator(root))
      if (e.path().filename().string().rfind("run.partial-", 0) == 0 && fs::exists(e.path() / ".crumple-output"))
        killed = e.path();
  }
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  REQUIRE_FALSE(killed.empty());
  REQUIRE(fs::exists(killed));
  const json marker = json::parse(slurp(killed / ".crumple-output"));
  CHECK(marker["owner"]["pid"] == pid);

  // Folders of other owners beside it.
  const std::string boot = firstLineOf("/proc/sys/kernel/random/boot_id");
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  const json self = {{"pid", ::getpid()}, {"start_time", ownStartTime()}, {"boot_id", boot}, {"host", host}};
  json reused = self, rebooted = self, elsewhere = self;
  reused["start_time"] = "1";                                    // this pid, another process before it: gone
  rebooted["boot_id"] = "00000000-0000-0000-0000-000000000000";  // before a reboot: gone
  elsewhere["host"] = std::string(host) + "-another-machine";    // cannot tell: kept
  fakeStaging(root / "run.partial-1-1", &self);                  // this test runs: kept
  fakeStaging(root / "run.partial-2-2", &reused);                // removed
  fakeStaging(root / "run.partial-3-3", &rebooted);              // removed
  fakeStaging(root / "run.partial-4-4", &elsewhere);             // kept
  fakeStaging(root / "run.partial-5-5", nullptr);                // no marker: kept
  fakeStaging(root / "run.partial-6-6.old", &reused);            // not a staging folder's name: kept
  fakeStaging(root / "other.partial-7-7", &reused);              // another folder's: kept
  fakeStaging(root / "target", &reused);
  fs::create_directory_symlink(root / "target", root / "run.partial-8-8");  // a link: kept, its target too
  {
    json noOwner = {{"format", "crumple-output/1"}, {"files", json::array()}};  // an output's marker: kept
    fs::create_directories(root / "run.partial-9-9");
    std::ofstream(root / "run.partial-9-9" / ".crumple-output") << noOwner;
  }

  REQUIRE(runSim(std::string(CRUMPLE_SCENES) + "/highway.json --steps 3 --quiet --out " + out.string(), &log) == 0);
  CAPTURE(log);
  CHECK_FALSE(fs::exists(killed));
  CHECK_FALSE(fs::exists(root / "run.partial-2-2"));
  CHECK_FALSE(fs::exists(root / "run.partial-3-3"));
  for (const char* kept : {"run.partial-1-1", "run.partial-4-4", "run.partial-5-5", "run.partial-6-6.old",
                           "other.partial-7-7", "run.partial-8-8", "run.partial-9-9"}) {
    CAPTURE(kept);
    CHECK(fs::exists(root / kept / ".crumple-output") == (std::string(kept) != "run.partial-5-5"));
    CHECK(fs::exists(root / kept));
  }
  CHECK(fs::exists(root / "target" / "heightmaps" / "floor.png"));
  // The output's marker lists its files, not itself, and names no owner.
  const json done = json::parse(slurp(out / ".crumple-output"));
  CHECK_FALSE(done.contains("owner"));
  CHECK(std::find(done["files"].begin(), done["files"].end(), ".crumple-output") == done["files"].end());
  CHECK(std::find(done["files"].begin(), done["files"].end(), "summary.json") != done["files"].end());
  fs::remove_all(root);
}

TEST_CASE(
    "bad UTF-8, a 5000-character camera name and a key of 60000 parts are bad input (exit 2) in a short message") {
  std::string log;
  writeScene("utf8.json", smallScene(R"("name": "utf8",)"));
  const std::string scene = (kTmp / "utf8.json").string(), out = " --out " + (kTmp / "utf8_out").string();
  CHECK(runShell(std::string(CRUMPLE_SIM) + " " + scene +
                     " --steps 2 --set \"bodies[ball].name=$(printf 'ball\\377')\"" + out,
                 &log) == 2);
  CHECK(log == "crumple-sim: error: " + scene + ": bodies[ball].name: the value 'ball\\xFF' is not valid UTF-8\n");
  CHECK(runShell(std::string(CRUMPLE_SIM) + " " + scene +
                     " --steps 2 --set \"$(printf 'bodies[b\\351].velocity')=[0,1,0]\"" + out,
                 &log) == 2);
  CHECK(log == "crumple-sim: error: " + scene + ": bodies[b\\xE9].velocity: bad key path: not valid UTF-8\n");
  // A camera name of 5000 characters used to fail at the first frame (exit 1, a 5 KB message).
  writeScene("long-camera.json", smallScene(R"("name": "long-camera",)", std::string(5000, 'c')));
  CHECK(runSim((kTmp / "long-camera.json").string() + " --steps 2 --render --size 16x16" + out, &log) == 2);
  CHECK(log == "crumple-sim: error: " + (kTmp / "long-camera.json").string() +
                   ": cameras[0].name: longer than 128 characters\n");
  // 60000 dotted parts (memory grew with their square: here 2 GB of address space would not have been enough).
  std::string key = "a";
  for (int i = 1; i < 60000; ++i) key += ".a";
  std::ofstream(kTmp / "key.txt") << key << "=1";
  CHECK(runShell(memoryCap() + std::string(CRUMPLE_SIM) + " " + scene + " --set \"$(cat " +
                     (kTmp / "key.txt").string() + ")\"" + out,
                 &log) == 2);
  CHECK(log.find("bad key path: longer than 1024 characters (119999)") != std::string::npos);
  CHECK(log.size() < 300);
  CHECK_FALSE(fs::exists(kTmp / "utf8_out"));
}
