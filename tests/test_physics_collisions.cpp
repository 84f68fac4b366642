// Free flight and collisions against analytic answers and conservation laws;
// no tunnelling at speed.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <string>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/quaternion.hpp>

#include <crumple/physics/sample_tree.h>
#include <crumple/physics/sdf_grid.h>
#include "physics_fixture.h"
#include "test_meshes.h"

using namespace crumple;
using namespace crumple::test;
using doctest::Approx;

namespace {
// `count` frictionless, perfectly elastic spheres of radius r0 + dr u in a cube of side `side`, each moving at up to
// `speed` / 2 m/s per axis (the numbers from Uniform(seed), in that order); their radii.
std::vector<double> addSphereCloud(World& w, uint64_t seed, int count, double r0, double dr, double side,
                                   double speed) {
  Uniform u(seed);
  std::vector<double> radius;
  for (int k = 0; k < count; ++k) {
    BodyDef d;
    radius.push_back(r0 + dr * u());
    d.shape = makeSphere(radius.back());
    d.origin = {side * u(), side * u(), side * u()};
    d.linearVelocity = glm::dvec3(u() - 0.5, u() - 0.5, u() - 0.5) * speed;
    d.friction = 0;
    d.restitution = 1;
    w.addBody(d);
  }
  return radius;
}
}  // namespace

TEST_CASE("free fall matches x = x0 - g t^2 / 2") {
  World w;
  BodyDef d;
  d.shape = makeSphere(0.5);
  d.origin = {0, 100, 0};
  const int i = w.addBody(d);
  const double h = 1.0 / 240;
  for (int s = 0; s < 240; ++s) w.step(h);
  // Symplectic Euler: x_n = x0 - g h^2 n(n+1)/2
  CHECK(w.body(i).x.y == Approx(100 - 9.81 * h * h * 240 * 241 / 2).epsilon(1e-9));
  CHECK(w.body(i).v.y == Approx(-9.81).epsilon(1e-9));
}

TEST_CASE("a bouncing sphere reaches eps^2 h") {
  for (double eps : {0.9, 0.5}) {
    World w;
    addGround(w, 0.0, 1.0);
    BodyDef d;
    d.shape = makeSphere(0.25);
    d.origin = {0, 0.25 + 2.0, 0};
    d.restitution = eps;
    d.friction = 0.0;
    const int i = w.addBody(d);
    const double h = 1.0 / 240;
    bool bounced = false;
    double apex = 0;
    for (int s = 0; s < 240 * 3; ++s) {
      w.step(h);
      const auto& b = w.body(i);
      if (b.v.y > 0) bounced = true;
      if (bounced) apex = std::max(apex, b.x.y - 0.25);
      if (bounced && b.v.y < 0) break;
    }
    CHECK(bounced);
    CHECK(apex == Approx(eps * eps * 2.0).epsilon(0.04));
  }
}

TEST_CASE("a ball thrown down at a slant leaves the ground rolling at 5/7 of its tangential speed, bouncing eps v") {
  // A solid ball (no spin) hits the ground at 6 m/s down and 0.7 m/s along; friction 0.57 is enough to stop its
  // sliding within the impact, so it leaves rolling: v_t = 5/7 * 0.7 = 0.5 m/s, omega = v_t / r, and bounces at
  // eps * 6 = 1.2 m/s (the default scene's throw). One exact contact gives this; the ground's surface samples
  // inside the ball added normals tilted by where each sample sat.
  World w;
  addGround(w, 0.8, 0.2);
  BodyDef d;
  d.shape = makeSphere(0.25);
  d.origin = {0, 0.26, 0};
  d.linearVelocity = {0.7, -6, 0};
  d.friction = 0.4;
  d.restitution = 0.95;
  d.density = 7800;
  const int b = w.addBody(d);
  w.settings().gravity = glm::dvec3(0);
  for (int s = 0; s < 12; ++s) w.step(1.0 / 240);
  const RigidBody& ball = w.body(b);
  MESSAGE("after the bounce: v = (" << ball.v.x << ", " << ball.v.y << ", " << ball.v.z << "), omega z " << ball.w.z);
  CHECK(ball.v.x == doctest::Approx(0.5).epsilon(1e-3));
  CHECK(ball.w.z == doctest::Approx(-0.5 / 0.25).epsilon(1e-3));
  CHECK(ball.v.y == doctest::Approx(1.2).epsilon(0.02));
  CHECK(std::abs(ball.v.z) < 1e-9);
}

TEST_CASE("head-on collision of unequal masses with partial restitution, zero gravity") {
  WorldSettings s;
  s.gravity = {0, 0, 0};
  World w(s);
  BodyDef a, b;
  a.shape = makeSphere(0.5);
  a.origin = {-2, 0, 0};
  a.linearVelocity = {3, 0, 0};
  a.mass = 2;
  a.restitution = 0.6;
  a.friction = 0;
  b = a;
  b.origin = {2, 0, 0};
  b.linearVelocity = {-1, 0, 0};
  b.mass = 1;
  b.restitution = 0.8;
  const int ia = w.addBody(a), ib = w.addBody(b);
  const double p0 = 2 * 3 + 1 * -1;
  for (int s2 = 0; s2 < 480; ++s2) w.step(1.0 / 240);
  const double va = w.body(ia).v.x, vb = w.body(ib).v.x;
  CHECK(2 * va + vb == Approx(p0));
  // eps = min(0.6, 0.8): v_b - v_a = eps * 4
  CHECK(vb - va == Approx(0.6 * 4.0));
  CHECK(w.body(ia).v.y == Approx(0.0));
}

TEST_CASE("momentum is conserved among tumbling boxes in zero gravity") {
  WorldSettings s;
  s.gravity = {0, 0, 0};
  World w(s);
  glm::dvec3 p0(0), L0(0);
  for (int k = 0; k < 6; ++k) {
    BodyDef d;
    d.shape = makeBox({0.5 + 0.1 * k, 0.4, 0.6});
    d.origin = {std::cos(k * 1.1) * 1.5, std::sin(k * 0.7) * 1.5, (k % 3) * 0.8 - 0.8};
    d.linearVelocity = -d.origin * 0.8;
    d.angularVelocity = {0.3 * k, -0.2, 0.1};
    d.restitution = 0.5;
    d.friction = 0.3;
    w.addBody(d);
  }
  for (const auto& b : w.bodies()) p0 += b.mass * b.v;
  int collisions = 0;
  for (int k = 0; k < 480; ++k) {
    w.step(1.0 / 240);
    collisions += static_cast<int>(w.events().size());
  }
  CHECK(collisions >= 3);
  glm::dvec3 p1(0);
  for (const auto& b : w.bodies()) p1 += b.mass * b.v;
  CHECK(glm::length(p1 - p0) < 1e-9 * (1 + glm::length(p0)));
  (void)L0;
}

TEST_CASE("a fast box does not tunnel through a thin static rail at 40 m/s (and 150 m/s)") {
  // Substeps keep every body's travel per substep under half the thinnest body's
  // half thickness; with at most 16 substeps at 240 Hz a 0.2 m rail holds up to
  // 0.5 * 0.1 m * 16 * 240 /s = 192 m/s.
  for (double speed : {40.0, 150.0}) {
    CAPTURE(speed);
    WorldSettings s;
    s.gravity = {0, 0, 0};
    World w(s);
    BodyDef rail;
    rail.shape = makeBox({0.2, 0.8, 6});
    rail.isStatic = true;
    rail.restitution = 0.2;
    w.addBody(rail);
    BodyDef car;
    car.shape = makeBox({4.2, 1.3, 1.8});
    car.origin = {-4, 0, 0};
    car.linearVelocity = {speed, 0, 0};
    car.mass = 1200;
    car.restitution = 0.2;
    const int i = w.addBody(car);
    for (int k = 0; k < 120; ++k) w.step(1.0 / 240);
    CHECK(w.body(i).x.x < -2.1 + 0.05);  // front face never past the rail's near face (by more than 5 cm)
    CHECK(w.body(i).v.x <= 0.0);
  }
}

TEST_CASE("thin plates hold: nothing tunnels through a static plate down to the loader's 0.1 mm at up to 100 m/s") {
  // Substeps cannot cover a 0.1 mm plate (16 substeps at 240 Hz move a body 100 m/s * 0.26 ms = 2.6 cm); the narrow
  // phase marches each sample along its path through thin bodies instead (continuous collision).
  struct Case {
    const char* name;
    std::shared_ptr<const Shape> shape;
    double speed;
  };
  const std::vector<Case> cases = {{"sphere 5 cm", makeSphere(0.05), 50},  {"box 5 cm", makeBox({0.05, 0.05, 0.05}), 50},
                                   {"box 30 cm", makeBox({0.3, 0.3, 0.3}), 100}, {"capsule", makeCapsule(0.03, 0.3), 40},
                                   {"disc", makeCylinder(0.1, 0.02), 60}};
  for (double thickness : {1e-4, 1e-3}) {
    for (const Case& c : cases) {
      for (double tilt : {0.0, 30.0, 80.0}) {
        CAPTURE(thickness);
        const std::string name = c.name;
        CAPTURE(name);
        CAPTURE(tilt);
        World w;
        BodyDef plate;
        plate.shape = makeBox({40, thickness, 40});  // wide: a hit can send a body sideways at 25 m/s
        plate.isStatic = true;
        plate.origin = {0.13, 0, 0.07};  // samples not lined up with the plate's
        w.addBody(plate);
        BodyDef b;
        b.shape = c.shape;
        b.origin = {0, 1.0, 0};
        b.orientation = glm::angleAxis(glm::radians(tilt), glm::normalize(glm::dvec3(1, 0, 0.5)));
        b.linearVelocity = {0, -c.speed, 0};
        b.restitution = 0.3;
        const int i = w.addBody(b);
        double lowest = 1e9;
        for (int k = 0; k < 144; ++k) {
          w.step(1.0 / 240);
          lowest = std::min(lowest, w.body(i).x.y);
        }
        CHECK(lowest > 0);  // its centre never went below the plate
        CHECK(w.body(i).x.y > 0);
      }
    }
  }
}

