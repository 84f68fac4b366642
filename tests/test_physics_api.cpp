// The World's API edges: read-only bodies, setters and forces that refuse
// values that are not finite, and the per-stage timings of a step.
#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <thread>
#include <type_traits>
#include <utility>

#include <crumple/physics/mesh.h>
#include <crumple/physics/sdf_grid.h>
#include "physics_fixture.h"

using namespace crumple;
using namespace crumple::test;
using doctest::Approx;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

// A body's state changes only through the World (its setters and forces).
static_assert(std::is_same_v<decltype(std::declval<World&>().body(0)), const RigidBody&>);

TEST_CASE("setters refuse values that are not finite and leave the body as it was") {
  PhysicsTestContext c;
  const int i = c.addBox({0.5, 0.5, 0.5}, {0, 2, 0}, 0.5, 0.3);
  World& w = c.world();
  const RigidBody before = w.body(i);
  CHECK_THROWS_AS(w.setVelocity(i, {kNaN, 0, 0}), std::invalid_argument);
  CHECK_THROWS_AS(w.setAngularVelocity(i, {0, kInf, 0}), std::invalid_argument);
  CHECK_THROWS_AS(w.setPose(i, {{0, -kInf, 0}, {1, 0, 0, 0}}), std::invalid_argument);
  CHECK_THROWS_AS(w.setPose(i, {{0, 1, 0}, {kNaN, 0, 0, 0}}), std::invalid_argument);
  CHECK_THROWS_AS(w.setPose(i, {{0, 1, 0}, {0, 0, 0, 0}}), std::invalid_argument);
  CHECK_THROWS_AS(w.setRestitution(i, 1.5), std::invalid_argument);
  CHECK_THROWS_AS(w.setRestitution(i, -0.1), std::invalid_argument);
  CHECK_THROWS_AS(w.setRestitution(i, kNaN), std::invalid_argument);
  CHECK_THROWS_AS(w.setFriction(i, -1), std::invalid_argument);
  CHECK_THROWS_AS(w.setFriction(i, kNaN), std::invalid_argument);
  CHECK_THROWS_AS(w.setFriction(i, kInf), std::invalid_argument);
  CHECK_THROWS_AS(w.setVelocity(7, {1, 0, 0}), std::out_of_range);
  CHECK_THROWS_AS(w.setPose(-1, {}), std::out_of_range);
  const RigidBody& b = w.body(i);
  CHECK(b.x == before.x);
  CHECK(b.q == before.q);
  CHECK(b.v == before.v);
  CHECK(b.w == before.w);
  CHECK(b.restitution == before.restitution);
  CHECK(b.friction == before.friction);
}

TEST_CASE("forces and torques refuse values that are not finite; a refused one is not applied") {
  WorldSettings s;
  s.gravity = glm::dvec3(0);
  PhysicsTestContext c(240, s);
  const int i = c.addSphere(0.5, {0, 0, 0}, 0.5, 0.5);
  World& w = c.world();
  CHECK_THROWS_AS(w.addForce(i, {kNaN, 0, 0}), std::invalid_argument);
  CHECK_THROWS_AS(w.addTorque(i, {0, 0, kInf}), std::invalid_argument);
  CHECK_THROWS_AS(w.addForceAtPoint(i, {1, 0, 0}, {0, kNaN, 0}), std::invalid_argument);
  CHECK_THROWS_AS(w.addForceAtPoint(i, {-kInf, 0, 0}, {0, 1, 0}), std::invalid_argument);
  CHECK_THROWS_AS(w.addForce(3, {1, 0, 0}), std::out_of_range);
  c.simulateSteps(1);
  CHECK(w.body(i).v == glm::dvec3(0));
  CHECK(w.body(i).w == glm::dvec3(0));
  // A finite force still acts: a = F / m for one step.
  const double m = w.body(i).mass;
  w.addForce(i, {m, 0, 0});
  c.simulateSteps(1);
  CHECK(w.body(i).v.x == Approx(c.stepSize()));
}

