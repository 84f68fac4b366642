// Rotation of a rigid body: principal axes of inertia and torque-free motion.
//
// A body spinning freely keeps its angular momentum L (world) and its kinetic
// energy; its angular velocity w = I(q)^-1 L does not stay constant unless it
// spins about a principal axis. The position update moves every dynamic body
// through its torque-free motion over the step (forces and torques act on the
// velocities before it), by a splitting of the kinetic energy in the principal
// frame (Dullweber, Leimkuhler & McLachlan 1997; McLachlan & Zanna 2005):
//
//   T = |L|^2 / (2 I_m) + 1/2 c_0 L_0^2 + 1/2 c_2 L_2^2,  c_k = 1/I_k - 1/I_m
//
// with I_0 <= I_m = I_1 <= I_2. Each part's flow is an exact rotation: the
// first about L (world) by h |L| / I_m, and it commutes with the others (|L|^2
// is a Casimir); the others about a principal axis, taken as half, whole,
// half (Strang: second order, time-reversible, symplectic). So:
// - L (world) is kept exactly (to rounding): every part's flow rotates the
//   body about a direction that keeps it;
// - a body with two equal principal moments (a symmetric top) and a sphere or
//   cube turn exactly (the remaining part vanishes: one turn of each part);
// - with three distinct moments, the kinetic energy is then brought back to
//   its value at the start (the body turned by the small rotation that puts
//   its angular momentum back on the level set of the energy, on the same
//   sphere): no drift, no gain, and the intermediate-axis flip keeps its
//   analytic period to second order in h.
#pragma once
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace crumple {

// The principal axes of a symmetric inertia tensor: moments ascending, and the
// rotation that takes principal axes to the tensor's axes (its columns are the
// unit eigenvectors; a right-handed frame). A diagonal tensor keeps its axes
// (permuted into ascending order).
struct PrincipalInertia {
  glm::dvec3 moments{1};
  glm::dquat frame{1, 0, 0, 0};
};
PrincipalInertia principalInertia(const glm::dmat3& inertia);

// exp(h w) q: q turned by the angle h |w| about w (world), exactly.
glm::dquat rotateBy(const glm::dquat& q, const glm::dvec3& w, double h);

// The torque-free motion of a body with principal moments `moments` (shape axes
// to principal axes: `frame`) from orientation q and angular velocity w (world)
// over h: the orientation and angular velocity after it. Keeps I(q) w (world)
// and the kinetic energy.
struct FreeRotation {
  glm::dquat q{1, 0, 0, 0};
  glm::dvec3 w{0};
};
FreeRotation freeRotation(const PrincipalInertia& inertia, const glm::dquat& q, const glm::dvec3& w, double h);

}  // namespace crumple
