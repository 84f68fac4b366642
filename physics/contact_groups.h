// Contact groups (internal to the physics library).
//
// Resting contact treats a pair's penetrating points in groups: points whose
// normals agree (within about 35 degrees of the group's deepest) make one
// impulse at their centre of pressure (weighted by depth) along their mean
// normal. Processing points one by one (Guendelman's deepest point) makes a box
// resting on a face rock from corner to corner and walk; one averaged contact
// per face is the face's resultant and leaves no spurious torque. Grouping by
// normal keeps the separate touching places of nonconvex bodies apart.
#pragma once
#include <glm/glm.hpp>

#include <vector>

#include <crumple/physics/body.h>
#include <crumple/physics/impulse.h>
#include <crumple/physics/types.h>

namespace crumple::detail {

// Normals within about 35 degrees of a group's deepest make one group.
constexpr double kSameGroup = 0.82;

// A group's resultant: its members' points and normals (oriented as the
// seed's, out of the seed's body a) weighted by depth.
struct GroupSum {
  const Contact& seed;
  glm::dvec3 point{0}, normal{0};
  double weight = 0;
  glm::dvec3 oriented(const Contact& c) const { return c.a == seed.a ? c.normal : -c.normal; }
  bool agrees(const Contact& c) const { return glm::dot(oriented(c), seed.normal) >= kSameGroup; }
  void add(const Contact& c) {
    const double w = -c.phi + 1e-6;
    point += w * c.point;
    normal += w * oriented(c);
    weight += w;
  }
  Contact result() const {
    Contact m = seed;
    m.point = point / weight;
    const double len = glm::length(normal);
    m.normal = len > 1e-12 ? normal / len : seed.normal;
    return m;
  }
};

// A contact point's offsets from the two centres of mass, at the poses it was found at.
struct Levers {
  glm::dvec3 ra, rb;
};
inline Levers levers(const Contact& c, const Pose& poseA, const Pose& poseB) {
  return {c.point - poseA.position, c.point - poseB.position};
}

// One group of a pair as the contact step last found it, with what its
// impulses need: the points and inertias stay put until the geometry is found
// again, so only the relative velocity changes between passes.
struct ContactGroup {
  Contact contact;          // the group's resultant (point, mean normal, deepest depth)
  Levers levers;            // at the poses the group was found at
  ImpulseMatrix matrix;     // K and K^-1 at those levers
  double speed = 0;         // normal relative speed when found
  FrictionTotals totals;    // impulses so far this contact step (Coulomb's cone bounds them)
  PatchMatrix patchMatrix;  // the patch impulse system, with the members' extent about the group's point (.patch)
};

// Groups `contacts` (sorted deepest first): sets each group's contact, patch
// (patchMatrix.patch) and zero totals in `out` (resized to the groups); the other
// fields keep what the element held (the caller sets them: levers, matrix,
// setPatchMatrix, speed).
void groupContacts(const std::vector<Contact>& contacts, std::vector<ContactGroup>& out);

}  // namespace crumple::detail
