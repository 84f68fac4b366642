// The world feels its dents: contacts on a dented surface are measured against
// it (engine/simulation.cpp reads each dented map back; physics/narrow_phase.cpp
// displaces the surface by k (0.5 - h)), checked against the craters' geometry.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <unistd.h>

#include <crumple/engine/simulation.h>
#include <crumple/gl/image.h>
#include "gl_fixture.h"

using namespace crumple;

namespace {

// A steel ball of radius 0.25 m dropped at 8 m/s on a static clay plate (its top at y = 0) that keeps only the
// first impact's dent (impulse_floor), and, parked away from it, a glass marble of radius 1.5 cm.
// `plateImage`: the plate's bump map starts from this image (a path) instead of flat.
std::string craterScene(bool feel, double ballX = 0, double plateThickness = 0.2, double speed = 8,
                        const std::string& plateImage = "") {
  return R"({"format": "crumple-scene/1", "name": "crater", "gravity": [0, -9.81, 0], "timestep": 0.0041666667,
    "duration": 10,
    "materials": {
      "clay": {"density": 1800, "restitution": 0.05, "friction": 0.8, "kappa": 0.00006, "thickness": 0.05},
      "steel": {"density": 7800, "restitution": 0.05, "friction": 0.4, "kappa": 0.00006, "thickness": 0.01},
      "glass": {"density": 2500, "restitution": 0.05, "friction": 0.6, "kappa": 0.00006, "thickness": 0.01}},
    "deformation": {"bump_depth": 0.1, "bump_depth_collide": 0.02, "address_map": 512, "impulse_floor": 1000,
                    "feel_dents": )" +
         std::string(feel ? "true" : "false") + R"(},
    "bodies": [
      {"name": "plate", "shape": {"type": "box", "size": [2, )" + std::to_string(plateThickness) + R"(, 2]},
       "material": "clay", "static": true, "position": [0, )" + std::to_string(-plateThickness / 2) + R"(, 0],
       "bump_map": {)" + (plateImage.empty() ? std::string(R"("resolution": 512)") : R"("image": ")" + plateImage + "\"") + R"(}},
      {"name": "ball", "shape": {"type": "sphere", "radius": 0.25}, "material": "steel",
       "position": [)" + std::to_string(ballX) + R"(, 0.6, 0], "velocity": [0, )" + std::to_string(-speed) + R"(, 0]},
      {"name": "marble", "shape": {"type": "sphere", "radius": 0.015}, "material": "glass",
       "position": [0.8, 0.015, 0.8]},
      {"name": "box", "shape": {"type": "box", "size": [0.24, 0.02, 0.04]}, "material": "clay",
       "position": [0.7, 0.01, -0.6]}],
    "cameras": [{"name": "low", "position": [0.9, 0.3, 0.9], "target": [0, 0, 0]}]})";
}

struct Crater {
  double depth = 0;  // m below the plate's top at its deepest
};

Crater crater(const Simulation& sim) {
  Crater c;
  for (const BodyRuntime& b : sim.bodies())
    if (b.name == "plate") {
      const gl::Image map = b.surface->downloadHeight();
      float lowest = 0.5f;
      for (float v : map.pixels) lowest = std::min(lowest, v);
      c.depth = b.surface->bumpDepth() * (0.5 - lowest);
    }
  return c;
}

const RigidBody& body(const Simulation& sim, const std::string& name) {
  for (const BodyRuntime& b : sim.bodies())
    if (b.name == name) return sim.world().body(b.index);
  FAIL("no body " << name);
  throw 0;
}
int index(const Simulation& sim, const std::string& name) {
  for (const BodyRuntime& b : sim.bodies())
    if (b.name == name) return b.index;
  return -1;
}

void run(Simulation& sim, double seconds) {
  const long steps = std::lround(seconds / sim.scene().timestep);
  for (long i = 0; i < steps; ++i) sim.step();
}

}  // namespace

