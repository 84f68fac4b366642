// Random physics scenarios and the invariants every step must keep: the
// physics fuzzer (tests/fuzz/fuzz_physics.cpp, libFuzzer) and the physics suite
// (which replays tests/fuzz/corpus/physics/ and a range of seeds) share it.
//
// A scenario is built from bytes: each choice takes the next byte, and once the
// bytes run out, numbers from a generator seeded by their hash; every choice is
// its own statement (or in a braced list), so every compiler builds the same scene. Every scene it
// builds is valid input: boxes, spheres, capsules and cylinders of 2 cm to 2 m
// (thin plates among them) of 10 g to 10 t, thrown at up to 20 m/s and spun at
// up to 100 rad/s, some started inside each other; kinematic bodies spinning
// at up to 50 rad/s or following a circular path; joints of every type between
// bodies or to the world, some with limits or motors, some started violated;
// a raycast vehicle of 1 kg to 3 t on springs of any stiffness and damping the
// scene format accepts, driven by a throttle.
//
// After every step (240 Hz, 120 steps):
// - every body's state is finite and the step succeeded (valid input never fails); every event names two bodies
//   and has finite impulses, none negative;
// - no dynamic body moves faster than the scene can push it: four times the
//   fastest speed present at the start (a point's |v| + |w| r, kinematic bodies'
//   surfaces included) plus the correction speed, plus what gravity, the vehicle's
//   engine and the motors can add since; a body joined to a kinematic body, or
//   jointed in a scene with kinematic bodies, at most twice its joints' reach
//   per step (a mechanism driven through a singular pose: a rod on a tether
//   dragged into the ground, a roped body run through by a kinematic one);
// - a scene with no source of energy (no kinematic body, vehicle or motor,
//   nothing started overlapping or violated) gains no energy beyond the
//   positional projection's slop;
// - a body that touches nothing over a step (its bounds clear of every other
//   body's by what both can travel, no joint) keeps its angular momentum and
//   changes its velocity by g h only.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include <crumple/physics/vehicle.h>
#include <crumple/physics/world.h>

namespace crumple::test {

constexpr double kScenarioRate = 240;  // steps per second

// Choices from bytes, then from a generator seeded by their hash.
class ScenarioInput {
 public:
  ScenarioInput(const uint8_t* data, size_t size) : data_(data), size_(size) {
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < size; ++i) h = (h ^ data[i]) * 1099511628211ull;
    state_ = h;
  }
  // A number in [0, 1).
  double unit() {
    if (at_ < size_) return data_[at_++] / 256.0 + next() / 256.0;  // a byte, refined by the generator
    return next();
  }
  double range(double lo, double hi) { return lo + (hi - lo) * unit(); }
  double logRange(double lo, double hi) { return lo * std::pow(hi / lo, unit()); }
  int pick(int n) { return std::min(n - 1, static_cast<int>(unit() * n)); }
  bool chance(double p) { return unit() < p; }
  glm::dvec3 vec(double scale) { return {range(-scale, scale), range(-scale, scale), range(-scale, scale)}; }

 private:
  double next() {
    state_ = state_ * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state_ >> 11) / 9007199254740992.0;
  }
  const uint8_t* data_;
  size_t size_, at_ = 0;
  uint64_t state_;
};

struct Scenario {
  World world;
  std::vector<int> kinematic;            // bodies moved by script
  std::vector<glm::dvec3> pathCentre;    // per kinematic body: a circular path's centre (radius 0: none)
  std::vector<double> pathRadius, pathRate;
  std::vector<Vehicle> vehicles;
  std::vector<double> throttle;
  std::vector<char> jointed;             // per body: a joint holds it
  std::vector<char> sling;               // per body: on a slider without limits joined to a kinematic body
  std::vector<double> energySpeed;       // per body: twice the speed at which it would hold all the energy there is
  std::vector<double> mechanismSpeed;    // per body: what a kinematic body can force it to through joints (m/s)
  double springEnergy = 0;               // the vehicles' springs fully compressed (J)
  double closingEnergy = 0;              // what closing the joints started violated may hand out (J)
  bool energySources = false;            // kinematic bodies, vehicles, motors, overlaps or violated joints
  double pushSpeed = 0;                  // the fastest speed present at the start (m/s)
  double jointSpeed = 0;                 // the fastest a joint's anchor moves at the start (m/s)
  double accelerationBound = 0;          // what engines and motors can add per second (m/s^2), gravity included
  std::string description;
};