TEST_CASE("fast bodies hold: a ball at 100 to 10000 m/s never passes a 2 cm plate, static or free") {
  // At these speeds the substeps are capped (16) and a substep carries the ball past the plate's middle: a
  // sample that ends there, its gradient pointing out of the far side, is met where it came in.
  std::vector<double> speeds;
  for (double v = 100; v <= 1000; v += 25) speeds.push_back(v);
  for (double v : {1500.0, 3000.0, 10000.0}) speeds.push_back(v);
  for (bool free : {false, true}) {
    for (double speed : speeds) {
      CAPTURE(free);
      CAPTURE(speed);
      WorldSettings settings;
      if (free) settings.gravity = glm::dvec3(0);
      World w(settings);
      BodyDef plate;
      plate.shape = makeBox({2, 0.02, 2});
      plate.isStatic = !free;
      plate.restitution = 0.2;
      const int p = w.addBody(plate);
      BodyDef b;
      b.shape = makeSphere(0.05);
      b.origin = {0, 1.0, 0};
      b.linearVelocity = {0, -speed, 0};
      b.restitution = 0.2;
      const int i = w.addBody(b);
      double lowest = 1e9;
      for (int k = 0; k < 24; ++k) {
        w.step(1.0 / 240);
        lowest = std::min(lowest, w.body(i).x.y - w.body(p).x.y);
      }
      // The ball's centre never below the plate's middle, and the ball leaves upwards, relative to the plate.
      CHECK(lowest > 0);
      CHECK(w.body(i).v.y > w.body(p).v.y);
    }
  }
}

TEST_CASE("convex meshes become polytopes; nonconvex ones keep the samples") {
  const double pi = glm::pi<double>();
  const auto wedge = convexPolytope(voussoirMesh(2.0, 0.4, 0.6, 0, pi / 10));
  REQUIRE(wedge);
  CHECK(wedge->faces.size() == 6);
  CHECK(wedge->vertices.size() == 8);
  CHECK(wedge->edges.size() == 12);
  for (const auto& f : wedge->faces) CHECK(f.loop.size() == 4);
  // Exact distance inside: a point on the mid-angle, 2.05 m out, below the inner face (a chord 2 cos 9 deg out).
  const glm::dvec3 p(2.05 * std::cos(pi / 20), 2.05 * std::sin(pi / 20), 0);
  CHECK(wedge->planeDistance(p) == Approx(-(2.05 - 2 * std::cos(pi / 20))).epsilon(1e-5));
  CHECK_FALSE(convexPolytope(torusMesh(0.3f, 0.1f, 16, 8)));
  const auto box = boxPolytope({0.5, 1, 1.5});
  CHECK(box->faces.size() == 6);
  CHECK(box->edgeDirections.size() == 3);
}

TEST_CASE("box on box: the dedicated manifold finds what the polytopes' finds") {
  // Random boxes in random relative poses, many of them touching: the same points, normals and depths as the
  // general polytope manifold (face, face of B, and edge cases all met), up to the order of the points.
  Uniform u(11);
  int touching = 0, onB = 0, edges = 0;
  std::vector<PolytopeContact> general, dedicated;
  for (int trial = 0; trial < 4000; ++trial) {
    const glm::dvec3 ha(0.1 + u(), 0.1 + u(), 0.1 + u()), hb(0.1 + u(), 0.1 + u(), 0.1 + u());
    RigidMap map;
    if (trial % 4 == 0) {
      // Aligned (a stack), slightly turned about the vertical: faces lying on faces.
      map.rotation = glm::mat3_cast(glm::angleAxis(0.2 * (u() - 0.5), glm::dvec3(0, 1, 0)));
    } else {
      map.rotation = glm::mat3_cast(glm::angleAxis(6.3 * u(), glm::normalize(glm::dvec3(u(), u(), u()) - 0.5)));
    }
    const glm::dvec3 dir = glm::normalize(glm::dvec3(u(), u(), u()) - 0.5);
    map.translation = dir * (0.5 + 2.5 * u()) * (trial % 4 == 0 ? 0.0 : 1.0);
    if (trial % 4 == 0) map.translation = {0.3 * (u() - 0.5), ha.y + hb.y - 0.02 * u(), 0.3 * (u() - 0.5)};
    polytopeContacts(*boxPolytope(ha), *boxPolytope(hb), map, general);
    boxContacts(ha, hb, map, dedicated);
    REQUIRE(general.size() == dedicated.size());
    if (general.empty()) continue;
    ++touching;
    onB += !general[0].normalOfA;
    edges += general.size() == 1;
    for (const PolytopeContact& g : general) {
      bool matched = false;
      for (const PolytopeContact& d : dedicated)
        matched = matched || (d.normalOfA == g.normalOfA && glm::length(d.point - g.point) < 1e-9 &&
                              glm::length(d.normal - g.normal) < 1e-9 && std::abs(d.depth - g.depth) < 1e-9);
      CHECK(matched);
    }
  }
  MESSAGE("box on box: " << touching << " touching, " << onB << " on B's face, " << edges << " single points");
  CHECK(touching > 1000);
  CHECK(onB > 100);
  CHECK(edges > 50);
}

TEST_CASE("a box resting off-centre on a box touches at the corners of the overlap of their faces") {
  // A 0.4 m cube pressed 1 mm into a 0.6 x 0.2 x 0.6 m slab, 0.35 m off-centre in x and 0.1 m in z, turned 0.3 rad
  // about the vertical: the contacts are the corners of the overlap of the two faces (the cube's bottom face
  // clipped to the slab's top), each 1 mm deep along the slab's normal.
  World w;
  const int a = addBox(w, {0.6, 0.2, 0.6}, {0, 0, 0}, 0.5, 0);
  const int b = addBox(w, {0.4, 0.4, 0.4}, {0.35, 0.3 - 0.001, 0.1}, 0.5, 0);
  const glm::dquat turn = glm::angleAxis(0.3, glm::dvec3(0, 1, 0));
  std::vector<Contact> contacts;
  w.findContacts(a, b, {w.body(a).x, w.body(a).q}, {w.body(b).x, turn}, contacts);
  // The cube's bottom face: its centre c (in x, z) and half axes u, v.
  const glm::dvec3 c(0.35, 0, 0.1);
  const glm::dvec3 u = turn * glm::dvec3(0.2, 0, 0), v = turn * glm::dvec3(0, 0, 0.2);
  double area = 0;  // of the overlap, counted on a grid over the slab's top
  const int n = 400;
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) {
      const glm::dvec2 p(-0.3 + 0.6 * (i + 0.5) / n, -0.3 + 0.6 * (k + 0.5) / n);
      const glm::dvec3 d = glm::dvec3(p.x, 0, p.y) - c;
      if (std::abs(glm::dot(d, u)) <= 0.04 && std::abs(glm::dot(d, v)) <= 0.04) area += 0.36 / (n * n);
    }
  REQUIRE(contacts.size() >= 4);
  std::vector<glm::dvec2> polygon;
  for (const Contact& k : contacts) {
    CHECK(k.phi == Approx(-0.001).epsilon(1e-6));
    CHECK(std::abs(std::abs(k.normal.y) - 1) < 1e-12);
    CHECK(k.point.x <= 0.3 + 1e-12);  // on the slab's top face
    CHECK(std::abs(k.point.z) <= 0.3 + 1e-12);
    const glm::dvec3 d = k.point - glm::dvec3(0.35, k.point.y, 0.1);
    CHECK(std::abs(glm::dot(d, u)) <= 0.04 + 1e-12);  // and inside the cube's bottom face
    CHECK(std::abs(glm::dot(d, v)) <= 0.04 + 1e-12);
    polygon.push_back({k.point.x, k.point.z});
  }
  // The contacts span the overlap: their polygon's area (its corners in angle order, shoelace) is the overlap's.
  glm::dvec2 mid(0);
  for (const glm::dvec2& p : polygon) mid += p / static_cast<double>(polygon.size());
  std::sort(polygon.begin(), polygon.end(), [&](const glm::dvec2& p, const glm::dvec2& q) {
    return std::atan2(p.y - mid.y, p.x - mid.x) < std::atan2(q.y - mid.y, q.x - mid.x);
  });
  double shoelace = 0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const glm::dvec2& p = polygon[i];
    const glm::dvec2& q = polygon[(i + 1) % polygon.size()];
    shoelace += p.x * q.y - q.x * p.y;
  }
  MESSAGE("overlap " << area << " m^2, contacts' polygon " << std::abs(shoelace) / 2 << " m^2, " << contacts.size()
                     << " contacts");
  CHECK(std::abs(shoelace) / 2 == Approx(area).epsilon(0.01));
}

