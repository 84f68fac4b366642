#include <crumple/physics/mesh.h>

#include <cmath>
#include <glm/gtc/constants.hpp>
#include <limits>
#include <utility>

namespace crumple {

void TriangleMesh::computeNormals() {
  normals.assign(positions.size(), glm::vec3(0));
  for (const auto& t : triangles) {
    const glm::vec3 n = glm::cross(positions[t.y] - positions[t.x], positions[t.z] - positions[t.x]);
    normals[t.x] += n;
    normals[t.y] += n;
    normals[t.z] += n;
  }
  for (auto& n : normals) {
    const float len = glm::length(n);
    n = len > 0 ? n / len : glm::vec3(0, 1, 0);
  }
}

glm::vec3 TriangleMesh::boundsMin() const {
  glm::vec3 m(std::numeric_limits<float>::max());
  for (const auto& p : positions) m = glm::min(m, p);
  return m;
}
glm::vec3 TriangleMesh::boundsMax() const {
  glm::vec3 m(-std::numeric_limits<float>::max());
  for (const auto& p : positions) m = glm::max(m, p);
  return m;
}

// Eberly, "Polyhedral Mass Properties (Revisited)", 2002: integrals of
// 1, x, y, z, x^2, y^2, z^2, xy, yz, zx over the solid via the divergence theorem.
MassProperties polyhedralMassProperties(const TriangleMesh& mesh) {
  const double mult[10] = {1. / 6, 1. / 24, 1. / 24, 1. / 24, 1. / 60, 1. / 60, 1. / 60, 1. / 120, 1. / 120, 1. / 120};
  double intg[10] = {0};
  auto subexpr = [](double w0, double w1, double w2, double& f1, double& f2, double& f3, double& g0, double& g1,
                    double& g2) {
    const double temp0 = w0 + w1;
    f1 = temp0 + w2;
    const double temp1 = w0 * w0;
    const double temp2 = temp1 + w1 * temp0;
    f2 = temp2 + w2 * f1;
    f3 = w0 * temp1 + w1 * temp2 + w2 * f2;
    g0 = f2 + w0 * (f1 + w0);
    g1 = f2 + w1 * (f1 + w1);
    g2 = f2 + w2 * (f1 + w2);
  };
  for (const auto& t : mesh.triangles) {
    const glm::dvec3 p0 = mesh.positions[t.x], p1 = mesh.positions[t.y], p2 = mesh.positions[t.z];
    const glm::dvec3 d = glm::cross(p1 - p0, p2 - p0);
    double f1x, f2x, f3x, g0x, g1x, g2x, f1y, f2y, f3y, g0y, g1y, g2y, f1z, f2z, f3z, g0z, g1z, g2z;
    subexpr(p0.x, p1.x, p2.x, f1x, f2x, f3x, g0x, g1x, g2x);
    subexpr(p0.y, p1.y, p2.y, f1y, f2y, f3y, g0y, g1y, g2y);
    subexpr(p0.z, p1.z, p2.z, f1z, f2z, f3z, g0z, g1z, g2z);
    intg[0] += d.x * f1x;
    intg[1] += d.x * f2x;
    intg[2] += d.y * f2y;
    intg[3] += d.z * f2z;
    intg[4] += d.x * f3x;
    intg[5] += d.y * f3y;
    intg[6] += d.z * f3z;
    intg[7] += d.x * (p0.y * g0x + p1.y * g1x + p2.y * g2x);
    intg[8] += d.y * (p0.z * g0y + p1.z * g1y + p2.z * g2y);
    intg[9] += d.z * (p0.x * g0z + p1.x * g1z + p2.x * g2z);
  }
  for (int i = 0; i < 10; ++i) intg[i] *= mult[i];
  MassProperties mp;
  mp.volume = intg[0];
  if (!(mp.volume > 0)) return mp;
  const glm::dvec3 c(intg[1] / mp.volume, intg[2] / mp.volume, intg[3] / mp.volume);
  mp.centerOfMass = c;
  const double m = mp.volume;
  const double ixx = intg[5] + intg[6] - m * (c.y * c.y + c.z * c.z);
  const double iyy = intg[4] + intg[6] - m * (c.z * c.z + c.x * c.x);
  const double izz = intg[4] + intg[5] - m * (c.x * c.x + c.y * c.y);
  const double ixy = -(intg[7] - m * c.x * c.y);
  const double iyz = -(intg[8] - m * c.y * c.z);
  const double ixz = -(intg[9] - m * c.z * c.x);
  mp.inertia = glm::dmat3(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz);
  return mp;
}

TriangleMesh torusMesh(float R, float r, int nu, int nv) {
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
  if (polyhedralMassProperties(m).volume < 0)
    for (auto& t : m.triangles) std::swap(t.y, t.z);
  return m;
}


}  // namespace crumple
