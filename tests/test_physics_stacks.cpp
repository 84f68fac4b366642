// Stacks and piles: resting contact, patches, shock propagation; they stand
// still, rest level and fall asleep.
#include <doctest/doctest.h>

#include <cmath>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include "physics_fixture.h"
#include "test_meshes.h"

using namespace crumple;
using namespace crumple::test;
using doctest::Approx;

namespace {
// Steps `w` `steps` times at 240 Hz: the largest distance a body of `ids` moved from `start`, and when every body
// was first asleep (-1: never).
std::pair<double, double> settle(World& w, const std::vector<int>& ids, const std::vector<glm::dvec3>& start,
                                 int steps) {
  double asleepAt = -1;
  for (int s = 1; s <= steps; ++s) {
    w.step(1.0 / 240);
    if (asleepAt < 0 && w.lastStats().awake == 0) asleepAt = s / 240.0;
  }
  double drift = 0;
  for (size_t k = 0; k < ids.size(); ++k) drift = std::max(drift, glm::length(w.body(ids[k]).x - start[k]));
  return {drift, asleepAt};
}
}  // namespace

TEST_CASE("a 10-level box pyramid stands for 10 s with drift under 1 cm, sleeping or not") {
  for (bool sleeping : {true, false}) {
    CAPTURE(sleeping);
    PhysicsTestContext c;
    c.settings().sleeping = sleeping;
    c.addGround(0.6, 0.0);
    const int levels = 10;
    const double size = 0.5;
    std::vector<int> ids;
    std::vector<glm::dvec3> start;
    for (int row = 0; row < levels; ++row) {
      const int count = levels - row;
      for (int k = 0; k < count; ++k) {
        ids.push_back(
            c.addBox({size, size, size}, {(k - (count - 1) / 2.0) * size * 1.02, size / 2 + row * size, 0}, 0.6, 0.0));
        start.push_back(c.body(ids.back()).x);
      }
    }
    c.simulate(10.0);
    double drift = 0;
    for (size_t k = 0; k < ids.size(); ++k) drift = std::max(drift, glm::length(c.body(ids[k]).x - start[k]));
    MESSAGE("pyramid max drift after 10 s" << std::string(sleeping ? "" : " (no sleeping)") << ": " << drift << " m");
    CHECK(drift < 0.01);
  }
}

TEST_CASE("a tower of ten boxes, every other one 5 cm off, dropped with 10 cm gaps, stands and falls asleep") {
  // One column of crumple-bench's pile. Each box lands on an off-centre face:
  // an impulse at one point spins it, and the tower used to lean and fall.
  World w;
  addGround(w, 0.6, 0.1);
  std::vector<int> ids;
  for (int k = 0; k < 10; ++k) ids.push_back(addBox(w, {0.4, 0.4, 0.4}, {0.05 * (k % 2), 0.3 + 0.5 * k, 0}, 0.6, 0.1));
  double asleepAt = -1;
  for (int s = 1; s <= 720; ++s) {
    w.step(1.0 / 240);
    if (asleepAt < 0 && w.lastStats().awake == 0) asleepAt = s / 240.0;
  }
  double lean = 0, tilt = 0;
  for (int k = 0; k < 10; ++k) {
    const RigidBody& b = w.body(ids[static_cast<size_t>(k)]);
    lean = std::max(lean, glm::length(glm::dvec2(b.x.x - 0.05 * (k % 2), b.x.z)));
    tilt = std::max(tilt, glm::angle(b.q));
    CHECK(b.x.y == Approx(0.2 + 0.4 * k).epsilon(0.01));
  }
  MESSAGE("offset tower: lean " << lean << " m, tilt " << tilt << " rad, asleep at " << asleepAt << " s");
  CHECK(lean < 0.02);
  CHECK(tilt < 0.02);
  CHECK(asleepAt > 0);
  // The top box lands at about 0.45 s; the boxes rock by fractions of a millimetre for a second after that, which
  // is still (they stay near where they came to rest): asleep about sleepTime (0.5 s) after the last landing.
  CHECK(asleepAt < 1.2);
}

