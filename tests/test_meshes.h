// Meshes made in code for tests.
#pragma once
#include <cmath>
#include <glm/gtc/constants.hpp>

#include "physics/mesh.h"

namespace crumple::test {

// A torus around y, outward winding, with a (periodic, seam-split) uv map.
inline TriangleMesh torusMesh(float R, float r, int nu, int nv) {
  TriangleMesh m;
  const float tau = glm::two_pi<float>();
  for (int i = 0; i <= nu; ++i) {
    for (int j = 0; j <= nv; ++j) {
      const float u = tau * i / nu, v = tau * j / nv;
      const glm::vec3 c(std::cos(u) * R, 0, std::sin(u) * R);
      const glm::vec3 n(std::cos(u) * std::cos(v), std::sin(v), std::sin(u) * std::cos(v));
      m.positions.push_back(c + n * r);
      m.normals.push_back(n);
      m.uvs.push_back({static_cast<float>(i) / nu, static_cast<float>(j) / nv});
    }
  }
  auto id = [&](int i, int j) { return static_cast<unsigned>(i * (nv + 1) + j); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i, j + 1), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i + 1, j)});
    }
  // Make the winding outward whatever the parameter orientation.
  if (polyhedralMassProperties(m).volume < 0)
    for (auto& t : m.triangles) std::swap(t.y, t.z);
  return m;
}

}  // namespace crumple::test