TEST_CASE("two voussoirs lying face on face touch over the whole joint, not at its centre") {
  // The samples of a face lying on a face of the same size sit on the other's edges, neither in nor out:
  // the manifold clips the joint's polygon instead, four corners deep.
  const double pi = glm::pi<double>();
  World w;
  const int a = addShape(w, makeMeshShape(voussoirMesh(2.0, 0.4, 0.6, 0.4 * pi, 0.5 * pi)), {0, 0, 0}, 0.6, 0);
  const int b = addShape(w, makeMeshShape(voussoirMesh(2.0, 0.4, 0.6, 0.5 * pi, 0.6 * pi)), {0, 0, 0}, 0.6, 0);
  const RigidBody& A = w.body(a);
  const RigidBody& B = w.body(b);
  std::vector<Contact> contacts;
  // B pressed 1 mm into A across the joint (the joint's normal is x).
  w.findContacts(a, b, {A.x, A.q}, {B.x + glm::dvec3(0.001, 0, 0), B.q}, contacts);
  REQUIRE(contacts.size() == 4);
  glm::dvec3 lo(1e9), hi(-1e9);
  for (const Contact& c : contacts) {
    CHECK(c.phi == Approx(-0.001).epsilon(1e-3));
    CHECK(std::abs(std::abs(c.normal.x) - 1) < 1e-9);
    lo = glm::min(lo, c.point);
    hi = glm::max(hi, c.point);
  }
  CHECK(hi.y - lo.y == Approx(0.4).epsilon(1e-3));  // the joint's radial extent
  CHECK(hi.z - lo.z == Approx(0.6).epsilon(1e-3));  // and its depth
}

TEST_CASE("sample tree: an oriented box query visits every sample inside it and few of the others") {
  Uniform u(3);
  std::vector<glm::dvec3> samples;
  for (int i = 0; i < 5000; ++i) samples.push_back({2 * u() - 1, 2 * u() - 1, 0.5 * u()});
  const SampleTree tree(samples);
  REQUIRE(tree.size() == samples.size());
  size_t visited = 0, inside = 0, missed = 0, twice = 0;
  for (int q = 0; q < 200; ++q) {
    const glm::dmat3 axes = glm::mat3_cast(glm::angleAxis(6.3 * u(), glm::normalize(glm::dvec3(u(), u(), u()) + 0.01)));
    const glm::dvec3 centre(2 * u() - 1, 2 * u() - 1, 0.5 * u()), half(0.05 + 0.2 * u(), 0.05 + 0.2 * u(), 0.01);
    std::vector<char> seen(samples.size(), 0);
    tree.query(centre, axes, half, [&](uint32_t k) {
      ++seen[k];
      ++visited;
    });
    for (size_t k = 0; k < samples.size(); ++k) {
      twice += seen[k] > 1;
      const glm::dvec3 local = glm::transpose(axes) * (samples[k] - centre);
      if (std::abs(local.x) <= half.x && std::abs(local.y) <= half.y && std::abs(local.z) <= half.z) {
        ++inside;
        missed += seen[k] != 1;
      }
    }
  }
  MESSAGE("sample tree: " << inside << " samples inside the boxes, " << visited << " visited of " << 200 * 5000);
  CHECK(inside > 0);
  CHECK(missed == 0);
  CHECK(twice == 0);
  CHECK(visited < 200 * 5000 / 10);  // thin boxes: a small fraction of the samples is looked at
}

TEST_CASE("sample tree: bodies on a mesh step to the same bits with the tree and without it") {
  auto run = [](bool withTree) {
    World w;
    addGround(w, 0.6, 0.2);
    auto torus = std::make_shared<Shape>(*makeMeshShape(torusMesh(0.6f, 0.2f, 32, 16), 32));
    REQUIRE(torus->sampleTree);
    if (!withTree) torus->sampleTree.reset();
    BodyDef d;
    d.shape = torus;
    d.origin = {0, 0.3, 0};
    d.orientation = glm::angleAxis(0.2, glm::dvec3(1, 0, 0));
    w.addBody(d);
    for (int k = 0; k < 12; ++k)
      addBox(w, {0.15, 0.15, 0.15}, {-0.6 + 0.11 * k, 0.7 + 0.2 * (k % 3), 0.05 * (k % 4)}, 0.5, 0.3);
    for (int s = 0; s < 240; ++s) w.step(1.0 / 240);
    return w.stateHash();
  };
  CHECK(run(true) == run(false));
}

TEST_CASE("a mesh's half thickness is its thinnest part's: a torus's tube, an L's thinner arm") {
  // Torus of tube radius 0.1 (16 x 8 segments: the tube's octagon has an inscribed radius of 0.092).
  const auto torus = makeMeshShape(torusMesh(0.3f, 0.1f, 16, 8), 32);
  MESSAGE("torus tube 0.1: half thickness " << torus->halfThickness());
  CHECK(torus->halfThickness() > 0.08);
  CHECK(torus->halfThickness() < 0.12);
  // An L-shaped prism 0.6 deep: a 1 x 0.2 arm and a 0.6 x 0.6 block at its end. Its thinnest part is the arm
  // (half thickness 0.1), never the block's 0.3.
  const glm::vec2 outline[7] = {{0, 0}, {1, 0}, {1.6f, 0}, {1.6f, 0.6f}, {1, 0.6f}, {1, 0.2f}, {0, 0.2f}};
  TriangleMesh l;
  for (float z : {0.0f, 0.6f})
    for (const glm::vec2& p : outline) l.positions.push_back({p.x, p.y, z});
  const unsigned caps[5][3] = {{0, 1, 5}, {0, 5, 6}, {1, 2, 3}, {1, 3, 4}, {1, 4, 5}};  // counter-clockwise
  for (const auto& t : caps) {
    l.triangles.push_back({t[0], t[2], t[1]});         // bottom, seen from below
    l.triangles.push_back({t[0] + 7, t[1] + 7, t[2] + 7});  // top
  }
  for (unsigned i = 0; i < 7; ++i) {
    const unsigned j = (i + 1) % 7;
    l.triangles.push_back({i, j, j + 7});
    l.triangles.push_back({i, j + 7, i + 7});
  }
  l.computeNormals();
  const auto shape = makeMeshShape(l, 48);
  MESSAGE("L: half thickness " << shape->halfThickness());
  CHECK(shape->halfThickness() <= 0.11);
  CHECK(shape->halfThickness() > 0.05);
}

TEST_CASE("a long thin mesh's distance field resolves its profile: a 4 m guard-rail beam's W within 5 mm") {
  // A beam 4 m along x with a W profile 0.31 m tall (y): its traffic face zigzags between z = -0.01 and -0.09
  // (two crests, a groove between, as scenes/assets/wbeam.obj), its back flat at z = +0.09.
  std::vector<glm::vec2> front;  // (y, z), y rising
  for (int i = 0; i <= 16; ++i) {
    const float y = -0.155f + 0.31f * static_cast<float>(i) / 16;
    front.push_back({y, -0.05f - 0.04f * std::cos(2 * glm::pi<float>() * static_cast<float>(i) / 8)});
  }
  TriangleMesh beam;
  const unsigned n = static_cast<unsigned>(front.size());
  for (float x : {-2.0f, 2.0f}) {
    for (const glm::vec2& f : front) beam.positions.push_back({x, f.x, f.y});
    for (const glm::vec2& f : front) beam.positions.push_back({x, f.x, 0.09f});
  }
  // Vertex k of the front (0) or back (1) line at end e (0: x = -2, 1: x = +2).
  auto v = [&](unsigned e, unsigned back, unsigned k) { return e * 2 * n + back * n + k; };
  // Each triangle wound to face `out`.
  auto add = [&](unsigned a, unsigned b, unsigned c, const glm::vec3& out) {
    const glm::vec3 nrm = glm::cross(beam.positions[b] - beam.positions[a], beam.positions[c] - beam.positions[a]);
    if (glm::dot(nrm, out) >= 0) beam.triangles.push_back({a, b, c});
    else beam.triangles.push_back({a, c, b});
  };
  for (unsigned k = 0; k + 1 < n; ++k) {
    for (unsigned e = 0; e < 2; ++e) {  // the end caps: a strip of quads between the front and the back
      const glm::vec3 out(e ? 1 : -1, 0, 0);
      add(v(e, 0, k), v(e, 0, k + 1), v(e, 1, k + 1), out);
      add(v(e, 0, k), v(e, 1, k + 1), v(e, 1, k), out);
    }
    add(v(0, 0, k), v(1, 0, k), v(1, 0, k + 1), {0, 0, -1});  // the traffic face
    add(v(0, 0, k), v(1, 0, k + 1), v(0, 0, k + 1), {0, 0, -1});
    add(v(0, 1, k), v(1, 1, k), v(1, 1, k + 1), {0, 0, 1});  // the back
    add(v(0, 1, k), v(1, 1, k + 1), v(0, 1, k + 1), {0, 0, 1});
  }
  for (unsigned k : {0u, n - 1}) {  // the bottom and top edges' faces
    const glm::vec3 out(0, k ? 1 : -1, 0);
    add(v(0, 0, k), v(1, 0, k), v(1, 1, k), out);
    add(v(0, 0, k), v(1, 1, k), v(0, 1, k), out);
  }
  beam.computeNormals();
  const SdfGrid grid(beam, 48);  // makeMeshShape's default resolution
  // Points 1 cm in front of the traffic face (and 1 cm behind it) along the beam: the field against the exact
  // distance. Cells of 4 m / 48 = 8 cm (the longest extent's alone) put the crests and the groove inside two
  // cells and miss by 3 cm.
  double worst = 0;
  for (double x = -1.9; x <= 1.9; x += 0.173)
    for (size_t k = 1; k + 1 < front.size(); ++k) {
      const glm::dvec3 on(x, front[k].x, front[k].y);
      for (double off : {-0.01, 0.01}) {
        const glm::dvec3 p = on + glm::dvec3(0, 0, off);
        worst = std::max(worst, std::abs(grid.distance(p, nullptr) - grid.exactDistance(p)));
      }
    }
  MESSAGE("W beam: the field's worst error 1 cm off its face " << worst << " m");
  CHECK(worst < 0.005);
}