TEST_CASE("sleeping: a body drifting slower than sleepLinear / 2 falls asleep, one drifting faster never does") {
  // On frictionless ground a box keeps its speed. Still means staying within sleepLinear x sleepTime / 2
  // (1.25 cm) of where the stillness began for sleepTime (0.5 s): 2 cm/s drifts 1 cm in that time, 4 cm/s 2 cm.
  for (double speed : {0.02, 0.04}) {
    CAPTURE(speed);
    World w;
    addGround(w, 0.0, 0.0);
    const int box = addBox(w, {0.4, 0.4, 0.4}, {0, 0.2, 0}, 0.0, 0.0);
    w.setVelocity(box, {speed, 0, 0});
    double asleepAt = -1;
    for (int s = 1; s <= 480 && asleepAt < 0; ++s) {
      w.step(1.0 / 240);
      if (w.body(box).asleep) asleepAt = s / 240.0;
    }
    MESSAGE("box drifting at " << speed << " m/s: asleep at " << asleepAt << " s");
    if (speed < 0.025) {
      CHECK(asleepAt > 0.45);
      CHECK(asleepAt < 0.6);
    } else {
      CHECK(asleepAt < 0);
      CHECK(w.body(box).v.x == Approx(speed).epsilon(1e-6));
    }
  }
}

TEST_CASE("heavy bodies on light ones: each box ten times heavier than the one below rests still") {
  PhysicsTestContext c;
  c.settings().sleeping = false;  // the solver must hold them, not sleep
  c.addGround(0.6, 0.0);
  std::vector<int> ids;
  for (int k = 0; k < 4; ++k)  // 12.5 kg ... 12.5 t
    ids.push_back(c.addBox({0.5, 0.5, 0.5}, {0.03 * (k % 2), 0.25 + 0.5 * k, 0}, 0.6, 0.0, 100 * std::pow(10.0, k)));
  c.simulate(5.0);
  for (int k = 0; k < 4; ++k) {
    CAPTURE(k);
    const RigidBody& b = c.body(ids[static_cast<size_t>(k)]);
    CHECK(b.x.y == Approx(0.25 + 0.5 * k).epsilon(0.002));
    CHECK(std::abs(b.x.x - 0.03 * (k % 2)) < 0.002);
    CHECK(glm::angle(b.q) < 0.005);
  }
}

TEST_CASE("a heavy beam leaning from the ground onto a light brick stands: the brick is not shoved out") {
  // Both touch the ground (one contact-graph level); the beam rests on the brick. Friction holds this
  // (tan of the 12 degree lean is under both friction coefficients). A 1350 kg beam on a 29 kg brick: solved as
  // one level, the brick crept out at 0.2 m/s and the beam's end hit it anew each step.
  for (double thickness : {0.1, 0.3}) {  // a plank (the resting solve's kind of body) and a beam
    CAPTURE(thickness);
    PhysicsTestContext c;
    c.settings().sleeping = false;  // the solver must hold them
    c.addGround(0.7, 0.15);
    const int brick = c.addBox({0.4, 0.2, 0.2}, {0.6, 0.1, 0}, 0.7, 0.15, 1800);
    const double lean = std::atan2(0.2 + thickness / 2, 1.2);
    BodyDef beam;
    beam.shape = makeBox({1.6, thickness, 0.5});
    beam.origin = {0, 0.1 + thickness / 2 / std::cos(lean) + 0.002, 0};
    beam.orientation = glm::angleAxis(lean, glm::dvec3(0, 0, 1));
    beam.mass = 1350;
    beam.friction = 0.4;
    beam.restitution = 0.8;
    const int b = c.add(beam);
    c.simulate(0.5);
    const glm::dvec3 brickAt = c.body(brick).x, beamAt = c.body(b).x;
    int hits = 0;
    double fastest = 0;
    for (int s = 0; s < 2 * 240; ++s) {
      c.simulateSteps(1);
      hits += static_cast<int>(c.world().events().size());
      fastest = std::max({fastest, glm::length(c.body(brick).v), glm::length(c.body(b).v)});
    }
    MESSAGE("thickness ", thickness, ": brick moved ", glm::length(c.body(brick).x - brickAt), " m, beam ",
            glm::length(c.body(b).x - beamAt), " m in 2 s; ", hits, " collision events, fastest ", fastest, " m/s");
    CHECK(glm::length(c.body(brick).x - brickAt) < 0.005);
    CHECK(glm::length(c.body(b).x - beamAt) < 0.005);
    CHECK(hits == 0);
    CHECK(fastest < 0.05);
  }
}