TEST_CASE("setters change the state; a velocity or a new pose wakes a sleeping body, never a static one") {
  PhysicsTestContext c;
  const int ground = c.addGround(0.6, 0.0);
  const int i = c.addBox({0.5, 0.5, 0.5}, {0, 0.25, 0}, 0.6, 0.0);
  World& w = c.world();
  c.simulate(2.0);
  REQUIRE(w.body(i).asleep);
  w.setVelocity(i, {0.5, 0, 0});
  CHECK_FALSE(w.body(i).asleep);
  CHECK(w.body(i).v == glm::dvec3(0.5, 0, 0));
  w.setAngularVelocity(i, {0, 1, 0});
  CHECK(w.body(i).w == glm::dvec3(0, 1, 0));
  // A pose: the centre of mass and a normalised orientation.
  w.setPose(i, {{1, 2, 3}, {2, 0, 0, 0}});
  CHECK(w.body(i).x == glm::dvec3(1, 2, 3));
  CHECK(w.body(i).q == glm::dquat(1, 0, 0, 0));
  w.setRestitution(i, 0.25);
  w.setFriction(i, 0.75);
  CHECK(w.body(i).restitution == 0.25);
  CHECK(w.body(i).friction == 0.75);
  // The box falls from its new place and lands on the ground.
  w.setVelocity(i, glm::dvec3(0));
  w.setAngularVelocity(i, glm::dvec3(0));
  c.simulate(2.0);
  CHECK(w.body(i).x.y == Approx(0.25).epsilon(0.01));
  // A static body stays static.
  w.setVelocity(ground, {1, 0, 0});
  CHECK(w.body(ground).isStatic);
  CHECK_FALSE(w.body(ground).asleep);
}

TEST_CASE("a step reports the milliseconds of each stage") {
  PhysicsTestContext c;
  c.addGround(0.6, 0.1);
  for (int k = 0; k < 20; ++k) c.addBox({0.4, 0.4, 0.4}, {0.05 * (k % 2), 0.3 + 0.5 * k, 0}, 0.6, 0.1);
  c.simulateSteps(10);
  const StepProfile& ms = c.world().lastStats().ms;
  const double stages =
      ms.broadPhase + ms.candidates + ms.collide + ms.contact + ms.shockPropagation + ms.positions + ms.sleep;
  for (double t : {ms.broadPhase, ms.candidates, ms.collide, ms.contact, ms.shockPropagation, ms.positions, ms.sleep})
    CHECK(t >= 0);
  CHECK(ms.total > 0);
  CHECK(stages <= ms.total * (1 + 1e-9));
  CHECK(ms.contact > 0);
}

TEST_CASE("a step that would make a body non-finite is refused and undone, naming the body") {
  World w;
  BodyDef d;
  d.shape = makeBox({1, 1, 1});
  d.origin = {0, 5, 0};
  d.linearVelocity = {1, 0, 0};
  w.addBody(d);
  d.origin = {3, 5, 0};
  d.mass = 1e-3;
  const int light = w.addBody(d);
  REQUIRE(w.step(1.0 / 240));
  const RigidBody before = w.body(light);
  const double t = w.time();
  // A finite force that no double can integrate: 1e308 N on 1 g.
  w.addForce(light, {1e308, 0, 0});
  const StepStatus s = w.step(1.0 / 240);
  CHECK_FALSE(s);
  CHECK(s.body == light);
  CHECK(s.lastPose.position == before.x);
  CHECK(s.lastVelocity == before.v);
  CHECK(w.body(light).x == before.x);
  CHECK(w.body(light).v == before.v);
  CHECK(w.time() == t);
  for (const RigidBody& b : w.bodies()) CHECK(std::isfinite(glm::dot(b.v, b.v) + glm::dot(b.x, b.x)));
  // The force is spent: the next step goes on.
  CHECK(w.step(1.0 / 240));
  CHECK(w.time() > t);
}