TEST_CASE("a mesh's distance grid changes no faster than its bound (SdfGrid::lipschitz)") {
  // The narrow phase skips a sample whose distance, less the bound times how far it can have moved, stays
  // above zero: a bound that is too small would miss contacts.
  const SdfGrid torus(torusMesh(0.3f, 0.1f, 16, 8), 32);
  const SdfGrid block(test::voussoirMesh(1.0, 0.25, 0.3, 0.3 * 3.141592653589793, 0.4 * 3.141592653589793), 24);
  for (const SdfGrid* grid : {&torus, &block}) {
    const double L = grid->lipschitz();
    // Exact distances at the nodes change by at most a cell per cell along an axis: at most sqrt(3 + 1) in all.
    CHECK(L >= 1);
    CHECK(L <= 2 + 1e-9);
    test::Uniform u(7);
    double steepest = 0;
    for (int k = 0; k < 20000; ++k) {
      // Points in and around the body (some outside the grid), and a second one near it or far from it.
      const glm::dvec3 p(2 * u() - 1, 2 * u() - 1, 2 * u() - 1);
      const double reach = k % 2 ? 1e-4 + 0.01 * u() : 0.5 * u();
      const glm::dvec3 d = glm::normalize(glm::dvec3(u() - 0.5, u() - 0.5, u() - 0.5) + 1e-9) * reach;
      const double change = std::abs(grid->distance(p + d, nullptr) - grid->distance(p, nullptr));
      REQUIRE(change <= L * reach * (1 + 1e-9) + 1e-12);
      steepest = std::max(steepest, change / reach);
    }
    MESSAGE("bound " << L << ", steepest change seen " << steepest);
    CHECK(steepest > 0.9);  // (near the surface a distance changes as fast as the point moves)
  }
}

TEST_CASE("substeps go by pairs that can meet: bodies falling side by side take none, one closing on a plate does") {
  // apart: the plate in a group set apart from the boxes', or (joined) each box joined to it: pairs that never
  // collide ask for no substeps.
  enum class Apart { No, Groups, Joined };
  auto substeps = [](bool plate, Apart apart = Apart::No) {
    World w;
    w.settings().gravity = {0, 0, 0};
    // Two small boxes (half thickness 0.05) 5 mm apart side by side at 30 m/s: 0.125 m a step at 240 Hz, 5
    // times what one substep may move (half the thinnest half thickness).
    const int a = addBox(w, {0.1, 0.1, 0.1}, {0, 10, 0}, 0.5, 0.5);
    const int b = addBox(w, {0.1, 0.1, 0.1}, {0.105, 10, 0}, 0.5, 0.5);
    w.setVelocity(a, {0, -30, 0});
    w.setVelocity(b, {0, -30, 0});
    if (plate) {
      BodyDef d;
      d.shape = makeBox({2, 0.1, 2});
      d.origin = {0, 9.8, 0};
      d.isStatic = true;
      if (apart == Apart::Joined) {  // a dynamic plate, each box held to it by a rod that lets it fall
        d.isStatic = false;
        d.density = 1000;
      }
      const int p = w.addBody(d);
      if (apart == Apart::Groups) {
        w.setGroup(p, 2);
        w.setGroupsCollide(0, 2, false);
      }
      if (apart == Apart::Joined) {
        for (int box : {a, b}) {
          JointDef j;
          j.type = JointType::Distance;
          j.a = p;
          j.b = box;
          j.anchorA = w.body(p).x;
          j.anchorB = w.body(box).x;
          j.minLength = 0;
          j.maxLength = 10;  // a slack rope: it acts on nothing within the step
          w.addJoint(j);
        }
      }
    }
    w.step(1.0 / 240);
    return w.lastStats().substeps;
  };
  CHECK(substeps(false) == 1);
  CHECK(substeps(true) == 5);  // 0.125 m / (0.5 x 0.05 m)
  CHECK(substeps(true, Apart::Groups) == 1);
  CHECK(substeps(true, Apart::Joined) == 1);
}

TEST_CASE("substeps: bodies whose spheres stay apart over the step ask for none, however their boxes overlap") {
  // Two rods 1 m long and 4 cm thick (half thickness 0.02: a substep may move 1 cm) on one diagonal line, their
  // centres `apart` m apart, B closing on A along the line at 9 m/s: 0.15 m in a 60 Hz step. Tilted, their bounds
  // boxes reach 0.71 m from the centres along x and y, so the swept boxes overlap at 1.2 m; each rod reaches 0.5 m
  // from its centre, so at 1.2 m they stay 0.2 m apart over the step, at 1.1 m they may meet (0.1 m apart).
  auto run = [](double apart, int steps, int* firstSubsteps) {
    World w;
    w.settings().gravity = {0, 0, 0};
    const glm::dvec3 along = glm::normalize(glm::dvec3(1, 1, 0));
    const glm::dquat tilt = glm::angleAxis(0.25 * 3.14159265358979323846, glm::dvec3(0, 0, 1));
    int ids[2];
    for (int k = 0; k < 2; ++k) {
      BodyDef d;
      d.shape = makeBox({1, 0.04, 0.04});
      d.origin = glm::dvec3(0, 5, 0) + (k * apart) * along;
      d.orientation = tilt;
      d.restitution = 0;
      ids[k] = w.addBody(d);
    }
    w.setVelocity(ids[1], -9.0 * along);
    for (int s = 0; s < steps; ++s) {
      w.step(1.0 / 60);
      if (s == 0) *firstSubsteps = w.lastStats().substeps;
    }
    return glm::dot(w.body(ids[1]).x - w.body(ids[0]).x, along);  // B's centre ahead of A's along the line
  };
  int far = 0, near = 0;
  run(1.2, 1, &far);
  CHECK(far == 1);
  const double gap = run(1.1, 3, &near);
  CHECK(near == 15);  // 0.15 m / 1 cm
  CHECK(gap > 0.99);  // the rods met end to end and did not pass through each other
}

namespace {
// A static plate 4 x 0.1 x 4 m whose top face is the plane y = 0 (half thickness 0.05: a substep may move a body
// 2.5 cm against it).
void addPlate(World& w) {
  BodyDef plate;
  plate.shape = makeBox({4, 0.1, 4});
  plate.origin = {0, -0.05, 0};
  plate.isStatic = true;
  w.addBody(plate);
}
}  // namespace

TEST_CASE("substeps: a turn that moves no point of the shape asks for none") {
  // A body 5 mm over a static plate 0.1 m thick (half thickness 0.05: a substep may move a body 2.5 cm), turning
  // fast and not moving. A ball spinning and a capsule rolling on its side (spinning about its own axis) move no
  // point of their shapes: one substep. The capsule tumbling end over end (its axis' ends move, its round part
  // with them), a box spinning fast, and a ball whose normals a map bends (the map turns with it) move theirs:
  // more. A box moves its corners at their distance from the turn's axis, not at its half diagonal.
  enum class Body { Ball, CapsuleRolling, CapsuleTumbling, Box, BoxFast, BumpedBall };
  auto substeps = [](Body kind) {
    World w;
    w.settings().gravity = {0, 0, 0};
    addPlate(w);
    BodyDef d;
    d.density = 1000;
    glm::dvec3 spin(0);
    switch (kind) {
      case Body::Ball:
      case Body::BumpedBall:
        d.shape = makeSphere(0.1);  // 80 rad/s turns a point of its surface 3.3 cm a step
        spin = {0, 0, 80};
        break;
      case Body::CapsuleRolling:
      case Body::CapsuleTumbling:
        // Lying along x, its axis' ends 0.2 from its centre: tumbling at 45 rad/s moves them 3.75 cm a step.
        d.shape = makeCapsule(0.1, 0.4);
        d.orientation = glm::angleAxis(glm::half_pi<double>(), glm::dvec3(0, 0, 1));
        spin = kind == Body::CapsuleRolling ? glm::dvec3(45, 0, 0) : glm::dvec3(0, 45, 0);
        break;
      case Body::Box:
      case Body::BoxFast:
        // Corners 0.141 from the vertical axis (the half diagonal is 0.173): 40 rad/s moves them 2.36 cm a step
        // (at the half diagonal, 2.89), 60 rad/s 3.54 cm.
        d.shape = makeBox({0.2, 0.2, 0.2});
        spin = {0, kind == Body::Box ? 40 : 60, 0};
        break;
    }
    d.origin = {0, 0.105, 0};
    d.angularVelocity = spin;
    const int i = w.addBody(d);
    if (kind == Body::BumpedBall) {
      w.setNormalModifier([](int, const glm::dvec3&, const glm::dvec3& n) { return n; });
      w.setBumpNormals(i, true);
    }
    w.step(1.0 / 240);
    CHECK(std::isfinite(w.body(i).x.y));
    CHECK(w.body(i).x.y > 0.09);  // on the plate, not through it
    return w.lastStats().substeps;
  };
  CHECK(substeps(Body::Ball) == 1);
  CHECK(substeps(Body::CapsuleRolling) == 1);
  CHECK(substeps(Body::CapsuleTumbling) == 2);  // 0.0375 m / 0.025 m
  CHECK(substeps(Body::Box) == 1);              // 0.0236 m / 0.025 m
  CHECK(substeps(Body::BoxFast) == 2);          // 0.0354 m / 0.025 m
  CHECK(substeps(Body::BumpedBall) == 2);       // 0.033 m / 0.025 m
}