TEST_CASE("uneven stacks under a shared lid: the contact graph's cycle collapses and the lid rests level") {
  // Left: one 0.5 m box; right: two 0.25 m boxes; a plank across both. By
  // breadth-first levels the plank and the upper right box share a level and
  // touch each other: a cycle that must neither loop nor topple anything.
  PhysicsTestContext c;
  c.addGround(0.6, 0.0);
  auto box = [&](glm::dvec3 size, glm::dvec3 origin) { return c.addBox(size, origin, 0.6, 0.0); };
  box({0.5, 0.5, 0.5}, {-0.6, 0.25, 0});
  box({0.5, 0.25, 0.5}, {0.6, 0.125, 0});
  box({0.5, 0.25, 0.5}, {0.6, 0.375, 0});
  const int lid = box({1.8, 0.1, 0.5}, {0, 0.55, 0});
  const glm::dvec3 start = c.body(lid).x;
  c.simulate(5.0);
  const RigidBody& l = c.body(lid);
  REQUIRE(std::isfinite(l.x.x + l.x.y + l.x.z));
  CHECK(glm::length(l.x - start) < 0.005);
  CHECK(glm::angle(l.q) < 0.01);
  CHECK(c.world().lastStats().awake == 0);
}

TEST_CASE("a running-bond wall (each block half on two below) of six courses stands and falls asleep") {
  // Blocks 0.3 m thick: each rests on two supports side by side, and nothing
  // but their patches keeps it from rocking out of the wall's plane (at the
  // origin the wall is symmetric to the last bit and that mode never starts).
  World w;
  addGround(w, 0.7, 0.1);
  const double L = 0.6, H = 0.3, T = 0.3;
  std::vector<int> ids;
  std::vector<glm::dvec3> start;
  for (int course = 0; course < 6; ++course) {
    const bool odd = course % 2 == 1;
    const int count = odd ? 13 : 12;
    for (int i = 0; i < count; ++i) {
      const bool half = odd && (i == 0 || i == count - 1);
      const double z = !odd ? -L * 5.5 + L * i : half ? (i == 0 ? -1 : 1) * (L * 6 - L / 4) : -L * 6 + L * i;
      // Off the origin: rounding breaks the wall's symmetry, as anywhere else it would.
      ids.push_back(
          addBox(w, {T, H, half ? L / 2 - 0.01 : L - 0.01}, {12, H / 2 + (H + 0.0005) * course, z}, 0.7, 0.1, 1800));
      start.push_back(w.body(ids.back()).x);
    }
  }
  const auto [drift, asleepAt] = settle(w, ids, start, 600);
  MESSAGE("running-bond wall: drift " << drift << " m, asleep at " << asleepAt << " s");
  CHECK(drift < 0.01);
  CHECK(asleepAt > 0);
}