// The fastest point of a body's bounding box: max |v + w x r| over its corners (the box bounds every surface point's
// lever, and |w x r| is convex in r).
inline double pointSpeed(const RigidBody& b) {
  const Shape& s = *b.shape;
  const glm::dmat3 r = b.rotation();
  double fastest = glm::length(b.v);
  for (int k = 0; k < 8; ++k) {
    const glm::dvec3 corner((k & 1) ? s.boundsMax.x : s.boundsMin.x, (k & 2) ? s.boundsMax.y : s.boundsMin.y,
                            (k & 4) ? s.boundsMax.z : s.boundsMin.z);
    fastest = std::max(fastest, glm::length(b.v + glm::cross(b.w, r * (corner - b.localCom))));
  }
  return fastest;
}

inline Aabb scenarioBounds(const RigidBody& b) {
  const Shape& s = *b.shape;
  const glm::dvec3 c = (s.boundsMin + s.boundsMax) * 0.5, e = (s.boundsMax - s.boundsMin) * 0.5;
  const glm::dmat3 r = b.rotation();
  const glm::dvec3 wc = b.x + r * (c - b.localCom);
  glm::dvec3 we(0);
  for (int col = 0; col < 3; ++col) we += glm::abs(r[col]) * e[col];
  return {wc - we, wc + we};
}

