#include <crumple/physics/vehicle.h>

#include <algorithm>
#include <glm/gtc/matrix_transform.hpp>
#include <cmath>

namespace crumple {

double Vehicle::speed(const World& world) const {
  const RigidBody& b = world.body(body_);
  return glm::dot(b.v, b.rotation() * glm::dvec3(1, 0, 0));
}

void Vehicle::apply(World& world, const VehicleControls& c, double h) {
  const RigidBody& b = world.body(body_);
  const glm::dmat3 r = b.rotation();
  const glm::dvec3 up = r * glm::dvec3(0, 1, 0), forward = r * glm::dvec3(1, 0, 0);
  const double reach = params_.suspensionRest + params_.wheelRadius;
  const double wheelMass = b.mass / std::max<size_t>(1, params_.wheels.size());
  const double steer = std::clamp(c.steer, -1.0, 1.0) * params_.maxSteer;
  int grounded = 0;
  for (size_t i = 0; i < params_.wheels.size(); ++i) {
    WheelState& w = wheels_[i];
    const glm::dvec3 origin = b.x + r * (params_.wheels[i] - b.localCom);
    RayHit hit;
    // A wheel whose attachment point is inside a body (the chassis sunk into it, or a body inside the chassis)
    // stands on nothing: that body meets the chassis' own contacts (a spring found fully compressed from one
    // step to the next would hand it energy from nowhere).
    w.onGround = world.raycast(origin, -up, reach, body_, hit) && hit.distance > 0;
    grounded += w.onGround;
  }
  for (size_t i = 0; i < params_.wheels.size(); ++i) {
    WheelState& w = wheels_[i];
    if (!w.onGround) {
      w.compression = w.spring = 0;
      w.load = 0;
      continue;
    }
    const glm::dvec3 origin = b.x + r * (params_.wheels[i] - b.localCom);
    RayHit hit;
    world.raycast(origin, -up, reach, body_, hit);
    w.contact = hit.point;
    w.normal = hit.normal;
    const bool sameGround = w.ground == hit.body;  // the body this wheel stood on in the last step
    w.ground = hit.body;
    const double compression = reach - hit.distance;
    w.compression = compression;
    const glm::dvec3 pointVelocity = b.velocityAt(hit.point);
    // Compression rate: the chassis' approach to the ground along the ground's normal, as the ray sees it.
    const glm::dvec3 groundVelocity = world.body(hit.body).velocityAt(hit.point);
    const double rate = -glm::dot(hit.normal, pointVelocity - groundVelocity) /
                        std::max(glm::dot(hit.normal, up), 0.1);
    // Suspension: spring and damper along the chassis' up axis, never pulling down, integrated implicitly
    // (backward Euler on the wheel's share of the chassis' mass at its point, which the wheels on the ground
    // split): stable for any mass, stiffness, damping and step; at most it stops the compression and undoes it
    // within the step.
    const glm::dvec3 lever = glm::cross(origin - b.x, up);
    double pointInverseMass = b.invMass + glm::dot(lever, b.invInertiaWorld() * lever);
    const RigidBody& ground = world.body(hit.body);
    if (ground.dynamic()) {  // a body under the wheel takes the reaction: its mass at the point counts too
      const glm::dvec3 groundLever = glm::cross(hit.point - ground.x, up);
      pointInverseMass += ground.invMass + glm::dot(groundLever, ground.invInertiaWorld() * groundLever);
    }
    const double share = 1.0 / (pointInverseMass * std::max(grounded, 1));
    const double stiff = params_.stiffness * h + params_.damping;
    // What else pushes the wheel's point into the ground during the step (the chassis' weight, the other wheels,
    // the engine's pitch) is what this wheel held against it in the last step: its load then (0 on landing, or
    // on another body than the last step's). It speeds the point's approach by load / share over the step. So at
    // rest, and under any steady load, k x = the load, as an explicit spring holds it; only changes are damped
    // implicitly.
    // That load is trusted up to four times the wheel's share of the car's weight (a steady push that big:
    // another body on the car, hard cornering): when something else cancels this wheel's push (the chassis
    // pressed into a body that the contact step holds), the load it carried over grew each step without bound
    // and flung the car when the other let go.
    const double weightShare = b.mass * std::max(glm::length(world.settings().gravity), 9.81) / std::max(grounded, 1);
    const double carried = std::min(w.load, 4 * weightShare);
    const double approach = rate + (sameGround ? h * carried / share : 0.0);
    w.spring = std::min(compression, w.spring + h * (std::max(rate, 0.0) + world.settings().maxCorrectionSpeed));
    w.load = std::max(0.0, (params_.stiffness * w.spring + stiff * approach) / (1 + h * stiff / share));
    glm::dvec3 force = up * w.load;
    // Tyre frame on the ground.
    const bool front = params_.wheels[i].x > b.localCom.x;
    glm::dvec3 dir = forward;
    if (front && steer != 0)
      dir = glm::dvec3(glm::dmat4(glm::rotate(glm::dmat4(1), steer, up)) * glm::dvec4(forward, 0));
    dir = glm::normalize(dir - hit.normal * glm::dot(dir, hit.normal));
    const glm::dvec3 side = glm::normalize(glm::cross(hit.normal, dir));
    const double friction = params_.grip * w.load;
    const bool rear = !front;
    // Lateral: remove the sideways slip at the contact within a couple of steps.
    const double vSide = glm::dot(pointVelocity - groundVelocity, side);
    // The mass that a tyre force acts against: the wheel's share of the chassis, and with a dynamic body under
    // it that body's mass at the contact in series (a light body under a heavy car is not flung by the car's mass).
    auto slipMass = [&](const glm::dvec3& along) {
      if (!ground.dynamic()) return wheelMass;
      const glm::dvec3 l = glm::cross(hit.point - ground.x, along);
      const double inverse = ground.invMass + glm::dot(l, ground.invInertiaWorld() * l);
      return 1.0 / (1.0 / wheelMass + inverse);
    };
    double lateral = -vSide * slipMass(side) / (2 * h);
    const double lateralLimit = (c.handbrake && rear) ? 0.3 * friction : friction;
    lateral = std::clamp(lateral, -lateralLimit, lateralLimit);
    // Longitudinal: engine drive, brakes (never reversing the wheel), friction-limited together.
    const double vLong = glm::dot(pointVelocity - groundVelocity, dir);
    double longitudinal = std::clamp(c.throttle, -1.0, 1.0) * params_.engineForce / std::max(grounded, 1);
    double brake = std::clamp(c.brake, 0.0, 1.0) * params_.brakeForce / std::max(grounded, 1);
    if (c.handbrake && rear) brake = std::max(brake, params_.brakeForce / std::max(grounded, 1));
    const double stop = -vLong * slipMass(dir) / h;  // the force that would stop this wheel in one step
    longitudinal += std::clamp(stop, -brake, brake);
    const double total = std::hypot(lateral, longitudinal);
    if (total > friction && total > 0) {
      lateral *= friction / total;
      longitudinal *= friction / total;
    }
    force += side * lateral + dir * longitudinal;
    world.addForceAtPoint(body_, force, hit.point);
    // Newton's third law: what the wheel pushes on is pushed back (a car on a loose body moves it).
    if (ground.dynamic()) world.addForceAtPoint(hit.body, -force, hit.point);
  }
}

}  // namespace crumple