TEST_CASE("a running-bond wall with a door under a lintel stands and falls asleep") {
  // Six courses of 0.6 x 0.3 x 0.3 m blocks over 7.2 m; a 1.2 m opening through the first three courses (half
  // blocks at its jambs), spanned by a 1.8 m lintel bearing 0.3 m on each side, and the courses above it.
  // With sleeping (the default) the wall settles its 0.5 mm course gaps and sleeps at 0.5 s. (Without sleeping
  // the blocks over the lintel creep, about a millimetre a second.)
  World w;
  addGround(w, 0.7, 0.1);
  const double L = 0.6, H = 0.3, T = 0.3, u = L / 2;  // u: half a block, the unit of the joints below
  std::vector<int> ids;
  std::vector<glm::dvec3> start;
  int lintel = -1;
  auto block = [&](int z0, int z1, int course) {
    ids.push_back(addBox(w, {T, H, (z1 - z0) * u - 0.01}, {12, H / 2 + (H + 0.0005) * course, 0.5 * (z0 + z1) * u},
                         0.7, 0.1, 1800));
    start.push_back(w.body(ids.back()).x);
    return ids.back();
  };
  for (int course = 0; course < 6; ++course) {
    std::vector<int> joints;  // block ends, in half blocks over [-12, 12]; odd courses offset by half a block
    for (int z = course % 2 ? -11 : -12; z <= 12; z += 2) joints.push_back(z);
    if (course % 2) {
      joints.insert(joints.begin(), -12);
      joints.push_back(12);
    }
    for (size_t k = 0; k + 1 < joints.size(); ++k) {
      const int z0 = joints[k], z1 = joints[k + 1];
      if (course < 3) {  // the opening: [-2, 2]
        if (z1 <= -2 || z0 >= 2) block(z0, z1, course);
        else if (z0 < -2) block(z0, -2, course);
        else if (z1 > 2) block(2, z1, course);
      } else if (course == 3) {  // the lintel: [-3, 3]
        if (z1 <= -3 || z0 >= 3) block(z0, z1, course);
        else if (z0 == -3) lintel = block(-3, 3, course);
      } else {
        block(z0, z1, course);
      }
    }
  }
  REQUIRE(ids.size() == 68);
  REQUIRE(lintel >= 0);
  const auto [drift, asleepAt] = settle(w, ids, start, 1200);
  MESSAGE("wall with a door: drift " << drift << " m, asleep at " << asleepAt << " s, lintel turned "
                                     << glm::angle(w.body(lintel).q) << " rad");
  CHECK(drift < 0.01);
  CHECK(glm::angle(w.body(lintel).q) < 0.01);
  CHECK(asleepAt > 0);
  CHECK(asleepAt < 2.0);
}

namespace {
// Cards 0.3 x 0.2 m, 1 cm thick (700 kg/m^3, friction 0.6), an A-frame two of them leaning 20 degrees from
// upright with their top edges touching (the feet need friction tan(20) / 2 = 0.18 of the 0.6 there).
struct CardHouse {
  static constexpr double t = 0.01, l = 0.3, d = 0.2, mu = 0.6;
  const double tilt = glm::radians(20.0);
  const double span = 2 * (l * std::sin(tilt) + t * std::cos(tilt)) + 0.02;  // an A-frame's footprint and a gap
  World w;
  std::vector<int> ids;
  std::vector<glm::dvec3> start;
  CardHouse() { addGround(w, mu, 0); }
  void add(const glm::dvec3& size, const glm::dvec3& at, const glm::dquat& q) {
    BodyDef b;
    b.shape = makeBox(size);
    b.origin = at;
    b.orientation = q;
    b.friction = mu;
    b.restitution = 0;
    b.density = 700;
    ids.push_back(w.addBody(b));
    start.push_back(w.body(ids.back()).x);
  }
  // An A-frame centred at x standing on height y.
  void aFrame(double x, double y) {
    const double cy = y + l / 2 * std::cos(tilt) + t / 2 * std::sin(tilt) + 0.0005;
    const double cx = l / 2 * std::sin(tilt) + t / 2 * std::cos(tilt);
    add({t, l, d}, {x - cx, cy, 0}, glm::angleAxis(-tilt, glm::dvec3(0, 0, 1)));
    add({t, l, d}, {x + cx, cy, 0}, glm::angleAxis(tilt, glm::dvec3(0, 0, 1)));
  }
  // A house of `storeys`: n A-frames on the ground, a flat card over each two neighbours, n - 1 frames on them...
  void house(int storeys) {
    double y = 0;
    for (int s = 0; s < storeys; ++s) {
      const int frames = storeys - s;
      const double x0 = -(frames - 1) * span / 2;
      for (int f = 0; f < frames; ++f) aFrame(x0 + f * span, y);
      y += l * std::cos(tilt) + t * std::sin(tilt) + 0.001;
      if (s + 1 == storeys) break;
      for (int f = 0; f + 1 < frames; ++f)
        add({span + 0.01, t, d}, {x0 + (f + 0.5) * span, y + t / 2, 0}, glm::dquat(1, 0, 0, 0));
      y += t + 0.001;
    }
  }
  // The largest distance a card moved from where it was put.
  double drift() const {
    double m = 0;
    for (size_t k = 0; k < ids.size(); ++k) m = std::max(m, glm::length(w.body(ids[k]).x - start[k]));
    return m;
  }
  double run(bool sleeping, double seconds) {
    w.settings().sleeping = sleeping;
    for (int s = 1; s <= static_cast<int>(seconds * 240); ++s) w.step(1.0 / 240);
    return drift();
  }
};
}  // namespace