TEST_CASE("a shape's bounding radius is its farthest point's distance from its origin") {
  // Every point the shape's distance says is inside (random points in its bounds box) and every sample (with its
  // radius) lies within the bounding radius, and the farthest sample reaches it: the least sphere about the
  // origin (a sphere's radius, not its bounds box's corner; a mesh's farthest vertex).
  Uniform u(5);
  const std::vector<std::shared_ptr<Shape>> shapes = {makeBox({0.3, 0.5, 0.7}), makeSphere(0.2), makeCapsule(0.1, 0.6),
                                                      makeCylinder(0.2, 0.5),
                                                      makeMeshShape(torusMesh(0.3f, 0.1f, 16, 8), 32)};
  for (const std::shared_ptr<Shape>& shape : shapes) {
    CAPTURE(shapeTypeName(shape->type));
    double farthest = 0;
    for (const glm::dvec3& p : shape->samples) farthest = std::max(farthest, glm::length(p) + shape->sampleRadius);
    CHECK(farthest == Approx(shape->boundingRadius).epsilon(1e-12));
    double inside = 0;
    int found = 0;
    for (int k = 0; k < 20000; ++k) {
      const glm::dvec3 t(u(), u(), u());
      const glm::dvec3 p = shape->boundsMin + t * (shape->boundsMax - shape->boundsMin);
      if (shape->distance(p) > 0) continue;
      ++found;
      inside = std::max(inside, glm::length(p));
    }
    CHECK(found > 1000);
    CHECK(inside <= shape->boundingRadius * (1 + 1e-9));
    CHECK(inside > 0.8 * shape->boundingRadius);  // (points inside do come near it)
  }
}

TEST_CASE("substeps: a turning box or capsule asks for what its fastest sample moves, over random turns") {
  // Boxes and capsules of random sizes, orientations and spins, 2 mm over a static plate 0.1 m thick, not moving
  // and without gravity: the step splits into as many substeps as the fastest of the body's samples (a box's
  // corners are among them; a capsule's lie on its axis) needs to move no more than half the thinner half
  // thickness in one. The bound is the samples' own speed: no fewer substeps (a sample would move too far), and
  // no more (a box's half diagonal turning at right angles to the turn, a capsule's whole length, ask for more).
  Uniform u(7);
  const double h = 1.0 / 240;
  int split = 0, tried = 0;
  for (int k = 0; k < 60; ++k) {
    World w;
    w.settings().gravity = {0, 0, 0};
    addPlate(w);
    BodyDef d;
    d.density = 1000;
    const bool box = k % 2 == 0;
    d.shape = box ? makeBox({0.1 + 0.3 * u(), 0.1 + 0.3 * u(), 0.1 + 0.3 * u()})
                  : makeCapsule(0.05 + 0.1 * u(), 0.1 + 0.4 * u());
    d.orientation = glm::angleAxis(
        6.283 * u(), glm::normalize(glm::dvec3(u() - 0.5, u() - 0.5, u() - 0.5) + glm::dvec3(1e-3, 0, 0)));
    d.angularVelocity =
        (20 + 60 * u()) * glm::normalize(glm::dvec3(u() - 0.5, u() - 0.5, u() - 0.5) + glm::dvec3(0, 1e-3, 0));
    const glm::dmat3 R = glm::mat3_cast(d.orientation);
    double lowest = 0, fastest = 0;
    for (const glm::dvec3& p : d.shape->samples) {
      lowest = std::min(lowest, (R * p).y - d.shape->sampleRadius);
      fastest = std::max(fastest, glm::length(glm::cross(d.angularVelocity, R * p)));
    }
    d.origin = {0, 0.002 - lowest, 0};
    const int i = w.addBody(d);
    const double allowed = 0.5 * std::min(0.05, d.shape->halfThickness());
    const double ratio = fastest * h / allowed;
    if (std::abs(ratio - std::round(ratio)) < 1e-6) continue;  // (a tie: rounding decides)
    ++tried;
    w.step(h);
    CAPTURE(k);
    CAPTURE(ratio);
    CHECK(w.lastStats().substeps == std::max(1, static_cast<int>(std::ceil(ratio))));
    CHECK(w.body(i).x.y > d.origin.y - 0.003);  // (nothing pushed it into the plate)
    split += w.lastStats().substeps > 1;
  }
  MESSAGE(split << " of " << tried << " turning bodies split their step");
  CHECK(tried > 50);
  CHECK(split > 10);
  CHECK(split < tried);
}

TEST_CASE("substeps: a world that keeps its fat boxes asks for as many substeps as a fresh one at the same state") {
  // The substep count comes from the fat boxes' pairs where few bodies left their fat boxes, from a grid of its
  // own otherwise (a world just made has no fat boxes). Small fast spheres in a cloud, made again as they are in
  // a new world before each step: both must split the step alike, and the run must have needed substeps.
  World w;
  w.settings().gravity = {0, 0, 0};
  w.settings().sleeping = false;
  addSphereCloud(w, 13, 200, 0.05, 0.05, 2, 12.0);
  const double h = 1.0 / 240;
  int split = 0;
  for (int step = 0; step < 120; ++step) {
    World fresh;
    fresh.settings() = w.settings();
    for (size_t i = 0; i < w.size(); ++i) {
      const RigidBody& b = w.body(static_cast<int>(i));
      BodyDef d;
      d.shape = b.shape;
      d.origin = b.origin();
      d.orientation = b.q;
      d.linearVelocity = b.v;
      d.angularVelocity = b.w;
      d.friction = 0;
      d.restitution = 1;
      fresh.addBody(d);
    }
    w.step(h);
    fresh.step(h);
    CAPTURE(step);
    REQUIRE(fresh.lastStats().substeps == w.lastStats().substeps);
    split += w.lastStats().substeps > 1;
  }
  MESSAGE(split << " of 120 steps split into substeps");
  CHECK(split > 10);
}

TEST_CASE("broad phase: the kept pair list (fat boxes) finds exactly the overlapping pairs as bodies move") {
  // Frictionless spheres flying about without gravity (they do not turn, so each predicted pose is x + h v):
  // every step, a pair is every two spheres whose bounds, swept from now to the predicted pose and widened by
  // 5 mm + 2 h |v|, overlap. The broad phase keeps a superset from one step to the next and remakes it only
  // when a sphere leaves its fat box (where a few left, 1 to 18 of the 300 here, only theirs, tested against every
  // fat box; where more did, all, by a grid): a pair it missed would show as a count short of the brute force's.
  World w;
  w.settings().gravity = {0, 0, 0};
  w.settings().sleeping = false;
  const std::vector<double> radius = addSphereCloud(w, 5, 300, 0.1, 0.15, 3, 1.5);
  const double h = 1.0 / 240;
  int checked = 0;
  std::set<size_t> counts;
  for (int step = 0; step < 240; ++step) {
    size_t expected = 0;
    std::vector<Aabb> boxes;
    for (size_t i = 0; i < w.size(); ++i) {
      const RigidBody& b = w.body(static_cast<int>(i));
      const glm::dvec3 next = b.x + h * b.v;
      const double margin = radius[i] + 0.005 + 2 * h * glm::length(b.v);
      boxes.push_back({glm::min(b.x, next) - margin, glm::max(b.x, next) + margin});
    }
    for (size_t i = 0; i < boxes.size(); ++i)
      for (size_t j = i + 1; j < boxes.size(); ++j) {
        const Aabb& a = boxes[i];
        const Aabb& b = boxes[j];
        expected += !(b.lo.x > a.hi.x || a.lo.x > b.hi.x || b.lo.y > a.hi.y || a.lo.y > b.hi.y || b.lo.z > a.hi.z ||
                      a.lo.z > b.hi.z);
      }
    w.step(h);
    REQUIRE(w.lastStats().substeps == 1);
    CHECK(static_cast<size_t>(w.lastStats().pairs) == expected);
    for (size_t i = 0; i < w.size(); ++i) REQUIRE(glm::length(w.body(static_cast<int>(i)).w) < 1e-9);  // (rounding only)
    counts.insert(expected);
    ++checked;
  }
  MESSAGE("pair counts seen: " << counts.size() << " different, from " << *counts.begin() << " to " << *counts.rbegin());
  CHECK(counts.size() > 10);  // the pairs came and went
}

