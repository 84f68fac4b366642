// A raycast vehicle (the usual game-car model): the chassis is a rigid body;
// each wheel is a ray along the chassis' down axis from its attachment point,
// held up by a spring-damper (integrated implicitly: stable at any mass and
// damping), with tyre forces from the slip at the contact:
// lateral grip, engine drive and brakes, each limited by friction (Coulomb,
// mu * load). Forces go through World::addForceAtPoint before each step; a
// dynamic body under a wheel takes the opposite force.
// Body frame: +x forward, +y up.
#pragma once
#include <glm/glm.hpp>

#include <vector>

#include <crumple/physics/world.h>

namespace crumple {

struct VehicleParams {
  std::vector<glm::dvec3> wheels;  // attachment points, shape frame; x > centre: steered front wheels
  double wheelRadius = 0.35;
  double suspensionRest = 0.3;  // spring length at rest (m)
  double stiffness = 40000;     // N/m per wheel
  double damping = 4000;        // N s/m per wheel
  double engineForce = 6000;    // N at full throttle, shared by the wheels on the ground
  double brakeForce = 9000;     // N at full brake
  double maxSteer = 0.6;        // rad
  double grip = 1.2;            // tyre friction coefficient
};

struct VehicleControls {
  double throttle = 0;  // -1 (reverse) .. 1
  double steer = 0;     // -1 (right) .. 1 (left)
  double brake = 0;     // 0 .. 1
  bool handbrake = false;
};

struct WheelState {
  bool onGround = false;
  double compression = 0;  // m
  // m: the spring's compression, which follows `compression` but grows no faster than the chassis approaches the
  // ground plus World's maxCorrectionSpeed (a body swept under a wheel, or a car set down deep on its springs,
  // loads the spring over a few steps instead of releasing its whole energy in one).
  double spring = 0;
  glm::dvec3 contact{0};
  glm::dvec3 normal{0, 1, 0};  // of the ground at the contact
  int ground = -1;             // the body under the wheel
  double load = 0;             // N
};

class Vehicle {
 public:
  Vehicle(int body, const VehicleParams& params) : body_(body), params_(params), wheels_(params.wheels.size()) {}
  // Computes and applies this step's forces.
  void apply(World& world, const VehicleControls& controls, double h);
  const std::vector<WheelState>& wheels() const { return wheels_; }
  const VehicleParams& params() const { return params_; }
  int body() const { return body_; }
  double speed(const World& world) const;  // forward speed, m/s

 private:
  int body_;
  VehicleParams params_;
  std::vector<WheelState> wheels_;
};

}  // namespace crumple