TEST_CASE("cards: an A-frame stands sleeping or not, on the ground and on a loose card") {
  for (bool sleeping : {false, true}) {
    CardHouse one;
    one.aFrame(0, 0);
    const double m = one.run(sleeping, 10);
    MESSAGE("one A-frame, sleeping " << sleeping << ": drift " << m << " m in 10 s");
    CHECK(m < 0.005);
  }
  {
    // On a loose card as light as itself: the A-frame's feet push the card's ends apart, and the card and the
    // apex share the load. Shock propagation's passes run until they converge here (with a fixed 3 the apex kept
    // closing by 2 mm/s and the frame fell in 4 s).
    CardHouse onCard;
    onCard.add({onCard.span + 0.02, CardHouse::t, CardHouse::d}, {0, CardHouse::t / 2 + 0.0005, 0},
               glm::dquat(1, 0, 0, 0));
    onCard.aFrame(0, CardHouse::t + 0.001);
    const double m = onCard.run(false, 10);
    MESSAGE("an A-frame on a loose card, no sleeping: drift " << m << " m in 10 s");
    CHECK(m < 0.005);
  }
}

TEST_CASE("cards: houses of two and three storeys stand 10 s, sleeping or not; without the resting solve they fall") {
  // Two A-frames, a flat card on their apexes and a third A-frame on it (7 cards); three storeys: 15 cards. Each
  // card's load goes sideways through the leaning cards and the flat ones: the contact step's passes leave the
  // lower frames creeping apart (the house fell in 5 s), the resting solve (plates are loadBearing) holds it.
  // Three storeys, while the upper cards land, take up to 2000 of its sweeps: with the default 1000 the solve is
  // taken when its last sweep is within 10 x its tolerance (the house fell when the contact step's result stood).
  for (int storeys : {2, 3})
    for (bool sleeping : {false, true}) {
      CAPTURE(storeys);
      CAPTURE(sleeping);
      CardHouse h;
      h.house(storeys);
      REQUIRE(h.ids.size() == (storeys == 2 ? 7u : 15u));
      const double settled = h.run(sleeping, 1);
      const double m = h.run(sleeping, 9);
      MESSAGE(storeys << " storeys, sleeping " << sleeping << ": drift " << settled * 1000
                      << " mm after 1 s (settling), " << m * 1000 << " mm after 10 s");
      CHECK(m < 0.01);
      CHECK(m - settled < 0.001);
    }
  CardHouse h;
  h.w.settings().restingSolveRows = 0;
  h.house(2);
  const double m = h.run(false, 10);
  MESSAGE("2 storeys without the resting solve: drift " << m << " m in 10 s");
  CHECK(m > 0.1);
}