TEST_CASE("broad phase: the hashed grid finds exactly the pairs whose bounds overlap, large bodies among them") {
  // Boxes of many sizes (1 cm to 3 m, and a 60 m slab and a 40 m pole that span many cells), some static, at
  // rest without gravity: a pair is every two bodies, one of them dynamic, whose bounds (a movable body's
  // widened by 5 mm) overlap. Counted by brute force against StepStats::pairs.
  World w;
  w.settings().gravity = {0, 0, 0};
  w.settings().sleeping = false;
  Uniform u(7);
  std::vector<std::pair<glm::dvec3, glm::dvec3>> bounds;  // lo, hi
  std::vector<bool> dynamic;
  auto add = [&](const glm::dvec3& size, const glm::dvec3& at, bool isStatic) {
    BodyDef d;
    d.shape = makeBox(size);
    d.origin = at;
    d.isStatic = isStatic;
    w.addBody(d);
    const double margin = isStatic ? 0.0 : 0.005;
    bounds.push_back({at - size * 0.5 - margin, at + size * 0.5 + margin});
    dynamic.push_back(!isStatic);
  };
  add({60, 0.5, 60}, {0, -0.25, 0}, true);
  add({0.3, 40, 0.3}, {1, 20, 1}, true);
  for (int k = 0; k < 600; ++k) {
    const double s = u() < 0.1 ? 0.5 + 2.5 * u() : 0.01 + 0.4 * u();
    add({s, s * (0.5 + u()), s * (0.5 + u())}, {8 * u() - 4, 4 * u(), 8 * u() - 4}, u() < 0.2);
  }
  size_t expected = 0;
  for (size_t i = 0; i < bounds.size(); ++i)
    for (size_t j = i + 1; j < bounds.size(); ++j) {
      if (!dynamic[i] && !dynamic[j]) continue;
      const auto& a = bounds[i];
      const auto& b = bounds[j];
      if (b.first.x > a.second.x || a.first.x > b.second.x || b.first.y > a.second.y || a.first.y > b.second.y ||
          b.first.z > a.second.z || a.first.z > b.second.z)
        continue;
      ++expected;
    }
  w.step(1.0 / 240);
  MESSAGE("overlapping pairs: " << expected);
  CHECK(expected > 600);
  CHECK(w.lastStats().substeps == 1);
  CHECK(static_cast<size_t>(w.lastStats().pairs) == expected);
}

TEST_CASE("a ball pressed into a box, a capsule or a ball touches at one point: its lowest, as deep as it sinks") {
  // A 0.2 m ball 3 mm into the top of each, over a face, over an edge and a corner of the box: one contact, on the
  // ball's surface where the two meet, the normal out of the other body, 3 mm deep (the ball's centre against the
  // other's field; the other's surface samples inside the ball only repeated it).
  struct Case {
    const char* name;
    std::shared_ptr<Shape> other;
    glm::dvec3 top;     // the point of the other's surface the ball sinks into (world)
    glm::dvec3 normal;  // the other's outward normal there
  };
  const double r = 0.2, depth = 0.003;
  const glm::dvec3 edgeN = glm::normalize(glm::dvec3(1, 1, 0)), cornerN = glm::normalize(glm::dvec3(1, 1, 1));
  const std::vector<Case> cases = {
      {"box face", makeBox({1, 0.4, 1}), {0.1, 0.2, -0.2}, {0, 1, 0}},
      {"box edge", makeBox({1, 0.4, 1}), {0.5, 0.2, 0.1}, edgeN},
      {"box corner", makeBox({1, 0.4, 1}), {0.5, 0.2, 0.5}, cornerN},
      {"capsule", makeCapsule(0.15, 0.6), {0, 0.45, 0}, {0, 1, 0}},
      {"ball", makeSphere(0.3), glm::dvec3(0.3) * glm::normalize(glm::dvec3(1, 2, 0.5)),
       glm::normalize(glm::dvec3(1, 2, 0.5))},
  };
  for (const Case& k : cases) {
    CAPTURE(std::string(k.name));
    World w;
    BodyDef od;
    od.shape = k.other;
    const int a = w.addBody(od);
    BodyDef bd;
    bd.shape = makeSphere(r);
    bd.origin = k.top + (r - depth) * k.normal;
    const int b = w.addBody(bd);
    std::vector<Contact> contacts;
    w.findContacts(a, b, {w.body(a).x, w.body(a).q}, {w.body(b).x, w.body(b).q}, contacts);
    REQUIRE(contacts.size() == 1);
    const Contact& c = contacts[0];
    CHECK(c.a == a);
    CHECK(glm::length(c.normal - k.normal) < 1e-9);
    CHECK(c.phi == doctest::Approx(-depth).epsilon(1e-6));
    CHECK(glm::length(c.point - (k.top - depth * k.normal)) < 1e-9);
    // The same pair the other way round: still one contact as deep, along the same line (two balls: the field
    // of either may be the one the other's centre is tested in).
    w.findContacts(b, a, {w.body(b).x, w.body(b).q}, {w.body(a).x, w.body(a).q}, contacts);
    REQUIRE(contacts.size() == 1);
    CHECK(contacts[0].phi == doctest::Approx(-depth).epsilon(1e-6));
    CHECK(glm::length(contacts[0].normal - (contacts[0].a == a ? 1.0 : -1.0) * k.normal) < 1e-9);
    if (k.other->type != ShapeType::Sphere) CHECK(contacts[0].a == a);
  }
}

TEST_CASE(
    "a capsule across a box's edge sinks between its core samples: the contact is where its axis passes nearest") {
  // A capsule (radius 0.1 m, straight part 1 m: core samples 0.1 m apart) tilted 20 degrees over the top edge of a
  // box, its axis 0.097 m from the edge at a point 0.03 m from the nearest core sample: 3 mm deep there, while that
  // sample stands 0.1015 m from the edge (no sample touches). The contact: 3 mm deep, normal from the edge to the
  // axis, on the capsule's surface. Also a capsule 10 m long (101 core samples: the search runs over its whole axis).
  for (double length : {1.0, 10.0}) {
    CAPTURE(length);
    World w;
    BodyDef bd;
    bd.shape = makeBox({1, 0.4, 1});
    const int a = w.addBody(bd);
    const double r = 0.1, depth = 0.003, tilt = glm::radians(20.0);
    const glm::dvec3 edge(0.5, 0.2, 0.1), u(std::cos(tilt), -std::sin(tilt), 0), n(std::sin(tilt), std::cos(tilt), 0);
    const glm::dvec3 foot = edge + (r - depth) * n;
    BodyDef cd;
    cd.shape = makeCapsule(r, length);
    cd.orientation = glm::angleAxis(-(glm::half_pi<double>() + tilt), glm::dvec3(0, 0, 1));  // its y axis along u
    cd.origin = foot + 0.03 * u;  // the foot at y = -0.03 of the capsule's own axis
    const int b = w.addBody(cd);
    REQUIRE(glm::length(w.body(b).q * glm::dvec3(0, 1, 0) - u) < 1e-12);
    std::vector<Contact> contacts;
    w.findContacts(a, b, {w.body(a).x, w.body(a).q}, {w.body(b).x, w.body(b).q}, contacts);
    REQUIRE(!contacts.empty());
    const Contact& c = contacts[0];  // deepest first
    MESSAGE("capsule over an edge: " << contacts.size() << " contacts, deepest " << -c.phi * 1000 << " mm");
    CHECK(c.a == a);
    CHECK(c.phi == doctest::Approx(-depth).epsilon(0.01));
    CHECK(glm::length(c.normal - n) < 1e-3);
    CHECK(glm::length(c.point - (foot - r * n)) < 1e-3);
    CHECK(contacts.size() <= 2);
  }
}

TEST_CASE(
    "a capsule laid across two thin ridges rests on its surface, not between its core samples, whatever pairs come "
    "and go beside it") {
  // A capsule (radius 0.1 m, straight part 1 m: core samples 0.1 m apart) dropped level onto two ridges 2 cm wide
  // that stand midway between core samples. Only its segment's deepest point (narrow_phase.cpp) holds it at its
  // radius over the ridges' tops; its core samples' spheres alone would let it sink 8.3 mm. The same capsule beside
  // 40 balls bouncing on their own plates far away (pairs made and dropped every few substeps, the pair list
  // remade around its pairs) must move bit for bit as alone: what its pairs carry from one substep to the next
  // (candidate lists, whether the segment can reach) goes with them.
  auto run = [](bool crowd) {
    World w;
    w.settings().sleeping = false;
    // The crowd: balls bouncing on plates, half of them before the capsule and its ridges in the bodies' order,
    // half after, so that the capsule's pairs move along the pair list as the balls' pairs come and go.
    auto addCrowd = [&](int from, int to) {
      for (int k = from; crowd && k < to; ++k) {
        BodyDef ball, plate;
        plate.shape = makeBox({0.6, 0.1, 0.6});
        plate.isStatic = true;
        plate.origin = {20 + 1.5 * (k % 8), -0.05, 1.5 * (k / 8)};
        ball.shape = makeSphere(0.05 + 0.005 * (k % 5));
        ball.origin = plate.origin + glm::dvec3(0, 0.15 + 0.04 * (k % 7), 0);
        ball.restitution = 0.9;
        w.addBody(ball);
        w.addBody(plate);
      }
    };
    addCrowd(0, 20);
    const double top = 0.2, r = 0.1;
    for (double x : {-0.25, 0.25}) {
      BodyDef ridge;
      ridge.shape = makeBox({0.02, 0.4, 1.0});
      ridge.isStatic = true;
      ridge.origin = {x, top - 0.2, 0};
      w.addBody(ridge);
    }
    BodyDef cd;
    cd.shape = makeCapsule(r, 1.0);
    cd.orientation = glm::angleAxis(glm::half_pi<double>(), glm::dvec3(0, 0, 1));  // its axis along x
    cd.origin = {0, top + r + 0.01, 0};
    const int capsule = w.addBody(cd);
    addCrowd(20, 40);
    for (int s = 0; s < 480; ++s) w.step(1.0 / 240);
    return w.body(capsule);
  };
  const RigidBody alone = run(false), beside = run(true);
  MESSAGE("capsule centre " << alone.x.y << " m, its radius over the ridges' tops at " << 0.3 << " m");
  CHECK(alone.x.y == Approx(0.3).epsilon(0.002 / 0.3));
  CHECK(std::abs(alone.x.x) < 1e-3);
  CHECK(beside.x == alone.x);
  CHECK(beside.q == alone.q);
  CHECK(beside.v == alone.v);
  CHECK(beside.w == alone.w);
}