TEST_CASE("a steel ball comes to rest in the crater it made, its centre the crater's depth below r") {
  test::glContext();
  Simulation sim(parseScene(craterScene(true), "crater.json", "."), true);
  run(sim, 2.5);
  const Crater c = crater(sim);
  const RigidBody& ball = body(sim, "ball");
  MESSAGE("crater " << c.depth * 1000 << " mm deep; the ball's centre at " << ball.x.y * 1000 << " mm (r - depth "
                    << (0.25 - c.depth) * 1000 << " mm)");
  CHECK(c.depth > 0.02);
  CHECK(std::abs(ball.x.y - (0.25 - c.depth)) < 0.002);
  CHECK(glm::length(ball.v) < 0.01);

  // The paper's behaviour (dents visual only): the same crater, the ball on the undented plate.
  Simulation paint(parseScene(craterScene(false), "crater.json", "."), true);
  run(paint, 2.5);
  CHECK(std::abs(crater(paint).depth - c.depth) < 1e-6);
  CHECK(std::abs(body(paint, "ball").x.y - 0.25) < 0.002);
}

TEST_CASE("a marble dropped on a crater's slope rolls to its floor and rests there") {
  test::glContext();
  Simulation sim(parseScene(craterScene(true), "crater.json", "."), true);
  run(sim, 1.0);
  const Crater c = crater(sim);
  // The ball set aside (on the undented plate); the marble set on the crater's slope, 6 cm from its centre.
  World& w = sim.world();
  const int ball = index(sim, "ball");
  w.setPose(ball, {{-0.6, 0.25, -0.6}, glm::dquat(1, 0, 0, 0)});
  w.setVelocity(ball, glm::dvec3(0));
  w.setAngularVelocity(ball, glm::dvec3(0));
  const int marble = index(sim, "marble");
  w.setPose(marble, {{0.06, 0.02, 0.0}, glm::dquat(1, 0, 0, 0)});
  w.setVelocity(marble, glm::dvec3(0));
  w.setAngularVelocity(marble, glm::dvec3(0));
  w.wake(marble);
  // It rolls to and fro across the floor, losing a little at each pass over the map's texels: 30 s.
  run(sim, 30.0);
  const RigidBody& m = body(sim, "marble");
  const double off = std::hypot(m.x.x, m.x.z);
  MESSAGE("crater " << c.depth * 1000 << " mm deep; the marble " << off * 1000 << " mm from its centre, at y "
                    << m.x.y * 1000 << " mm (floor + r: " << (0.015 - c.depth) * 1000 << " mm)");
  CHECK(off < 0.01);
  CHECK(std::abs(m.x.y - (0.015 - c.depth)) < 0.002);
}

TEST_CASE("a plank set half over a crater tips into it") {
  test::glContext();
  double tilt[2] = {0, 0};
  for (int feel = 0; feel < 2; ++feel) {
    Simulation sim(parseScene(craterScene(feel == 1), "crater.json", "."), true);
    run(sim, 1.0);
    World& w = sim.world();
    const int ball = index(sim, "ball"), box = index(sim, "box");
    w.setPose(ball, {{-0.6, 0.25, -0.6}, glm::dquat(1, 0, 0, 0)});
    w.setVelocity(ball, glm::dvec3(0));
    w.setAngularVelocity(ball, glm::dvec3(0));
    // A plank from the crater's centre out over its rim (11 cm from the centre) onto the undented plate, its
    // centre of mass inside the rim.
    w.setPose(box, {{-0.08, 0.011, 0}, glm::dquat(1, 0, 0, 0)});
    w.wake(box);
    run(sim, 2.0);
    const glm::dvec3 up = w.body(box).rotation() * glm::dvec3(0, 1, 0);
    tilt[feel] = std::acos(std::clamp(up.y, -1.0, 1.0)) * 180 / 3.141592653589793;
  }
  MESSAGE("tilt: " << tilt[0] << " degrees on the undented plate, " << tilt[1] << " degrees with the crater felt");
  CHECK(tilt[0] < 0.1);
  CHECK(tilt[1] > 3);
}

