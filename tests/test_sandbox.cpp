// crumple-sandbox under Xvfb: the autopilot drives into the rails; the window's
// last frame is a real picture and both the car and a rail are dented.
#include <doctest/doctest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <crumple/gl/image.h>

namespace fs = std::filesystem;

TEST_CASE("sandbox: --frames 150 --autopilot --screenshot ends with a picture and dented car and rail") {
  const fs::path dir = fs::temp_directory_path() / ("crumple_sandbox_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path shot = dir / "shot.png", out = dir / "out", log = dir / "log.txt";
  // In the sanitizer build, LeakSanitizer's tracer itself crashes (signal 11) at the exit of a GLX
  // process whose llvmpipe threads are still up; address and undefined-behaviour checks stay on.
  const char* asan = std::getenv("ASAN_OPTIONS");
  const std::string options = std::string(asan ? asan : "") + (asan ? ":" : "") + "detect_leaks=0";
  setenv("ASAN_OPTIONS", options.c_str(), 1);
  const std::string cmd = std::string(CRUMPLE_SANDBOX) +
                          " --frames 150 --autopilot --width 480 --height 270 --screenshot " + shot.string() +
                          " --out " + out.string() + " > " + log.string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  std::ifstream lf(log);
  std::stringstream ls;
  ls << lf.rdbuf();
  CAPTURE(ls.str());
  REQUIRE(WIFEXITED(rc));
  REQUIRE(WEXITSTATUS(rc) == 0);
  const crumple::gl::Image img = crumple::gl::readPng(shot.string(), 3);
  CHECK(img.width == 480);
  CHECK(img.height == 270);
  // Not blank: many distinct grey levels and real contrast.
  double mean = 0, var = 0;
  for (float v : img.pixels) mean += v;
  mean /= img.pixels.size();
  for (float v : img.pixels) var += (v - mean) * (v - mean);
  var /= img.pixels.size();
  CHECK(var > 0.002);
  // The car and one of the rail's segments are dented.
  auto lowest = [](const fs::path& map) {
    float low = 1;
    for (float v : crumple::gl::readPng(map.string()).pixels) low = std::min(low, v);
    return low;
  };
  CHECK(lowest(out / "heightmaps" / "car.png") < 0.49f);
  float rail = 1;
  for (const auto& f : fs::directory_iterator(out / "heightmaps"))
    if (f.path().filename().string().rfind("rail_", 0) == 0) rail = std::min(rail, lowest(f.path()));
  CHECK(rail < 0.49f);
}

TEST_CASE(
    "sandbox: a fixed render scale renders the view smaller and scales it to the window; bad scales are bad input") {
  const fs::path dir = fs::temp_directory_path() / ("crumple_sandbox_scale_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const char* asan = std::getenv("ASAN_OPTIONS");
  const std::string options = std::string(asan ? asan : "") + (asan ? ":" : "") + "detect_leaks=0";
  setenv("ASAN_OPTIONS", options.c_str(), 1);
  auto run = [&](const std::string& args, std::string& out) {
    const fs::path log = dir / "log.txt";
    const int rc = std::system((std::string(CRUMPLE_SANDBOX) + " " + args + " > " + log.string() + " 2>&1").c_str());
    std::ifstream lf(log);
    std::stringstream ls;
    ls << lf.rdbuf();
    out = ls.str();
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  };
  std::string log;
  const fs::path shot = dir / "half.png";
  REQUIRE(run("--frames 5 --width 320 --height 180 --render-scale 0.5 --screenshot " + shot.string(), log) == 0);
  CAPTURE(log);
  CHECK(log.find("view scale 0.50") != std::string::npos);
  const crumple::gl::Image img = crumple::gl::readPng(shot.string(), 3);
  CHECK(img.width == 320);  // the window's size: the view was scaled up to it
  CHECK(img.height == 180);
  for (const char* bad : {"0.1", "2", "fast", "0.5x"}) {
    CAPTURE(bad);
    CHECK(run(std::string("--frames 1 --render-scale ") + bad, log) == 2);
    CHECK(log.find("--render-scale") != std::string::npos);
  }
  fs::remove_all(dir);
}

TEST_CASE("sandbox: the scenes with joints load and run (ragdoll, wrecking ball, chain bridge)") {
  const fs::path dir = fs::temp_directory_path() / ("crumple_sandbox_joints_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const char* asan = std::getenv("ASAN_OPTIONS");
  const std::string options = std::string(asan ? asan : "") + (asan ? ":" : "") + "detect_leaks=0";
  setenv("ASAN_OPTIONS", options.c_str(), 1);
  for (const char* name : {"ragdoll", "wrecking-ball", "chain-bridge"}) {
    CAPTURE(name);
    const fs::path out = dir / name, log = dir / "log.txt", shot = dir / (std::string(name) + ".png");
    const std::string cmd = std::string(CRUMPLE_SANDBOX) + " " + CRUMPLE_SCENES + "/" + name +
                            ".json --frames 40 --width 320 --height 180 --screenshot " + shot.string() + " --out " +
                            out.string() + " > " + log.string() + " 2>&1";
    const int rc = std::system(cmd.c_str());
    std::ifstream lf(log);
    std::stringstream ls;
    ls << lf.rdbuf();
    CAPTURE(ls.str());
    REQUIRE(WIFEXITED(rc));
    CHECK(WEXITSTATUS(rc) == 0);
    std::ifstream sf(out / "summary.json");
    std::stringstream ss;
    ss << sf.rdbuf();
    CHECK(ss.str().find("\"joints\"") != std::string::npos);
    CHECK(ss.str().find("\"broken\": false") != std::string::npos);
    CHECK(crumple::gl::readPng(shot.string(), 3).width == 320);
  }
  fs::remove_all(dir);
}

TEST_CASE("sandbox: --set changes the scene, --save-scene writes what the panel has, loadable elsewhere") {
  const fs::path dir = fs::temp_directory_path() / ("crumple_sandbox_save_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const char* asan = std::getenv("ASAN_OPTIONS");
  const std::string options = std::string(asan ? asan : "") + (asan ? ":" : "") + "detect_leaks=0";
  setenv("ASAN_OPTIONS", options.c_str(), 1);
  auto run = [&](const std::string& args) {
    const int rc = std::system((std::string(CRUMPLE_SANDBOX) + " " + args + " > " + (dir / "log.txt").string() +
                                " 2>&1")
                                   .c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  };
  const fs::path saved = dir / "elsewhere" / "ball.json";
  REQUIRE(run(std::string(CRUMPLE_SCENES) + "/wrecking-ball.json --frames 2 --width 160 --height 90 " +
              "--set materials.clay.kappa=0.0001 --set bodies[ball].velocity=[1,0,0] --save-scene " + saved.string()) ==
          0);
  std::ifstream f(saved);
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string text = ss.str();
  CHECK(text.find("\"kappa\": 0.0001") != std::string::npos);
  CHECK(text.find("\"joints\"") != std::string::npos);
  // The saved scene runs from its new folder.
  const std::string sim = fs::path(CRUMPLE_SANDBOX).parent_path().string() + "/crumple-sim";
  CHECK(std::system((sim + " " + saved.string() + " --out " + (dir / "out").string() + " --steps 2 -q").c_str()) == 0);
  // A bad override is bad input.
  CHECK(run(std::string(CRUMPLE_SCENES) + "/wrecking-ball.json --frames 1 --set materials.nope.kappa=1") == 2);
  fs::remove_all(dir);
}
