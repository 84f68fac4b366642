// Meshes made in code for tests.
#pragma once
#include <crumple/physics/mesh.h>

#include <cmath>

namespace crumple::test {
using crumple::torusMesh;

// A voussoir: the annular sector of an arch between angles a0 and a1 (radians,
// about z from +x), inner radius ri, radial thickness t, depth d along z (centred),
// in the arch's frame (its centre at the origin), outward winding.
inline TriangleMesh voussoirMesh(double ri, double t, double d, double a0, double a1) {
  TriangleMesh m;
  for (int c = 0; c < 8; ++c) {
    const double r = c & 1 ? ri + t : ri, a = c & 2 ? a1 : a0, z = c & 4 ? d / 2 : -d / 2;
    m.positions.push_back(glm::vec3(static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)),
                                    static_cast<float>(z)));
  }
  // Each quad listed clockwise seen from outside, split as (q0, q2, q1), (q0, q3, q2).
  const unsigned q[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  for (const auto& f : q) {
    m.triangles.push_back({f[0], f[2], f[1]});
    m.triangles.push_back({f[0], f[3], f[2]});
  }
  m.computeNormals();
  return m;
}
}  // namespace crumple::test