TEST_CASE("a second ball on the same spot meets the first one's floor and deepens it") {
  test::glContext();
  // One ball, then the same ball again from the same height onto its crater, slower (its dent well short of the
  // map's floor, 0.5 k down).
  auto drop = [](Simulation& sim) {
    const int ball = index(sim, "ball");
    sim.world().setPose(ball, {{0, 0.6, 0}, glm::dquat(1, 0, 0, 0)});
    sim.world().setVelocity(ball, {0, -4, 0});
    sim.world().setAngularVelocity(ball, glm::dvec3(0));
    sim.world().wake(ball);
  };
  Simulation sim(parseScene(craterScene(true), "crater.json", "."), true);
  run(sim, 1.0);
  const double first = crater(sim).depth;
  const size_t before = sim.events().size();
  drop(sim);
  run(sim, 1.0);
  REQUIRE(sim.events().size() > before);
  const CollisionEvent& second = sim.events()[before].event;
  const double added = sim.events()[before].side[0].deformDepth;  // the plate's side of the second impact
  const double second_depth = crater(sim).depth;
  MESSAGE("first crater " << first * 1000 << " mm; the second impact's contact point at y " << second.point.y * 1000
                          << " mm; the crater then " << second_depth * 1000 << " mm (its deformation depth "
                          << added * 1000 << " mm)");
  // The second impact's contact lies at the first crater's floor (within the penetration of that step), and its
  // dent adds to the first: its own deformation depth below the floor the ball met, not cut again from below the
  // old floor by the part of it the dent's k' did not show (a ball hitting its crater again would dig itself in).
  CHECK(second.point.y < -first + 0.01);
  CHECK(second.point.y > -first - 0.03);
  CHECK(second_depth > first + 0.005);
  CHECK(second_depth < first + added + 0.003);
}

TEST_CASE("with nothing dented, or dents far away, bodies move as they did before dents were felt") {
  test::glContext();
  // The ball dents the plate at x = -0.6; the marble rests at (0.8, 0.8), far from it: its state is the same bits
  // with dents felt and without.
  Simulation felt(parseScene(craterScene(true, -0.6), "crater.json", "."), true);
  Simulation paint(parseScene(craterScene(false, -0.6), "crater.json", "."), true);
  run(felt, 1.0);
  run(paint, 1.0);
  const RigidBody& a = body(felt, "marble");
  const RigidBody& b = body(paint, "marble");
  CHECK(crater(felt).depth > 0.02);
  CHECK(a.x == b.x);
  CHECK(a.v == b.v);
  CHECK(a.q == b.q);
}

TEST_CASE("a map that starts from an image is felt where dents changed it, not where the image lies") {
  // The plate's map starts from an image whose surface stands 5 mm above the mesh everywhere (h = 0.55): only the
  // texels a dent changed are felt, so the marble far from the dent moves as with dents visual only. (A copy of
  // the start taken as flat would make the whole image a change, and the marble feel it.)
  test::glContext();
  const std::filesystem::path image =
      std::filesystem::temp_directory_path() / ("crumple_felt_start_" + std::to_string(::getpid()) + ".png");
  gl::writePng(image.string(), gl::Image(512, 512, 1, 0.55f), 16);
  Simulation felt(parseScene(craterScene(true, -0.6, 0.2, 8, image.string()), "crater.json", "."), true);
  Simulation paint(parseScene(craterScene(false, -0.6, 0.2, 8, image.string()), "crater.json", "."), true);
  std::filesystem::remove(image);
  run(felt, 1.0);
  run(paint, 1.0);
  CHECK(crater(felt).depth > 0.02);
  const RigidBody& a = body(felt, "marble");
  const RigidBody& b = body(paint, "marble");
  CHECK(a.x == b.x);
  CHECK(a.v == b.v);
  CHECK(a.q == b.q);
}