namespace {
// 2 s to settle, then the looks and kept looks of the next second (240 steps).
void settleThenCountLooks(PhysicsTestContext& c, int& kept, int& looks) {
  c.simulate(2.0);
  for (int s = 0; s < 240; ++s) {
    c.simulateSteps(1);
    kept += c.world().lastStats().keptLooks;
    looks += c.world().lastStats().looks;
  }
}
}  // namespace

TEST_CASE(
    "kept manifolds: resting boxes are answered by their carried contacts, a sliding box looks afresh, and "
    "both behave as when every look is new") {
  // contactRefreshTolerance 0 finds every pair's contacts again at every look; the default carries a manifold
  // of two boxes along with them while they move less than 0.5 mm from where it was found.
  struct Run {
    std::vector<glm::dvec3> tower;                            // the tower's centres at 3 s
    double slid = 0;                                          // how far the sliding box went
    int kept = 0, looks = 0;                                  // over the tower's last second
    int keptSliding = 0, looksSliding = 0, stepsSliding = 0;  // while the box slid faster than 1 m/s
  };
  auto run = [](double tolerance) {
    PhysicsTestContext c;
    c.settings().contactRefreshTolerance = tolerance;
    c.settings().sleeping = false;
    c.addGround(0.6, 0.0);
    std::vector<int> tower;
    for (int k = 0; k < 4; ++k) tower.push_back(c.addBox({0.5, 0.5, 0.5}, {0, 0.25 + 0.5 * k, 0}, 0.6, 0.0));
    Run r;
    settleThenCountLooks(c, r.kept, r.looks);
    for (int i : tower) r.tower.push_back(c.body(i).x);
    // A box sent sliding at 2 m/s on friction 0.3 (the ground's 0.6 with its own 0.15: sqrt of the product).
    PhysicsTestContext d;
    d.settings().contactRefreshTolerance = tolerance;
    d.settings().sleeping = false;
    d.addGround(0.6, 0.0);
    const int box = d.addBox({0.4, 0.2, 0.4}, {0, 0.1, 0}, 0.15, 0.0);
    d.world().setVelocity(box, {2, 0, 0});
    while (d.body(box).v.x > 1) {
      d.simulateSteps(1);
      r.keptSliding += d.world().lastStats().keptLooks;
      r.looksSliding += d.world().lastStats().looks;
      ++r.stepsSliding;
    }
    d.simulate(1.0);
    r.slid = d.body(box).x.x;
    return r;
  };
  const Run fresh = run(0), kept = run(0.0005);
  MESSAGE("kept looks over the tower's last second: " << kept.kept << " of " << kept.looks << " (every look new: "
                                                      << fresh.kept << " of " << fresh.looks << ")");
  MESSAGE("sliding faster than 1 m/s: " << kept.keptSliding << " kept of " << kept.looksSliding << " looks in "
                                        << kept.stepsSliding << " steps");
  CHECK(fresh.kept == 0);
  CHECK(kept.kept >= 0.8 * kept.looks);
  // 4 to 8 mm a step: every step looks afresh (a later look within the step, after an impulse, may be kept).
  CHECK(kept.looksSliding - kept.keptSliding >= kept.stepsSliding);
  CHECK(kept.stepsSliding > 50);
  double apart = 0, drift = 0;
  for (size_t k = 0; k < kept.tower.size(); ++k) {
    apart = std::max(apart, glm::length(kept.tower[k] - fresh.tower[k]));
    drift = std::max(drift, glm::length(glm::dvec2(kept.tower[k].x, kept.tower[k].z)));
  }
  MESSAGE("tower: carried vs new contacts " << apart * 1000 << " mm apart, sideways drift " << drift * 1000 << " mm");
  CHECK(apart < 0.0005);  // the penetration slop
  CHECK(drift < 0.001);
  // v^2 / (2 mu g) with mu = sqrt(0.6 * 0.15) = 0.3.
  const double predicted = 4 / (2 * 0.3 * 9.81);
  MESSAGE("sliding box stopped after " << kept.slid << " m (every look new: " << fresh.slid << ", predicted "
                                       << predicted << ")");
  CHECK(kept.slid == doctest::Approx(predicted).epsilon(0.02));
  CHECK(std::abs(kept.slid - fresh.slid) < 0.002);
}

TEST_CASE(
    "kept sample contacts: a capsule on a box and a torus on the ground rest on carried contacts as on fresh ones") {
  // Pairs that touch by samples keep their contacts as a manifold does (no ball in the pair, no sweep, no bent
  // normals, no dents): a capsule lying across a static box and a torus lying on the ground, each on its own and
  // settled, are answered mostly by carried contacts and rest where every look new puts them.
  struct Run {
    glm::dvec3 at{0};
    glm::dquat q{1, 0, 0, 0};
    int kept = 0, looks = 0;  // over the last second
  };
  auto run = [](double tolerance, bool torus) {
    PhysicsTestContext c;
    c.settings().contactRefreshTolerance = tolerance;
    c.settings().sleeping = false;
    BodyDef d;
    d.density = 1000;
    d.friction = 0.6;
    if (torus) {
      c.addGround(0.6, 0.0);
      d.shape = makeMeshShape(torusMesh(0.3f, 0.1f, 16, 8), 32);
      d.origin = {0, 0.12, 0};
    } else {
      BodyDef block;
      block.shape = makeBox({1, 0.4, 1});
      block.origin = {0, 0.2, 0};
      block.isStatic = true;
      block.friction = 0.6;
      c.add(block);
      d.shape = makeCapsule(0.1, 0.6);
      d.origin = {0.05, 0.51, 0};
      d.orientation = glm::angleAxis(glm::half_pi<double>(), glm::dvec3(0, 0, 1));
    }
    const int i = c.add(d);
    Run r;
    settleThenCountLooks(c, r.kept, r.looks);
    r.at = c.body(i).x;
    r.q = c.body(i).q;
    return r;
  };
  for (bool torus : {false, true}) {
    CAPTURE(torus);
    const Run fresh = run(0, torus), kept = run(0.0005, torus);
    MESSAGE(std::string(torus ? "torus" : "capsule")
            << ": kept looks " << kept.kept << " of " << kept.looks << ", " << glm::length(kept.at - fresh.at) * 1000
            << " mm from where fresh looks rest it");
    CHECK(fresh.kept == 0);
    CHECK(kept.looks > 0);
    CHECK(kept.kept >= 0.8 * kept.looks);
    CHECK(glm::length(kept.at - fresh.at) < 0.0005);
    CHECK(std::abs(glm::dot(kept.q, fresh.q)) > std::cos(0.5 * 0.005));  // within 5 mrad
  }
}

TEST_CASE("kept sample contacts: two frictionless balls that collide are looked at afresh and stay without spin") {
  World w;
  w.settings().gravity = {0, 0, 0};
  w.settings().sleeping = false;
  const int a = addSphere(w, 0.1, {0, 0, 0}, 0.0, 0.5);
  const int b = addSphere(w, 0.1, {0.25, 0.05, 0}, 0.0, 0.5);
  w.setVelocity(a, {1, 0, 0});
  int looks = 0, kept = 0;
  for (int s = 0; s < 120; ++s) {
    w.step(1.0 / 240);
    looks += w.lastStats().looks;
    kept += w.lastStats().keptLooks;
  }
  CHECK(looks > 0);
  CHECK(kept == 0);
  CHECK(glm::length(w.body(a).w) < 1e-9);
  CHECK(glm::length(w.body(b).w) < 1e-9);
  CHECK(glm::length(w.body(b).v) > 0.1);  // (they did collide)
}

TEST_CASE("a light body crushed between a heavy one and the ground passes the blow on: the ground's event carries it") {
  // The collision step's passes move an impulse through a light body a little each (a 1 kg crate under a 510 kg
  // ball: 1% a pass); the contact step and shock propagation stop the ball. What they push the pairs apart with is
  // the hit's, and what the crate takes while frozen under the ball reaches the ground.
  struct Case {
    double ballMass, speed, crateMass;
  };
  for (const Case& k : {Case{510, 6, 1}, Case{1e9, 3, 0.001}}) {
    CAPTURE(k.ballMass);
    World w;
    addGround(w, 0.8, 0.2);
    BodyDef crate;
    crate.shape = makeBox({0.125, 0.125, 0.125});
    crate.origin = {0, 0.0625, 0};
    crate.mass = k.crateMass;
    crate.restitution = 0.3;
    const int c = w.addBody(crate);
    BodyDef ball;
    ball.shape = makeSphere(0.25);
    ball.origin = {0, 0.125 + 0.25 + 0.005, 0};
    ball.linearVelocity = {0, -k.speed, 0};
    ball.mass = k.ballMass;
    ball.restitution = 0.95;
    const int b = w.addBody(ball);
    double ground = 0, crateBall = 0, elasticGround = 0;
    for (int s = 0; s < 24; ++s) {
      w.step(1.0 / 240);
      for (const CollisionEvent& e : w.events()) {
        if ((e.a == c) != (e.b == c)) {
          if (e.a == b || e.b == b)
            crateBall += e.impulse;
          else {
            ground += e.impulse;
            elasticGround = std::max(elasticGround, e.elasticImpulse);
          }
        }
      }
    }
    const double momentum = k.ballMass * k.speed;
    MESSAGE("ball " << k.ballMass << " kg at " << k.speed << " m/s: ground took " << ground << " N s, the crate "
                    << crateBall << " N s from the ball (its momentum " << momentum << ")");
    // The ball was stopped (not bounced: the crate is squeezed flat between), by the ground through the crate.
    CHECK(w.body(b).v.y > -0.1 * k.speed);
    CHECK(crateBall > 0.9 * momentum);
    CHECK(ground > 0.9 * momentum);
    CHECK(ground < 2.5 * momentum);
    CHECK(elasticGround > 1.8 * momentum);
  }
}