inline void buildScenario(Scenario& sc, ScenarioInput& in) {
  World& w = sc.world;
  std::ostringstream d;
  const bool gravity = in.chance(0.75);
  w.settings().gravity = gravity ? glm::dvec3(0, -9.81, 0) : glm::dvec3(0);
  w.settings().sleeping = in.chance(0.5);
  if (in.chance(0.85)) {
    BodyDef g;
    g.shape = makeBox({40, 1, 40});
    g.origin = {0, -0.5, 0};
    g.isStatic = true;
    g.friction = in.range(0, 1.5);
    g.restitution = in.range(0, 1);
    w.addBody(g);
    sc.pathCentre.emplace_back(0);  // per body, as below
    sc.pathRadius.push_back(0);
    sc.pathRate.push_back(0);
    d << "ground; ";
  }
  const int count = 1 + in.pick(10);
  for (int k = 0; k < count; ++k) {
    BodyDef b;
    const int type = in.pick(4);
    const double size = in.logRange(0.02, 2.0);
    switch (type) {
      case 0: {
        // (Each choice in its own statement: the order of a call's arguments is the compiler's.)
        const double height = in.logRange(0.02, 2.0);
        const double depth = in.logRange(0.02, 2.0);
        glm::dvec3 s(size, height, depth);
        if (in.chance(0.2)) s.y = std::max(0.02, 0.05 * std::min(s.x, s.z));  // a plate
        b.shape = makeBox(s);
        d << "box " << s.x << "x" << s.y << "x" << s.z;
        break;
      }
      case 1:
        b.shape = makeSphere(0.5 * size);
        d << "sphere r" << 0.5 * size;
        break;
      case 2:
        b.shape = makeCapsule(0.5 * std::min(size, 0.5), in.logRange(0.02, 2.0));
        d << "capsule";
        break;
      default:
        b.shape = makeCylinder(0.5 * std::min(size, 1.0), in.logRange(0.02, 2.0));
        d << "cylinder";
        break;
    }
    b.origin = {in.range(-3, 3), in.range(0.05, 5), in.range(-3, 3)};
    const glm::dvec3 turn = in.vec(1);
    const double turnW = in.range(-1, 1);
    b.orientation = glm::normalize(glm::dquat(turnW, turn.x, turn.y, turn.z) + glm::dquat(0.01, 0, 0, 0));
    if (in.chance(0.5)) b.mass = in.logRange(0.01, 10000);
    else b.density = in.logRange(10, 20000);
    b.restitution = in.range(0, 1);
    b.friction = in.range(0, 2);
    b.kinematic = in.chance(0.12);
    if (in.chance(0.6)) b.linearVelocity = in.vec(in.chance(0.3) ? 20 : 3);
    if (in.chance(0.6)) b.angularVelocity = in.vec(in.chance(0.4) ? 100 : 5) * (b.kinematic ? 0.5 : 1.0);
    d << (b.kinematic ? " kinematic" : "") << " at " << b.origin.x << "," << b.origin.y << "," << b.origin.z << "; ";
    const int i = w.addBody(b);
    sc.pathCentre.emplace_back(0);
    sc.pathRadius.push_back(0);
    sc.pathRate.push_back(0);
    if (b.kinematic) {
      sc.kinematic.push_back(i);
      sc.energySources = true;
      if (in.chance(0.5)) {
        sc.pathRadius.back() = in.range(0.1, 2);
        sc.pathRate.back() = in.range(-8, 8);
        sc.pathCentre.back() = w.body(i).x - glm::dvec3(sc.pathRadius.back(), 0, 0);
      }
    }
  }
  const int n = static_cast<int>(w.size());
  sc.jointed.assign(static_cast<size_t>(n), 0);
  // Joints between dynamic bodies or to the world.
  const bool withJoints = in.chance(0.5);
  const int joints = withJoints ? in.pick(6) : 0;
  for (int k = 0; k < joints; ++k) {
    JointDef j;
    j.type = static_cast<JointType>(in.pick(5));
    j.b = in.pick(n);
    j.a = in.chance(0.3) ? -1 : in.pick(n);
    if (j.a == j.b || w.body(j.b).isStatic) continue;
    // Joined dynamic bodies within a mass ratio of 1000 (docs/library.md: the joint solver's range).
    if (j.a >= 0 && w.body(j.a).dynamic() && w.body(j.b).dynamic()) {
      const double ratio = w.body(j.a).mass / w.body(j.b).mass;
      if (ratio > 1000 || ratio < 1e-3) continue;
    }
    const glm::dvec3 pb = w.body(j.b).x, pa = j.a < 0 ? pb + in.vec(1) : w.body(j.a).x;
    j.anchor = 0.5 * (pa + pb);
    j.anchorA = pa;
    j.anchorB = pb;
    j.axis = glm::normalize(in.vec(1) + glm::dvec3(0, 0.01, 0));
    if ((j.type == JointType::Hinge || j.type == JointType::Slider) && in.chance(0.5)) {
      j.limited = true;
      j.lower = in.range(-1, 0);
      j.upper = in.range(0, 1);
    }
    if ((j.type == JointType::Hinge || j.type == JointType::Slider) && in.chance(0.3)) {
      j.motor.enabled = true;
      j.motor.speed = in.range(-10, 10);
      j.motor.maxForce = in.logRange(1, 1e5);
      sc.energySources = true;
      const double lightest = std::min(j.a >= 0 && w.body(j.a).mass > 0 ? w.body(j.a).mass : 1e30, w.body(j.b).mass);
      sc.accelerationBound += j.motor.maxForce / std::max(lightest, 1e-3) * 4;  // a torque on a small lever too
    }
    if (j.type == JointType::Distance && in.chance(0.5)) {
      j.minLength = 0;
      j.maxLength = glm::length(pb - pa) * in.range(0.2, 1.5);
      if (j.maxLength < glm::length(pb - pa)) sc.energySources = true;  // a rope started stretched
    }
    if (in.chance(0.2)) j.breakImpulse = in.logRange(1, 1e5);
    j.collideConnected = in.chance(0.3);
    w.addJoint(j);
    // A joint drags its bodies along at its anchor's speed on either body (a spinning body swings what hangs on it).
    for (int end : {j.a, j.b}) {
      if (end < 0) continue;
      const RigidBody& e = w.body(end);
      const glm::dvec3 anchor = j.type == JointType::Distance ? (end == j.a ? j.anchorA : j.anchorB) : j.anchor;
      sc.jointSpeed = std::max(sc.jointSpeed, glm::length(e.v) + glm::length(e.w) * glm::length(anchor - e.x));
    }
    if (j.a >= 0) sc.jointed[static_cast<size_t>(j.a)] = 1;
    sc.jointed[static_cast<size_t>(j.b)] = 1;
    d << jointTypeName(j.type) << " joint " << j.a << "-" << j.b << (j.limited ? " limited" : "")
      << (j.motor.enabled ? " motor" : "") << "; ";
    if (in.chance(0.25) && !w.body(j.b).kinematic) {  // started violated: the body moved off
      const RigidBody& b = w.body(j.b);
      w.setPose(j.b, {b.x + in.vec(3), glm::normalize(b.q * glm::dquat(1, in.range(-1, 1), 0, 0))});
      sc.energySources = true;
      // What closing the joints on it may hand out (the engine's bound, joint_step.cpp: each joint's net work at
      // most twice its rows' effective masses at the correction speed), wherever it ends: contradicting joints
      // on a heavy body can pass a heavy body's share on to a light one.
      const double c = w.settings().maxCorrectionSpeed;
      for (int k = 0; k < static_cast<int>(w.jointCount()); ++k) {
        const JointDef& o = w.jointDef(k);
        if (o.b != j.b && o.a != j.b) continue;
        double inverseMass = 0, inverseInertia = 0;
        for (int end : {o.a, o.b}) {
          if (end < 0 || !w.body(end).dynamic()) continue;
          inverseMass += 1 / w.body(end).mass;
          inverseInertia += 1 / w.body(end).principal.moments.z;
        }
        if (inverseMass > 0) sc.closingEnergy += 2 * 6 * c * c * std::max(1 / inverseMass, 1 / inverseInertia);
      }
      d << "(violated); ";
    }
  }
  // A vehicle.
  if (in.chance(0.3)) {
    BodyDef car;
    car.shape = makeBox({4, 1, 1.8});
    car.origin = {in.range(-2, 2), in.range(0.5, 2), in.range(-2, 2)};
    car.mass = in.logRange(1, 3000);
    const int i = w.addBody(car);
    sc.jointed.push_back(0);
    sc.pathCentre.emplace_back(0);
    sc.pathRadius.push_back(0);
    sc.pathRate.push_back(0);
    VehicleParams p;
    p.wheels = {{1.3, -0.3, 1.0}, {1.3, -0.3, -1.0}, {-1.3, -0.3, 1.0}, {-1.3, -0.3, -1.0}};
    p.wheelRadius = 0.33;
    p.suspensionRest = 0.25;
    p.stiffness = in.logRange(10, 1e9);
    p.damping = in.chance(0.2) ? 0 : in.logRange(1, 1e9);
    sc.vehicles.emplace_back(i, p);
    sc.throttle.push_back(in.range(-1, 1));
    sc.energySources = true;
    // The engine (and the tyres' grip, at most the springs' load times grip) on the car's mass.
    sc.accelerationBound += (p.engineForce + p.brakeForce) / car.mass;
    // Springs set compressed can launch it: at most their whole energy, 4 x k reach^2 / 2, as speed.
    const double reach = p.suspensionRest + p.wheelRadius;
    sc.pushSpeed = std::max(sc.pushSpeed, std::sqrt(4 * p.stiffness * reach * reach / car.mass));
    sc.springEnergy += 4 * 0.5 * p.stiffness * reach * reach;
    d << "vehicle " << car.mass << " kg, k " << p.stiffness << ", c " << p.damping << "; ";
  }
  // Anything started inside something else is a source (the projection lifts it out).
  std::vector<Contact> contacts;
  for (int a = 0; a < static_cast<int>(w.size()) && !sc.energySources; ++a)
    for (int b = a + 1; b < static_cast<int>(w.size()); ++b) {
      contacts.clear();
      const RigidBody& A = w.body(a);
      const RigidBody& B = w.body(b);
      w.findContacts(a, b, {A.x, A.q}, {B.x, B.q}, contacts);
      if (!contacts.empty() && contacts.front().phi < -w.settings().penetrationSlop) {
        sc.energySources = true;
        break;
      }
    }
  for (const RigidBody& b : w.bodies())
    if (!b.isStatic) sc.pushSpeed = std::max(sc.pushSpeed, pointSpeed(b));
  // What joints hang on a spinning body turns with it (a light body welded far out on a spinning one keeps
  // nearly all of its spin): a sling reaches as far out as its links and ropes laid end to end, and its far end
  // moves at up to the body's speed plus its turn times that reach. A slider without limits in a kinematic body's
  // sling is a bead on a rod that turns for ever, flung out without bound (its speed grows as e^(w t)): such
  // bodies are held to the finite state only (on a rod only dynamic bodies turn, the energy bounds the bead).
  {
    const int bodies = static_cast<int>(w.size());
    std::vector<int> root(static_cast<size_t>(bodies));
    for (int i = 0; i < bodies; ++i) root[static_cast<size_t>(i)] = i;
    auto find = [&](int i) {
      while (root[static_cast<size_t>(i)] != i) i = root[static_cast<size_t>(i)] = root[static_cast<size_t>(root[static_cast<size_t>(i)])];
      return i;
    };
    std::vector<double> ropes(static_cast<size_t>(bodies), 0.0);
    std::vector<char> bead(static_cast<size_t>(bodies), 0);
    for (int j = 0; j < static_cast<int>(w.jointCount()); ++j) {
      const JointDef& d = w.jointDef(j);
      if (d.a < 0 || w.body(d.a).isStatic || w.body(d.b).isStatic) continue;
      const int ra = find(d.a), rb = find(d.b);
      if (ra != rb) {
        root[static_cast<size_t>(ra)] = rb;
        ropes[static_cast<size_t>(rb)] += ropes[static_cast<size_t>(ra)];
        bead[static_cast<size_t>(rb)] |= bead[static_cast<size_t>(ra)];
      }
      if (d.type == JointType::Distance) ropes[static_cast<size_t>(rb)] += std::max(d.maxLength, glm::length(d.anchorB - d.anchorA));
      if (d.type == JointType::Slider) {
        if (d.limited) ropes[static_cast<size_t>(rb)] += d.upper - d.lower;
        else bead[static_cast<size_t>(rb)] = 1;
      }
    }
    sc.sling.assign(static_cast<size_t>(bodies), 0);
    sc.mechanismSpeed.assign(static_cast<size_t>(bodies), 0.0);
    for (int k = 0; k < bodies; ++k) {
      const RigidBody& kb = w.body(k);
      if (kb.isStatic) continue;
      const int r = find(k);
      double reach = ropes[static_cast<size_t>(r)];
      for (int i = 0; i < bodies; ++i)
        if (i != k && find(i) == r) reach += glm::length(w.body(i).x - kb.x) + 2 * w.body(i).shape->boundingRadius;
      const size_t ki = static_cast<size_t>(k);
      const double turn = glm::length(kb.w) + std::abs(sc.pathRate[ki]);
      sc.pushSpeed = std::max(sc.pushSpeed, pointSpeed(kb) + std::abs(sc.pathRate[ki]) * sc.pathRadius[ki] + turn * reach);
      if (kb.kinematic && bead[static_cast<size_t>(r)])
        for (int i = 0; i < bodies; ++i)
          if (find(i) == r) sc.sling[static_cast<size_t>(i)] = 1;
      // A kinematic body drives what its joints hold with no limit on the force, and a mechanism it drives
      // into a static body passes through singular poses (a rod on a rigid tether dragged down into the ground
      // must swing sideways ever faster as the tether turns vertical, and rolls as it goes): within one step it
      // swings at most across the group's reach, rolling doubles that.
      if (kb.kinematic)
        for (int i = 0; i < bodies; ++i)
          if (find(i) == r && i != k)
            sc.mechanismSpeed[static_cast<size_t>(i)] = std::max(sc.mechanismSpeed[static_cast<size_t>(i)],
                                                                 2 * (reach + 1) * kScenarioRate);
    }
    // The same where a kinematic body pushes a jointed body by contact (a heavy cylinder on a short rope to the
    // world, run through by a kinematic one): the push meets the joints' constraint at any angle, and near a
    // right angle the body must slide along it ever faster; within one step, at most across its own joints' reach.
    if (!sc.kinematic.empty())
      for (int j = 0; j < static_cast<int>(w.jointCount()); ++j) {
        const JointDef& d = w.jointDef(j);
        double own = glm::length(d.anchorB - d.anchorA) + std::max(d.maxLength, 0.0) + std::abs(d.upper - d.lower);
        for (int end : {d.a, d.b}) {
          if (end < 0 || !w.body(end).dynamic()) continue;
          own += glm::length(w.body(end).x - (d.type == JointType::Distance ? (end == d.a ? d.anchorA : d.anchorB) : d.anchor));
        }
        for (int end : {d.a, d.b}) {
          if (end < 0 || !w.body(end).dynamic()) continue;
          const double r = 2 * w.body(end).shape->boundingRadius;
          sc.mechanismSpeed[static_cast<size_t>(end)] =
              std::max(sc.mechanismSpeed[static_cast<size_t>(end)], 2 * (own + r + 1) * kScenarioRate);
        }
      }
  }
  for (size_t k = 0; k < sc.kinematic.size(); ++k) {
    const size_t i = static_cast<size_t>(sc.kinematic[k]);
    sc.pushSpeed = std::max(sc.pushSpeed, std::abs(sc.pathRate[i]) * sc.pathRadius[i] + pointSpeed(w.body(sc.kinematic[k])));
  }
  sc.pushSpeed = std::max(sc.pushSpeed, sc.jointSpeed);
  // Energy can gather in one light body (a bead flung along a rod that heavy bodies turn, a marble under a wheel
  // taking the spring's energy): the speed at which a body would hold all the kinetic energy, the springs' and
  // what falling to the ground would release and what closing violated joints may hand out, twice over (a rod's tip
  // turns at up to sqrt 3 times that speed).
  double available = sc.springEnergy + sc.closingEnergy;
  for (const RigidBody& b : w.bodies())
    if (b.dynamic()) available += b.kineticEnergy() + b.mass * glm::length(w.settings().gravity) * (std::abs(b.x.y) + 1);
  sc.energySpeed.assign(w.size(), 0.0);
  for (size_t i = 0; i < w.size(); ++i)
    if (w.body(static_cast<int>(i)).dynamic()) sc.energySpeed[i] = 2 * std::sqrt(2 * available / w.body(static_cast<int>(i)).mass);
  sc.accelerationBound += glm::length(w.settings().gravity);
  sc.description = d.str();
}