TEST_CASE("a dent in a thin plate's top is felt on its top, not on its underside 1.6 cm below") {
  // Each point feels the map where its own nearest surface is: the underside's points are within the lookups'
  // 2 cm of the dented top, but nearest the undented underside.
  test::glContext();
  const double thickness = 0.016;
  Simulation sim(parseScene(craterScene(true, 0, thickness, 2.5), "crater.json", "."), true);
  run(sim, 0.5);
  const double depth = crater(sim).depth;
  MESSAGE("crater " << depth * 1000 << " mm");
  REQUIRE(depth > 0.004);
  REQUIRE(depth < thickness - 0.004);
  RayHit down, up;
  REQUIRE(sim.world().raycast({0, 0.4, 0}, {0, -1, 0}, 1.0, index(sim, "ball"), down));
  REQUIRE(sim.world().raycast({0, -0.5, 0}, {0, 1, 0}, 1.0, index(sim, "ball"), up));
  MESSAGE("crater " << depth * 1000 << " mm; from above the plate is met " << (down.distance - 0.4) * 1000
                    << " mm below its top, from below " << (up.distance - (0.5 - thickness)) * 1000
                    << " mm past its underside");
  CHECK(down.distance == doctest::Approx(0.4 + depth).epsilon(0.01));
  CHECK(std::abs(up.distance - (0.5 - thickness)) < 2e-4);
}

TEST_CASE("the change log and whole maps read back give the world the same dents") {
  // The deformer logs the texels its commits change; a step that changes more than the log holds reads its maps
  // back whole instead. A log of 8 entries overflows at every dent: both runs must feel the same maps, bit for bit.
  test::glContext();
  auto drop = [](Simulation& sim, double x) {
    const int ball = index(sim, "ball");
    sim.world().setPose(ball, {{x, 0.6, 0.1}, glm::dquat(1, 0, 0, 0)});
    sim.world().setVelocity(ball, {0, -8, 0});
    sim.world().setAngularVelocity(ball, glm::dvec3(0));
    sim.world().wake(ball);
  };
  Scene small = parseScene(craterScene(true), "crater.json", ".");
  small.deformation.options.changeLog = 8;
  Simulation logged(parseScene(craterScene(true), "crater.json", "."), true);
  Simulation whole(small, true);
  for (Simulation* sim : {&logged, &whole}) {
    run(*sim, 0.6);
    drop(*sim, 0.12);  // a second crater overlapping the first
    run(*sim, 0.6);
  }
  const Timings& a = logged.timings();
  const Timings& b = whole.timings();
  MESSAGE("log: " << a.dentReads << " maps taken in, " << a.dentTexels << " texels logged, " << a.dentFullReads
                  << " read whole; 8-entry log: " << b.dentFullReads << " read whole");
  REQUIRE(a.dentReads >= 2);
  CHECK(a.dentTexels > 1000);
  CHECK(a.dentFullReads == 0);
  CHECK(b.dentFullReads == b.dentReads);
  CHECK(b.dentReads == a.dentReads);
  // The dented plate as the physics meets it, probed on a grid over both craters.
  int deeper = 0;
  for (int i = -12; i <= 12; ++i)
    for (int j = -12; j <= 12; ++j) {
      const glm::dvec3 from(0.06 + 0.015 * i, 0.4, 0.05 + 0.015 * j);
      RayHit ha, hb;
      REQUIRE(logged.world().raycast(from, {0, -1, 0}, 1.0, index(logged, "ball"), ha));
      REQUIRE(whole.world().raycast(from, {0, -1, 0}, 1.0, index(whole, "ball"), hb));
      CHECK(ha.distance == hb.distance);
      deeper += ha.distance > 0.4 + 0.005;
    }
  CHECK(deeper > 50);  // (the grid crosses the craters)
  for (const char* name : {"ball", "marble", "box"}) {
    CHECK(body(logged, name).x == body(whole, name).x);
    CHECK(body(logged, name).v == body(whole, name).v);
  }
}