TEST_CASE("100 nonconvex tori dropped in a pile come to rest with no NaN and no explosion") {
  World w;
  addGround(w, 0.6, 0.2);
  // Walls keep the pile together.
  for (int k = 0; k < 4; ++k) {
    BodyDef wall;
    wall.shape = makeBox(k < 2 ? glm::dvec3(0.2, 16, 3.4) : glm::dvec3(3.4, 16, 0.2));
    wall.origin = k == 0   ? glm::dvec3(-1.6, 8, 0)
                  : k == 1 ? glm::dvec3(1.6, 8, 0)
                  : k == 2 ? glm::dvec3(0, 8, -1.6)
                           : glm::dvec3(0, 8, 1.6);
    wall.isStatic = true;
    w.addBody(wall);
  }
  const auto torus = makeMeshShape(test::torusMesh(0.3f, 0.1f, 16, 8), 32);
  std::vector<int> ids;
  double potential = 0;
  for (int k = 0; k < 100; ++k) {
    BodyDef d;
    d.shape = torus;
    d.origin = {-1.2 + 0.8 * (k % 4), 0.5 + 0.85 * (k / 16), -1.2 + 0.8 * ((k / 4) % 4)};
    d.orientation = glm::angleAxis(0.7 * k, glm::normalize(glm::dvec3(1, 0.3 * (k % 3), 0.5)));
    d.restitution = 0.3;
    d.friction = 0.5;
    d.density = 800;
    ids.push_back(w.addBody(d));
    potential += w.body(ids.back()).mass * 9.81 * w.body(ids.back()).x.y;
  }
  const double fallSpeed = std::sqrt(2 * 9.81 * 7.0);
  double maxSpeed = 0;
  const int steps = 240 * 3;
  for (int s = 0; s < steps; ++s) {
    w.step(1.0 / 240);
    for (int i : ids) {
      const auto& b = w.body(i);
      REQUIRE(std::isfinite(b.x.x + b.x.y + b.x.z + b.v.x + b.v.y + b.v.z + b.w.x + b.w.y + b.w.z));
      maxSpeed = std::max(maxSpeed, glm::length(b.v));
    }
  }
  double kinetic = 0, lowest = 1e9, highest = -1e9, potentialEnd = 0;
  for (int i : ids) {
    const auto& b = w.body(i);
    kinetic += 0.5 * b.mass * glm::dot(b.v, b.v);
    potentialEnd += b.mass * 9.81 * b.x.y;
    lowest = std::min(lowest, b.x.y);
    highest = std::max(highest, b.x.y);
    CHECK(std::abs(b.x.x) < 1.6);
    CHECK(std::abs(b.x.z) < 1.6);
  }
  const double released = potential - potentialEnd;
  MESSAGE("tori: max speed " << maxSpeed << " m/s (free fall " << fallSpeed << "), kinetic energy at 3 s " << kinetic
                             << " J of " << released << " J released, heights " << lowest << ".." << highest);
  CHECK(maxSpeed < fallSpeed * 1.1);  // no explosion: nothing moves faster than the fall itself
  CHECK(lowest > 0.0);                // nothing fell through the ground (tube radius 0.1)
  CHECK(released > 0);
  CHECK(kinetic < 0.01 * released);  // the pile has come (nearly) to rest
}

TEST_CASE("a heap of 300 mixed bodies started overlapping gains no energy: it only loses what it had") {
  // Spheres, boxes, capsules and cylinders dropped from up to 10 m into a 1 m column, many overlapping at the
  // start. Overlaps are pushed apart by translation only, never at speed: kinetic plus potential energy never
  // rises above its start (beyond 1%), and no body ever moves faster than a fall from the top.
  World w;
  BodyDef g;
  g.shape = makeBox({40, 1, 40});
  g.isStatic = true;
  g.origin = {0, -0.5, 0};
  w.addBody(g);
  Uniform u(12345);
  for (int i = 0; i < 300; ++i) {
    BodyDef b;
    switch (i % 4) {
      case 0:
        b.shape = makeSphere(0.2 + 0.2 * u());
        break;
      case 1:
        b.shape = makeBox({0.3 + 0.4 * u(), 0.3 + 0.4 * u(), 0.3 + 0.4 * u()});
        break;
      case 2:
        b.shape = makeCapsule(0.15, 0.4);
        break;
      default:
        b.shape = makeCylinder(0.2, 0.3);
    }
    b.origin = {u() - 0.5, 0.5 + 9.5 * u(), u() - 0.5};
    b.orientation = glm::normalize(glm::dquat(u(), u() - 0.5, u() - 0.5, u() - 0.5));
    b.restitution = 0.3;
    w.addBody(b);
  }
  auto energy = [&]() {
    double e = 0;
    for (const RigidBody& b : w.bodies()) {
      if (b.isStatic) continue;
      e += b.kineticEnergy() + b.mass * 9.81 * b.x.y;
    }
    return e;
  };
  const double e0 = energy();
  double maxGain = -1e300, maxSpeed = 0, lowest = 1e9;
  for (int s = 0; s < 2 * 240; ++s) {
    w.step(1.0 / 240);
    maxGain = std::max(maxGain, energy() - e0);
    for (const RigidBody& b : w.bodies()) {
      if (b.isStatic) continue;
      maxSpeed = std::max(maxSpeed, glm::length(b.v));
      lowest = std::min(lowest, b.x.y);
      REQUIRE(std::isfinite(b.x.y));
    }
  }
  MESSAGE("heap: largest energy gain " << maxGain << " J of " << e0 << " J, fastest " << maxSpeed << " m/s");
  CHECK(maxGain < 0.01 * e0);
  CHECK(maxSpeed < std::sqrt(2 * 9.81 * 10.5));
  CHECK(lowest > 0);
}

