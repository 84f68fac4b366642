// Collision impulses (Guendelman et al. 2003, section 7; the deformation paper's eq. 4).
#pragma once
#include <glm/glm.hpp>

namespace crumple {

// One side of a contact for the impulse: inverse mass, world inverse inertia,
// offset r from the centre of mass to the contact point. A static or frozen
// body has invMass 0 and a zero inverse inertia.
struct ImpulseSide {
  double invMass = 0;
  glm::dmat3 invInertia{0};
  glm::dvec3 r{0};
};

// K = sum over sides of (1/m) Id - r* I^-1 r*   (r* the cross-product matrix).
// An impulse j applied to B (and -j to A) changes the relative velocity u = v_B - v_A by K j.
// With `coupling`: also C = I_B^-1 [r_B]x + I_A^-1 [r_A]x (PatchMatrix::C), from the products K is made of.
glm::dmat3 collisionMatrix(const ImpulseSide& a, const ImpulseSide& b, glm::dmat3* coupling = nullptr);

// Eq. (4) of Wrotek et al. for two free point masses, normal N owned by A:
// j = -N (1 + eps) N.(v_B - v_A) / (1/m_A + 1/m_B), the impulse on B.
glm::dvec3 pointMassImpulse(const glm::dvec3& n, double eps, const glm::dvec3& vA, const glm::dvec3& vB, double mA,
                            double mB);

// Frictionless impulse on B for relative velocity u, unit normal n (out of A):
// j = -(1 + eps) (u.n) / (n^T K n) n. Zero when u.n >= 0 (separating).
glm::dvec3 frictionlessImpulse(const glm::dmat3& K, const glm::dvec3& u, const glm::dvec3& n, double eps);

// With Coulomb friction mu: the sticking impulse K^-1(-eps (u.n) n - u) when it
// lies inside the friction cone, otherwise the sliding impulse along n - mu T.
// The result never pulls the bodies together (j.n >= 0) and never adds kinetic
// energy. Zero when u.n >= 0.
glm::dvec3 frictionImpulse(const glm::dmat3& K, const glm::dvec3& u, const glm::dvec3& n, double eps, double mu);

// K with its inverse, for a contact whose matrix stays the same over many
// impulses (the passes of the contact step between two looks at the geometry).
struct ImpulseMatrix {
  glm::dmat3 K{0}, inverse{0};
  bool invertible = false;
  ImpulseMatrix() = default;
  explicit ImpulseMatrix(const glm::dmat3& k);
};
// The same impulse as frictionImpulse(m.K, ...), without inverting K again.
glm::dvec3 frictionImpulse(const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& n, double eps, double mu);

// The impulses already applied at one contact during a step (the passes of the
// contact step): normal magnitude and tangential vector.
struct FrictionTotals {
  double normal = 0;
  glm::dvec3 tangential{0};
};
// Coulomb's law over the whole step: the cone bounds the total tangential
// impulse at the contact by mu times its total normal impulse (as the law
// bounds the friction force by the normal force), not each pass's impulse by
// its own. The contact step ramps restitution from -1 to 0, so its first passes
// push only a little along the normal; judged alone, their sticking impulses
// leave the cone and a block that should stick on an incline creeps down it.
// Adds the impulse to `totals` (nullptr: this impulse alone, as above).
glm::dvec3 frictionImpulse(const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& n, double eps, double mu,
                           FrictionTotals* totals);

// A face contact: the extent of the touching patch about the point where its
// impulse acts, in two tangent directions t1, t2 (t2 = n x t1).
struct PatchExtent {
  glm::dvec3 n{0}, t1{0}, t2{0};
  double lo1 = 0, hi1 = 0, lo2 = 0, hi2 = 0;  // lo <= 0 <= hi
  bool flat() const { return hi1 - lo1 <= 0 || hi2 - lo2 <= 0; }
  // The mean lever of torsional friction over the patch (its twist limit is mu jn times this).
  double twistRadius() const { return 0.77 * 0.25 * ((hi1 - lo1) + (hi2 - lo2)); }
};
// One impulse at a single point cannot hold a face: it zeroes the relative
// velocity there but not the relative tilting or twisting, and a box resting
// off-centre on another (a brick wall, a leaning tower) rocks on its one point,
// and one set spinning keeps spinning. A patch impulse adds a torque impulse T:
// about the tangent axes, the moment of a pressure that moves off the centre
// while that centre of pressure stays within the patch; about the normal,
// torsional friction, at most mu times the normal impulse times the patch's
// mean lever. J at the point plus T (on B; -J and -T on A) make the point's
// relative velocity the target and the relative angular velocity zero. A
// centre of pressure outside the patch is clamped to its edge (the body then
// tips, as it should), a twist beyond its friction slides.
struct PatchMatrix {
  bool valid = false;
  glm::dmat3 C{0}, W{0};             // relative angular velocity change: C J + W T
  glm::dvec3 b[3] = {}, kb[3] = {};  // C^T e_i and K^-1 C^T e_i, e = (t1, t2, n)
  double w[3][3] = {};               // e_i.W e_k
  glm::dmat3 s3{0};                  // inverse Schur complement, tilt and twist
  double s2[2][2] = {};              // inverse Schur complement, tilt only
  double twistRadius = 0;
  bool hinge = false;  // only the tilt about patch.t1 (lineMatrix)
  double s1 = 0;       // its inverse Schur complement
  PatchExtent patch;
};
PatchMatrix patchMatrix(const ImpulseSide& a, const ImpulseSide& b, const ImpulseMatrix& k, const PatchExtent& patch);
// The same, in place: p.patch is the extent; every field a valid matrix uses is written (the contact step
// keeps one per group and refreshes it at each look, without a 600-byte temporary).
void setPatchMatrix(PatchMatrix& p, const ImpulseSide& a, const ImpulseSide& b, const ImpulseMatrix& k);
// The same with C given (collisionMatrix's `coupling` for the same sides).
void setPatchMatrix(PatchMatrix& p, const ImpulseSide& a, const ImpulseSide& b, const ImpulseMatrix& k,
                    const glm::dmat3& coupling);
// For one of a body's two supports: the patch holds only the tilt about the
// line through the two (`axis`, any direction along it), which the couple of
// the two supports' point impulses cannot; tilt across the line and twist are
// theirs. A brick on two bricks rocks out of the wall's plane without it.
PatchMatrix lineMatrix(const ImpulseSide& a, const ImpulseSide& b, const ImpulseMatrix& k, const PatchExtent& patch,
                       const glm::dvec3& axis);
// The patch impulse (J, T) for relative velocity u and relative angular
// velocity omega (B's minus A's) with the restitution and Coulomb cone of
// frictionImpulse (the cone over `totals`, which it updates). False when the
// patch cannot act as one (a slide, a pull, no patch): use frictionImpulse;
// J and T are then left as they were. `whole`, when given, says whether the
// impulse met every target (a full patch: the point's velocity, no relative
// tilt, no relative twist) with nothing clamped: applied whole, it leaves the
// pair at those targets but for rounding (with restitution 0: no relative motion).
bool patchImpulse(const PatchMatrix& p, const ImpulseMatrix& m, const glm::dvec3& u, const glm::dvec3& omega,
                  const glm::dvec3& n, double eps, double mu, FrictionTotals* totals, glm::dvec3& J, glm::dvec3& T,
                  bool* whole = nullptr);

}  // namespace crumple