TEST_CASE(
    "a ball and the crate under it land together: the ground's events carry both; a parked platform is as static") {
  // A 510 kg ball resting on a 1 kg crate, dropped together from 0.3 m onto static ground or onto a kinematic
  // platform standing still. The crate's landing stops the ball too: the floor's events carry the pair's momentum
  // (not the crate's alone), the same on both floors (a parked kinematic body drives nothing: no unbounded blow).
  // Then the ball rests on the crate for two seconds: its weight is no blow, and the events carry almost none of it.
  const double drop = 0.3, speed = std::sqrt(2 * 9.81 * drop), momentum = 511 * speed;
  double landing[2] = {0, 0}, resting[2] = {0, 0};
  for (int kinematic = 0; kinematic < 2; ++kinematic) {
    World w;
    BodyDef floor;
    floor.shape = makeBox({10, 1, 10});
    floor.origin = {0, -0.5, 0};
    floor.isStatic = kinematic == 0;
    floor.kinematic = kinematic == 1;
    floor.friction = 0.8;
    floor.restitution = 0.2;
    const int f = w.addBody(floor);
    BodyDef crate;
    crate.shape = makeBox({0.25, 0.25, 0.25});
    crate.origin = {0, 0.125 + drop, 0};
    crate.mass = 1;
    crate.restitution = 0.3;
    w.addBody(crate);
    BodyDef ball;
    ball.shape = makeSphere(0.25);
    ball.origin = {0, 0.5 + drop, 0};
    ball.mass = 510;
    ball.restitution = 0.95;
    const int b = w.addBody(ball);
    for (int s = 0; s < 720; ++s) {
      w.step(1.0 / 240);
      for (const CollisionEvent& e : w.events())
        if (e.a == f || e.b == f) (s < 240 ? landing : resting)[kinematic] += e.impulse;
    }
    CHECK(std::abs(w.body(b).x.y - 0.5) < 0.01);
  }
  const double weight = 510 * 9.81 * 2;
  MESSAGE("the floor's events: landing " << landing[0] << " N s on the ground, " << landing[1]
                                         << " on the parked platform (the pair's momentum " << momentum
                                         << "); resting 2 s " << resting[0] << " and " << resting[1]
                                         << " N s (the ball's weight over them " << weight << ")");
  for (int k = 0; k < 2; ++k) {
    CHECK(landing[k] > 0.9 * momentum);
    CHECK(landing[k] < 2.5 * momentum);
    CHECK(resting[k] < 0.05 * weight);
  }
  CHECK(landing[1] == doctest::Approx(landing[0]).epsilon(0.05));
}

TEST_CASE("a light box pinned between a heavy one and a wall: each event's elastic impulse holds all of its hits") {
  // The collision passes strike the light box back and forth between the heavy box and the wall in one substep; the
  // events' |j_eps=1| (what dents are decided from) sums those hits, so it is never less than what they applied
  // (frictionless here: with friction the impulse applied may lean off the normal).
  World w;
  w.settings().gravity = glm::dvec3(0);
  BodyDef wall;
  wall.shape = makeBox({0.5, 2, 2});
  wall.origin = {1.25, 0, 0};
  wall.isStatic = true;
  wall.friction = 0;
  wall.restitution = 0.2;
  w.addBody(wall);
  BodyDef light;
  light.shape = makeBox({0.2, 0.2, 0.2});
  light.origin = {0.9, -0.9, 0};  // struck off its centre: it turns, and is struck again
  light.mass = 1;
  light.friction = 0;
  light.restitution = 0.3;
  w.addBody(light);
  BodyDef heavy;
  heavy.shape = makeBox({0.5, 0.5, 0.5});
  heavy.origin = {0.5, -0.75, 0};
  heavy.mass = 500;
  heavy.friction = 0;
  heavy.restitution = 0.5;
  heavy.linearVelocity = {2, 0, 0};
  w.addBody(heavy);
  int events = 0, short_ = 0;
  double worst = 1e300;
  for (int step = 0; step < 240; ++step) {
    w.step(1.0 / 240);
    for (const CollisionEvent& e : w.events()) {
      ++events;
      worst = std::min(worst, e.elasticImpulse / e.impulse);
      short_ += e.elasticImpulse < e.impulse * (1 - 1e-9);
    }
  }
  MESSAGE(events << " events; the least elastic impulse over impulse applied: " << worst);
  CHECK(events > 0);
  CHECK(short_ == 0);
}

TEST_CASE("a kinematic body driving a dynamic one at a static one does not push it through: the static one holds it") {
  // A kinematic box at 1 m/s squeezes a 1 kg box against a static wall 0.5 m thick (no gravity); a kinematic plate
  // comes down at 1 m/s on a box resting on the ground. Nothing can give: the pinned box stays out of the static
  // body (it went through the wall in 0.4 s), and the kinematic body passes into it instead.
  for (int crusher = 0; crusher < 2; ++crusher) {
    CAPTURE(crusher);
    World w;
    const glm::dvec3 along = crusher == 0 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, -1, 0);
    if (crusher == 0) w.settings().gravity = glm::dvec3(0);
    BodyDef wall;  // its face towards the pinned box at the origin of `along`
    wall.shape = makeBox(crusher == 0 ? glm::dvec3(0.5, 2, 2) : glm::dvec3(4, 0.5, 4));
    wall.origin = along * 0.25;
    wall.isStatic = true;
    wall.restitution = 0.2;
    w.addBody(wall);
    BodyDef pinned;
    pinned.shape = makeBox({0.2, 0.2, 0.2});
    pinned.origin = -along * 0.1;
    pinned.mass = 1;
    pinned.restitution = 0.3;
    const int p = w.addBody(pinned);
    BodyDef driver;
    driver.shape = makeBox({0.5, 0.5, 0.5});
    driver.origin = -along * 0.5;
    driver.kinematic = true;
    driver.linearVelocity = along;
    w.addBody(driver);
    double deepest = 0;
    for (int step = 0; step < 240; ++step) {
      w.step(1.0 / 240);
      // How far the pinned box's leading face went past the static body's face.
      deepest = std::max(deepest, glm::dot(w.body(p).x, along) + 0.1);
    }
    MESSAGE(std::string(crusher == 0 ? "box against a wall" : "box under a crusher")
            << ": deepest into the static body " << deepest * 1000 << " mm");
    CHECK(deepest < 0.01);
  }
}

TEST_CASE(
    "a look that found nothing answers the pair's next looks while the bodies move less than its clearance: "
    "the same bits as looking again") {
  // Boxes (a separating axis between two), balls, capsules (their core segments) and tori (meshes: near samples)
  // tumbling onto a ground and into each other, with and without the clearances: the same bits, and the
  // clearances answer looks of every kind of pair.
  const auto torus = makeMeshShape(torusMesh(0.2f, 0.07f, 16, 8), 24);
  std::vector<double> end[2];
  int clear = 0, looks = 0;
  for (int run = 0; run < 2; ++run) {
    World w;
    w.settings().keepClearLooks = run == 0;
    addGround(w, 0.5, 0.2);
    Uniform u(29);
    for (int k = 0; k < 64; ++k) {
      BodyDef d;
      switch (k % 4) {
        case 0:
          d.shape = makeBox({0.1 + 0.2 * u(), 0.1 + 0.2 * u(), 0.1 + 0.2 * u()});
          break;
        case 1:
          d.shape = makeSphere(0.05 + 0.1 * u());
          break;
        case 2:
          d.shape = makeCapsule(0.05 + 0.05 * u(), 0.1 + 0.1 * u());
          break;
        default:
          d.shape = torus;
      }
      d.origin = {1.2 * u() - 0.6, 0.3 + 3 * u(), 1.2 * u() - 0.6};
      d.orientation = glm::angleAxis(6.0 * u(), glm::normalize(glm::dvec3(u() - 0.5, u() - 0.5, u() - 0.5) + 1e-3));
      d.linearVelocity = glm::dvec3(u() - 0.5, u() - 0.5, u() - 0.5);
      d.angularVelocity = glm::dvec3(u() - 0.5, u() - 0.5, u() - 0.5) * 4.0;
      d.friction = 0.4;
      d.restitution = 0.3;
      w.addBody(d);
    }
    for (int s = 0; s < 180; ++s) {
      w.step(1.0 / 60);
      if (run == 0) {
        clear += w.lastStats().clearLooks;
        looks += w.lastStats().looks;
      } else {
        CHECK(w.lastStats().clearLooks == 0);
      }
    }
    for (const RigidBody& b : w.bodies()) {
      for (const glm::dvec3& v : {b.x, b.v, b.w}) end[run].insert(end[run].end(), {v.x, v.y, v.z});
      end[run].insert(end[run].end(), {b.q.w, b.q.x, b.q.y, b.q.z});
    }
  }
  MESSAGE("looks answered by a clearance: " << clear << " of " << looks);
  CHECK(clear > looks / 20);
  REQUIRE(end[0].size() == end[1].size());
  CHECK(std::memcmp(end[0].data(), end[1].data(), end[0].size() * sizeof(double)) == 0);
}
