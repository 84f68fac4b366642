// Rigid bodies: state, mass properties and the frame conventions.
//
// Frames: a body's shape is defined in its shape frame (the frame of the mesh
// file or primitive). The body's state x is the world position of the centre of
// mass, q its orientation; the shape frame's origin is x - R(q) * localCom.
#pragma once
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <cstdint>
#include <memory>
#include <string>

#include <crumple/physics/rotation.h>
#include <crumple/physics/shape.h>

namespace crumple {

struct Pose {
  glm::dvec3 position{0};  // centre of mass, world
  glm::dquat orientation{1, 0, 0, 0};
};

// A handle to a body: its slot and the slot's generation. Once the body is
// removed and World::add reuses the slot for another, the old handle is stale:
// World::index refuses it, so it can never reach the new body (Box2D's b2BodyId).
struct BodyId {
  int32_t index = -1;
  uint32_t generation = 0;
  bool operator==(const BodyId&) const = default;
};

struct BodyDef {
  std::shared_ptr<const Shape> shape;
  glm::dvec3 origin{0};  // world position of the shape frame's origin
  glm::dquat orientation{1, 0, 0, 0};
  glm::dvec3 linearVelocity{0};   // of the centre of mass
  glm::dvec3 angularVelocity{0};  // rad/s, world
  double density = 1000;
  double mass = 0;  // > 0 overrides density
  double restitution = 0.5;
  double friction = 0.5;
  bool isStatic = false;
  // Moved, never pushed: keeps its velocities (or follows World::setKinematicTarget), infinite mass in
  // every impulse, no gravity; it carries and pushes what it touches. Its mass properties are ignored.
  bool kinematic = false;
  int group = 0;  // collision group, 0..63 (World::setGroupsCollide)
};

struct RigidBody {
  std::shared_ptr<const Shape> shape;
  glm::dvec3 localCom{0};
  double mass = 0, invMass = 0;
  glm::dmat3 inertiaBody{1}, invInertiaBody{0};  // about the centre of mass, shape axes
  PrincipalInertia principal;                      // of inertiaBody (the torque-free turn, rotation.h)
  glm::dvec3 x{0};
  glm::dquat q{1, 0, 0, 0};
  glm::dvec3 v{0}, w{0};
  double restitution = 0.5, friction = 0.5;
  bool isStatic = false;
  bool kinematic = false;  // invMass and invInertiaBody are 0; never sleeps
  bool removed = false;    // World::removeBody: takes part in nothing any more
  uint32_t generation = 0;  // bumped each time World::add reuses this slot (BodyId)
  int group = 0;
  bool asleep = false;
  double stillTime = 0;
  // Where the body was when its stillness began (stillTime 0 then): position, orientation (sleep.cpp).
  glm::dvec3 stillFromX{0};
  glm::dquat stillFromQ{1, 0, 0, 0};

  glm::dmat3 rotation() const { return glm::mat3_cast(q); }
  glm::dvec3 origin() const { return x - rotation() * localCom; }
  // The *At forms take the rotation R(q) made already (the same bits as the others).
  glm::dmat3 invInertiaWorld() const { return invInertiaAt(rotation()); }
  glm::dmat3 invInertiaAt(const glm::dmat3& r) const { return r * invInertiaBody * glm::transpose(r); }
  // World angular momentum about the centre of mass, and kinetic energy (translation and turn).
  glm::dvec3 angularMomentum() const { return angularMomentumOf(w); }
  // ... of the body turning at `turn` instead (world inertia times it).
  glm::dvec3 angularMomentumOf(const glm::dvec3& turn) const { return angularMomentumAt(rotation(), turn); }
  glm::dvec3 angularMomentumAt(const glm::dmat3& r, const glm::dvec3& turn) const {
    return r * (inertiaBody * (glm::transpose(r) * turn));
  }
  double kineticEnergy() const { return kineticEnergyAt(rotation()); }
  double kineticEnergyAt(const glm::dmat3& r) const {
    return 0.5 * mass * glm::dot(v, v) + 0.5 * glm::dot(w, angularMomentumAt(r, w));
  }
  glm::dvec3 velocityAt(const glm::dvec3& p) const { return v + glm::cross(w, p - x); }
  bool movable() const { return !isStatic && !asleep; }
  // Moved by impulses (not static, kinematic or asleep).
  bool dynamic() const { return movable() && !kinematic; }
};

// Shape-frame point to world for a body at pose (x, q) with centre localCom.
inline glm::dvec3 toWorld(const Pose& pose, const glm::dvec3& localCom, const glm::dvec3& p) {
  return pose.position + glm::mat3_cast(pose.orientation) * (p - localCom);
}
inline glm::dvec3 toShape(const Pose& pose, const glm::dvec3& localCom, const glm::dvec3& p) {
  return glm::transpose(glm::mat3_cast(pose.orientation)) * (p - pose.position) + localCom;
}

}  // namespace crumple