// A semicircular masonry arch of `n` voussoirs (convex mesh bodies, 2400 kg/m^3) springing from the ground;
// returns the largest displacement of any voussoir after `seconds`.
static double archDrift(double thickness, double mu, bool sleeping, double seconds, int* restingSolves = nullptr) {
  PhysicsTestContext c;
  c.settings().sleeping = sleeping;
  c.addGround(mu, 0.0);
  const int n = 10;
  const double ri = 2.0, depth = 0.6, pi = glm::pi<double>();
  std::vector<int> ids;
  for (int k = 0; k < n; ++k) {
    BodyDef b;
    b.shape = makeMeshShape(voussoirMesh(ri, thickness, depth, pi * k / n, pi * (k + 1) / n));
    REQUIRE(b.shape->polytope);  // convex: the manifold path
    b.density = 2400;
    b.friction = mu;
    b.restitution = 0;
    ids.push_back(c.world().addBody(b));
  }
  std::vector<glm::dvec3> start;
  for (int id : ids) start.push_back(c.body(id).x);
  double drift = 0;
  int solves = 0;
  const int steps = static_cast<int>(std::lround(seconds * 240));
  for (int s = 0; s < steps; ++s) {
    c.world().step(c.stepSize());
    solves += c.world().lastStats().restingSolves;
  }
  for (size_t k = 0; k < ids.size(); ++k) drift = std::max(drift, glm::length(c.body(ids[k]).x - start[k]));
  if (restingSolves) *restingSolves = solves;
  return drift;
}

TEST_CASE("a masonry arch (10 voussoirs, t/R 0.18, friction 0.6) stands 10 s within 1 cm, sleeping or not") {
  for (bool sleeping : {false, true}) {
    CAPTURE(sleeping);
    int solves = 0;
    const double drift = archDrift(0.4, 0.6, sleeping, 10.0, &solves);
    MESSAGE("arch t 0.4 mu 0.6 sleeping " << sleeping << ": largest drift " << drift * 1000 << " mm in 10 s, "
                                          << solves << " island solves");
    CHECK(drift < 0.01);
    CHECK(solves > 0);
  }
}

TEST_CASE("the arch holds only what holds in reality: thinner than Heyman's minimum or on low friction it falls") {
  // Heyman's minimum thickness of a semicircular arch is t/R = 0.106 (R the mean radius): 0.25 m on
  // ri 2 m is t/R 0.118 and stands, 0.2 m (0.095) forms four hinges and falls.
  CHECK(archDrift(0.25, 0.6, false, 10.0) < 0.01);
  CHECK(archDrift(0.2, 0.6, false, 3.0) > 0.3);
  // Friction 0.3 cannot hold the springings' thrust: they slide apart (Jolt's arch falls there too).
  CHECK(archDrift(0.4, 0.3, false, 3.0) > 0.3);
}