TEST_CASE("a distance field asked at a point that is not finite answers 'far', never an index") {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  TriangleMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  m.computeNormals();
  const std::shared_ptr<const Shape> tet = makeMeshShape(m, 8);
  REQUIRE(tet->grid);
  for (const glm::dvec3& p : {glm::dvec3(nan, 0, 0), glm::dvec3(0, inf, 0), glm::dvec3(0, 0, -inf)}) {
    glm::dvec3 g;
    const double phi = tet->grid->distance(p, &g);
    CHECK(phi == inf);
    CHECK(std::isfinite(g.x + g.y + g.z));
  }
  CHECK(tet->grid->distance({1e300, -1e300, 0}, nullptr) > 1e299);
}

TEST_CASE("nearest triangles within a reach: the BVH's distances at any point, the lowest of equal ones, any thread") {
  // A coarse torus (triangles wider than the cells) and a fine one (triangles smaller than the reach, as a car's
  // body has them: each cell lists dozens, and a point's nearest is often a neighbour's edge or corner).
  // Cells of 1 cm and of 20 cm (on the fine torus, lists of some ten thousand triangles: longer than the chunks
  // the lists are kept in, and together past the most a thread keeps, so the lists are emptied and made again;
  // fewer points there, each testing hundreds).
  for (const auto& [segments, rings, cell] :
       {std::tuple{48, 24, 0.01}, std::tuple{360, 120, 0.01}, std::tuple{360, 120, 0.2}}) {
    CAPTURE(segments);
    CAPTURE(cell);
    TriangleMesh m = torusMesh(0.5f, 0.15f, segments, rings);
    const size_t twice = 17;  // a face held twice (as some meshes have): the lower index answers
    const glm::uvec3 again = m.triangles[twice];
    m.triangles.push_back(again);
    const double reach = 0.02;
    const TriangleBvh bvh(m);
    const NearTriangles near(m, cell, reach);
    // Points near the surface (up to 3 cm off it, past the reach), and the duplicated face's centre.
    std::vector<glm::dvec3> points;
    uint64_t s = 12345;
    auto uniform = [&] {
      s = s * 6364136223846793005ull + 1442695040888963407ull;
      return static_cast<double>(s >> 11) / 9007199254740992.0;
    };
    const int count = cell > 0.1 ? 1000 : 4000;
    for (int i = 0; i < count; ++i) {
      const double u = 2 * M_PI * uniform(), v = 2 * M_PI * uniform(), off = 0.06 * uniform() - 0.03;
      const double rr = 0.15 + off;
      points.emplace_back((0.5 + rr * std::cos(v)) * std::cos(u), rr * std::sin(v),
                          (0.5 + rr * std::cos(v)) * std::sin(u));
    }
    const glm::dvec3 centre =
        (glm::dvec3(m.positions[again.x]) + glm::dvec3(m.positions[again.y]) + glm::dvec3(m.positions[again.z])) / 3.0;
    points.push_back(centre);
    std::vector<TriangleBvh::Hit> hits(points.size());
    int inside = 0;
    for (size_t i = 0; i < points.size(); ++i) {
      const TriangleBvh::Hit expected = bvh.closest(points[i], reach * reach);
      hits[i] = near.closest(points[i]);
      CHECK((hits[i].triangle < 0) == (expected.triangle < 0));
      if (expected.triangle < 0) continue;
      ++inside;
      CHECK(hits[i].distance2 == expected.distance2);
    }
    CHECK(inside > count / 4);
    CHECK(inside < count - count / 8);  // (some points lie beyond the reach)
    CHECK(hits.back().triangle == static_cast<int>(twice));
    // Another thread, asking in the opposite order (its own cells, listed in another order): the same answers.
    std::vector<TriangleBvh::Hit> other(points.size());
    std::thread([&] {
      for (size_t i = points.size(); i-- > 0;) other[i] = near.closest(points[i]);
    }).join();
    for (size_t i = 0; i < points.size(); ++i) {
      CHECK(other[i].triangle == hits[i].triangle);
      CHECK(other[i].distance2 == hits[i].distance2);
    }
    CHECK(near.closest({std::numeric_limits<double>::quiet_NaN(), 0, 0}).triangle == -1);
  }
}