TEST_CASE("a crate settling in its own crater dents no texel deeper than each event's deformation depth") {
  // A 20 kg wooden crate (0.2 m, map 128) dropped on clay sinks into the crater it makes and rocks there. Each
  // later touch is retracted to first contact and pushed in by its own depth d: a texel is cut no deeper than d.
  // (Cut by the whole overlap, the crate's side faces lost 2.6 mm at their bottom edge on a touch of 0.01 mm: a side
  // texel's centre, past the face's edge, was taken half a texel below the crate, inside the clay; and its texels
  // the crater's sloped wall stood over were cut by that wall.)
  test::glContext();
  for (const bool feel : {true, false}) {
    const std::string scene = R"({"format": "crumple-scene/1", "name": "crate", "duration": 2,
      "materials": {
        "clay": {"density": 1800, "restitution": 0.2, "friction": 0.8, "kappa": 0.00006, "thickness": 0.05},
        "wood": {"density": 600, "restitution": 0.3, "friction": 0.6, "kappa": 0.0002, "thickness": 0.03}},
      "deformation": {"feel_dents": )" +
                              std::string(feel ? "true" : "false") + R"(},
      "bodies": [
        {"name": "plate", "shape": {"type": "box", "size": [2, 0.2, 2]}, "material": "clay", "static": true,
         "position": [0, -0.1, 0], "bump_map": {"resolution": 256}},
        {"name": "crate", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]}, "material": "wood", "mass": 20,
         "position": [0, 0.6, 0.0], "orientation": [0, 0, 2], "bump_map": {"resolution": 128}}]})";
    Simulation sim(parseScene(scene, "crate.json", "."), true);
    run(sim, 2.0);
    sim.resolveEventStats();
    int sides = 0;
    double worst = 0;
    for (const EventRecord& e : sim.events())
      for (const SideDecision& s : e.side) {
        if (!s.deformed) continue;
        ++sides;
        worst = std::max(worst, s.stats.maxDent - s.deformDepth);
        CHECK(s.stats.maxDent <= s.deformDepth * 1.0001 + 1e-7);
      }
    MESSAGE(std::string(feel ? "felt" : "visual only")
            << ": " << sim.events().size() << " events, " << sides
            << " dented sides, deepest texel beyond its event's depth by " << worst * 1000 << " mm");
    CHECK(sides >= 4);
  }
}

TEST_CASE("a steel ball rolling out of its crater over the clay's rim dents no texel deeper than each event's depth") {
  // Crater rims raise the clay around each dent. The contact measures the ball against them at its samples, which
  // stand centimetres apart on a 20 cm ball: rolling out of its crater, the ball passes through rim texels between
  // them. That overlap is no event's to cut; the bound counts only the relief contacts do not feel (none here: no
  // image). (Bounded by the rims' highest reach instead, half the clay's bump depth, a steel ball rolling on clay
  // was cut centimetres deep on touches of hundredths of a millimetre, its map saturated.)
  test::glContext();
  const std::string scene = R"({"format": "crumple-scene/1", "name": "rim", "duration": 2,
    "materials": {
      "clay": {"density": 1800, "restitution": 0.15, "friction": 0.7, "kappa": 0.0002, "thickness": 0.05},
      "steel": {"density": 7800, "restitution": 0.8, "friction": 0.4, "kappa": 0.00001, "thickness": 0.02}},
    "deformation": {"crater_rims": true, "impulse_floor": 5},
    "bodies": [
      {"name": "floor", "shape": {"type": "box", "size": [3, 0.2, 3]}, "material": "clay", "static": true,
       "position": [0, -0.1, 0], "bump_map": {"resolution": 512}},
      {"name": "ball", "shape": {"type": "sphere", "radius": 0.2}, "material": "steel",
       "position": [-0.6, 1.0, 0], "velocity": [1.5, 0, 0], "bump_map": {"resolution": 128}}]})";
  Simulation sim(parseScene(scene, "rim.json", "."), true);
  run(sim, 2.0);
  sim.resolveEventStats();
  double worst = 0;
  for (const EventRecord& e : sim.events())
    for (const SideDecision& s : e.side) {
      if (!s.deformed) continue;
      worst = std::max(worst, s.stats.maxDent - s.deformDepth);
      CHECK(s.stats.maxDent <= s.deformDepth * 1.0001 + 1e-7);
    }
  MESSAGE(sim.events().size() << " events, deepest texel beyond its event's depth by " << worst * 1000 << " mm");
  CHECK(sim.events().size() >= 3);
}