inline double scenarioEnergy(const World& w) {
  double e = 0;
  for (const RigidBody& b : w.bodies()) {
    if (b.isStatic || b.kinematic || b.removed) continue;  // sleeping bodies count (their height)
    e += b.kineticEnergy() - b.mass * glm::dot(w.settings().gravity, b.x);
  }
  return e;
}

// Builds the scenario of `data` and steps it; the first broken invariant, or "" when all hold.
// `log`: each step's bodies (speed, position), for looking into a finding.
inline std::string runScenario(const uint8_t* data, size_t size, int steps = 120, std::FILE* log = nullptr) {
  ScenarioInput in(data, size);
  Scenario sc;
  buildScenario(sc, in);
  World& w = sc.world;
  const double h = 1.0 / kScenarioRate;
  const double e0 = scenarioEnergy(w);
  double weight = 0;
  for (const RigidBody& b : w.bodies())
    if (!b.isStatic && !b.kinematic) weight += b.mass * glm::length(w.settings().gravity);
  // Energy: the collision step's iterations (1e-4 of it), the projection's slop (a body resting penetrationSlop deep is lifted out of it, again after each
  // landing) and rounding.
  const double energySlack = 1e-4 * std::abs(e0) + weight * 0.01 + 1e-9;
  auto fail = [&](int step, const std::string& what) {
    std::ostringstream o;
    o << "step " << step << ": " << what << " [" << sc.description << "]";
    return o.str();
  };
  const size_t n = w.size();
  std::vector<Aabb> bounds(n);
  for (int s = 0; s < steps; ++s) {
    // Kinematic paths: the velocities that take each to its next point on the circle.
    const double t1 = (s + 1) * h;
    for (int k : sc.kinematic) {
      const size_t i = static_cast<size_t>(k);
      if (sc.pathRadius[i] <= 0) continue;
      const double a = sc.pathRate[i] * t1;
      const glm::dvec3 p = sc.pathCentre[i] + sc.pathRadius[i] * glm::dvec3(std::cos(a), 0, std::sin(a));
      w.setKinematicTarget(k, {p, w.body(k).q * glm::angleAxis(sc.pathRate[i] * h, glm::dvec3(0, 1, 0))}, h);
    }
    for (size_t v = 0; v < sc.vehicles.size(); ++v) {
      w.wake(sc.vehicles[v].body());
      sc.vehicles[v].apply(w, {sc.throttle[v], 0.3, 0, false}, h);
    }
    // Which bodies touch nothing this step: bounds grown by what each can travel in it, clear of all others (a
    // jointed body can be flung within the step: a spinning body it is hinged to whirls it at up to pushSpeed).
    for (size_t i = 0; i < n; ++i) {
      const RigidBody& b = w.body(static_cast<int>(i));
      Aabb a = scenarioBounds(b);
      const double speed = sc.jointed[i] ? std::max({pointSpeed(b), sc.pushSpeed, sc.mechanismSpeed[i]}) : pointSpeed(b);
      const double grow = (speed + glm::length(w.settings().gravity) * h) * h * 2 + 0.01;
      a.lo -= grow;
      a.hi += grow;
      bounds[i] = a;
    }
    std::vector<char> free(n, 0);
    for (size_t i = 0; i < n; ++i) {
      const RigidBody& b = w.body(static_cast<int>(i));
      if (!b.dynamic() || sc.jointed[i]) continue;
      bool clear = true;
      for (size_t j = 0; j < n && clear; ++j) {
        if (j == i) continue;
        const Aabb& p = bounds[i];
        const Aabb& q = bounds[j];
        clear = p.hi.x < q.lo.x || q.hi.x < p.lo.x || p.hi.y < q.lo.y || q.hi.y < p.lo.y || p.hi.z < q.lo.z ||
                q.hi.z < p.lo.z;
      }
      // A vehicle's wheels reach below its chassis: what lies within a metre of it may be under a wheel.
      for (const Vehicle& v : sc.vehicles) {
        const Aabb& p = bounds[i];
        Aabb q = bounds[static_cast<size_t>(v.body())];
        q.lo -= 1.0;
        q.hi += 1.0;
        if (static_cast<size_t>(v.body()) == i || !(p.hi.x < q.lo.x || q.hi.x < p.lo.x || p.hi.y < q.lo.y ||
                                                     q.hi.y < p.lo.y || p.hi.z < q.lo.z || q.hi.z < p.lo.z))
          clear = false;
      }
      free[i] = clear;
    }
    // Which bodies a kinematic body may press against something else this step (the ground, another body): a
    // push with no force limit against a rigid support levers the body about it, and its far end can move faster
    // than the push by the ratio of the levers, without bound as the support nears the pushed point (a car pressed
    // down at one end by a kinematic body, pivoting on the ground near it, flings its other end). Such a body
    // becomes a pusher at whatever speed it leaves the step with.
    auto overlap = [](const Aabb& p, const Aabb& q) {
      return !(p.hi.x < q.lo.x || q.hi.x < p.lo.x || p.hi.y < q.lo.y || q.hi.y < p.lo.y || p.hi.z < q.lo.z ||
               q.hi.z < p.lo.z);
    };
    std::vector<char> pressed(n, 0);
    for (int k : sc.kinematic)
      for (size_t i = 0; i < n; ++i) {
        if (!w.body(static_cast<int>(i)).dynamic() || !overlap(bounds[i], bounds[static_cast<size_t>(k)])) continue;
        for (size_t j = 0; j < n && !pressed[i]; ++j)
          pressed[i] = j != i && j != static_cast<size_t>(k) && overlap(bounds[i], bounds[j]);
      }
    std::vector<RigidBody> before(w.bodies().begin(), w.bodies().end());
    const StepStatus status = w.step(h);
    if (!status) return fail(s, "step refused: body " + std::to_string(status.body) + " went non-finite");
    const double t = (s + 1) * h;
    if (log)
      for (size_t i = 0; i < n; ++i) {
        const RigidBody& b = w.body(static_cast<int>(i));
        std::fprintf(log, "step %d body %zu speed %g x %g %g %g v %g %g %g w %g %g %g substeps %d\n", s, i,
                     pointSpeed(b), b.x.x, b.x.y, b.x.z, b.v.x, b.v.y, b.v.z, b.w.x, b.w.y, b.w.z, w.lastStats().substeps);
      }
    for (size_t i = 0; i < n; ++i)
      if (pressed[i]) sc.pushSpeed = std::max(sc.pushSpeed, pointSpeed(w.body(static_cast<int>(i))));
    const double bound = 4 * (sc.pushSpeed + w.settings().maxCorrectionSpeed) + sc.accelerationBound * t * 4 + 1;
    for (const CollisionEvent& e : w.events()) {
      const bool sound = std::isfinite(e.impulse) && e.impulse >= 0 && std::isfinite(e.elasticImpulse) &&
                         e.elasticImpulse >= 0 && std::isfinite(e.impulseVector.x + e.impulseVector.y + e.impulseVector.z) &&
                         e.a >= 0 && e.b >= 0 && e.a != e.b && static_cast<size_t>(std::max(e.a, e.b)) < n;
      if (!sound) return fail(s, "an event's bodies or impulses are not sound");
    }
    for (size_t i = 0; i < n; ++i) {
      const RigidBody& b = w.body(static_cast<int>(i));
      const bool finiteState = std::isfinite(b.x.x + b.x.y + b.x.z + b.v.x + b.v.y + b.v.z + b.w.x + b.w.y + b.w.z +
                                              b.q.w + b.q.x + b.q.y + b.q.z);
      if (!finiteState) return fail(s, "body " + std::to_string(i) + " not finite");
      if (!b.dynamic() || sc.sling[i]) continue;
      const double speed = pointSpeed(b);
      if (speed > std::max({bound, sc.energySpeed[i], sc.mechanismSpeed[i]})) {
        std::ostringstream o;
        o << "body " << i << " moves at " << speed << " m/s, over the bound " << bound << " m/s";
        return fail(s, o.str());
      }
      if (free[i] && before[i].dynamic()) {
        const RigidBody& a = before[i];
        const glm::dvec3 l0 = a.angularMomentum(), l1 = b.angularMomentum();
        if (glm::length(l1 - l0) > 1e-9 * glm::length(l0) + 1e-12) {
          std::ostringstream o;
          o << "free body " << i << " changed its angular momentum from " << glm::length(l0) << " by "
            << glm::length(l1 - l0);
          return fail(s, o.str());
        }
        const glm::dvec3 dv = b.v - a.v - h * w.settings().gravity;
        if (glm::length(dv) > 1e-9 * (glm::length(a.v) + 1)) return fail(s, "free body " + std::to_string(i) + " changed its velocity");
      }
    }
    if (!sc.energySources) {
      const double e = scenarioEnergy(w);
      if (e > e0 + energySlack) {
        std::ostringstream o;
        o << "energy grew from " << e0 << " J to " << e << " J (allowed " << energySlack << ")";
        return fail(s, o.str());
      }
    }
  }
  return "";
}

}  // namespace crumple::test