TEST_CASE("a dented body's answers at its surface samples are kept until its dents change, from any thread") {
  // An upright cylinder on the ground whose bottom rim's dented surface lies `sunk` inside its undented one: it
  // settles that much lower. The world asks the depth at each of its rim's samples once a change of its dents
  // (setDented), not at each contact: a new answer without setDented is not seen, with it is.
  for (int threads : {1, 2}) {
    WorldSettings settings;
    settings.threads = threads;
    settings.sleeping = false;
    World w(settings);
    addGround(w, 0.8, 0.0);
    BodyDef def;
    def.shape = makeCylinder(0.2, 0.3);
    def.origin = {0, 0.15, 0};
    def.mass = 2;
    def.restitution = 0;
    const int c = w.addBody(def);
    std::atomic<double> sunk{0.005};
    std::atomic<long> asked{0};
    w.setSurfaceDepth([&, c](int body, const glm::dvec3&, const glm::dvec3& n, glm::dvec3& bent) {
      bent = n;
      if (body != c || n.y > -0.5) return 0.0;
      if (n.y > -0.75 && n.y < -0.65) ++asked;  // at a rim sample (its normal: 45 degrees down and out)
      return sunk.load();
    });
    w.setDented(c, 0.0);
    auto settle = [&] {
      for (int s = 0; s < 240; ++s) w.step(1.0 / 240);
      return w.body(c).x.y;
    };
    const double first = settle();
    CHECK(first == Approx(0.15 - 0.005).epsilon(0.01));
    // Each of the rim's 24 bottom samples asked at most once (a thread losing the race to keep one asks too),
    // over a second of steps whose contacts all met them. (Points of the ground's own samples, projected onto
    // the cylinder's bottom, are asked at each contact: they move.)
    CHECK(asked.load() > 0);
    CHECK(asked.load() <= 24L * threads);
    sunk = 0.02;
    const double kept = settle();
    CHECK(std::abs(kept - first) < 1e-3);  // the kept answers: nothing changed for the world
    w.setDented(c, 0.0);
    const double changed = settle();
    CHECK(changed == Approx(0.15 - 0.02).epsilon(0.01));
  }
}

// Contact reports (World::setReportContacts, the contact deformation of the paper's figure 8): none until a body
// asks; then one per step for each pair of a flagged body that the contact step pushed apart, and none for a pair
// of bodies that did not ask, also for a body added after the flag was set.
TEST_CASE("contact reports come only for bodies that ask for them, bodies added later included") {
  World w;
  test::addGround(w);
  const int a = test::addBox(w, {0.5, 0.5, 0.5}, {0, 0.25, 0}, 0.5, 0.0);
  w.step(1.0 / 60);
  CHECK(w.contactReports().empty());  // (resting on the ground, but nobody asked)
  w.setReportContacts(a, true);
  const int b = test::addBox(w, {0.5, 0.5, 0.5}, {3, 0.25, 0}, 0.5, 0.0);  // after the flag: not flagged
  for (int k = 0; k < 10; ++k) {
    w.step(1.0 / 60);
    REQUIRE(w.contactReports().size() == 1);
    const CollisionEvent& e = w.contactReports().front();
    CHECK((e.a == a || e.b == a));
    CHECK((e.a != b && e.b != b));
    CHECK(e.impulse > 0);
  }
  w.setReportContacts(a, false);
  w.step(1.0 / 60);
  CHECK(w.contactReports().empty());
}
