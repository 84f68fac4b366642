#include <crumple/deform/model/stress_strain.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace crumple {

double yieldThreshold(double eps) {
  if (std::isnan(eps)) return std::numeric_limits<double>::infinity();
  eps = std::clamp(eps, 0.0, 1.0);
  if (eps >= 1.0) return std::numeric_limits<double>::infinity();
  return 1.0 / (1.0 - eps) - 1.0;
}

double percentDeform(double kappa, double elasticImpulse, double threshold) {
  if (std::isnan(kappa) || std::isnan(elasticImpulse) || std::isnan(threshold)) return 0.0;
  if (std::isinf(threshold) || !(elasticImpulse > threshold)) return 0.0;
  return std::max(0.0, kappa) * (elasticImpulse - threshold);
}

double deformDepth(double thickness, double percentDeformValue) {
  if (!(thickness > 0) || !(percentDeformValue > 0)) return 0.0;
  return thickness * percentDeformValue;
}

double percentDeformFromStress(double stress, double yieldStress, double plasticModulus, double youngsModulus) {
  if (!(stress > yieldStress) || !(plasticModulus > 0) || !(youngsModulus > 0)) return 0.0;
  const double compliance = 1.0 / plasticModulus - 1.0 / youngsModulus;
  return compliance > 0 ? (stress - yieldStress) * compliance : 0.0;
}

}  // namespace crumple
