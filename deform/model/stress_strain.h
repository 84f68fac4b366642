// The stress-strain model of Wrotek, Rice & McGuire (section 2.1), as pure functions.
//
//   eq. (3)  percentDeform = (S - S_yield) (1/P - 1/E)      for S > S_yield, else 0
//   eq. (5)  percentDeform = kappa * max(0, |j_eps=1| - Y)
//   eq. (6)  Y = 1 / (1 - eps) - 1
//
// and the depth of the dent, t * percentDeform (t: wall thickness of a shell,
// width of a solid).
#pragma once

namespace crumple {

// eq. (6): the impulse threshold below which a body of restitution eps does not
// dent. eps = 1 (perfectly elastic) never deforms: the threshold is +infinity
// (no division by zero). eps is clamped to [0, 1] first: a restitution outside
// that range has no physical meaning and is rejected by the scene loader.
double yieldThreshold(double eps);

// eq. (5): the fraction of thickness by which the body is pushed in. Returns 0
// when the elastic impulse does not exceed the threshold (including Y = inf)
// or when any input is NaN; kappa below 0 is treated as 0.
double percentDeform(double kappa, double elasticImpulse, double threshold);

// The dent depth in metres: t * percentDeform.
double deformDepth(double thickness, double percentDeformValue);

// eq. (3), the stress form the impulse form abstracts: stress S and yield stress
// in Pa, plastic slope P and Young's modulus E (P < E for a softening material).
// Returns 0 for S <= S_yield. If P >= E the plastic branch would not lose length:
// returns 0 (no permanent deformation) rather than a negative value.
double percentDeformFromStress(double stress, double yieldStress, double plasticModulus, double youngsModulus);

}  // namespace crumple
