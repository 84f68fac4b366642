// Triangle meshes as the physics and the renderer both see them: per-vertex
// positions, normals and texture coordinates (seams split vertices), and
// counter-clockwise triangles seen from outside.
#pragma once
#include <glm/glm.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

namespace crumple {

struct TriangleMesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
  std::vector<glm::vec2> uvs;  // empty when the mesh has no parameterisation
  // Vertex colours (sRGB), empty when the file has none. They multiply the
  // material's colour, as glTF's COLOR_0 multiplies its base colour.
  std::vector<glm::vec3> colors;
  // The file's own material (glTF): per vertex, the texture coordinates of its images (TEXCOORD_0, kept when the
  // atlas above is regenerated) and the index of its material in the file's look (render/look.h);
  // both empty when the file has none.
  std::vector<glm::vec2> materialUvs;
  std::vector<int> materialIds;
  std::vector<glm::uvec3> triangles;

  bool empty() const { return triangles.empty(); }
  void computeNormals();  // area-weighted vertex normals
  glm::vec3 boundsMin() const;
  glm::vec3 boundsMax() const;
};

// A triangle's parameterisation, the tangent frame the renderer shades with: dP/du and dP/dv (the mesh's frame)
// from its positions and texture coordinates, and `det`, twice its signed area in uv. False, with all zero, where
// its uvs are degenerate.
struct UvFrame {
  glm::dvec3 dPdu{0}, dPdv{0};
  double det = 0;
};
inline bool uvFrame(const TriangleMesh& mesh, const glm::uvec3& t, UvFrame& out) {
  const glm::dvec3 e1 = glm::dvec3(mesh.positions[t.y] - mesh.positions[t.x]);
  const glm::dvec3 e2 = glm::dvec3(mesh.positions[t.z] - mesh.positions[t.x]);
  const glm::dvec2 uv0(mesh.uvs[t.x]), d1 = glm::dvec2(mesh.uvs[t.y]) - uv0, d2 = glm::dvec2(mesh.uvs[t.z]) - uv0;
  const double det = d1.x * d2.y - d1.y * d2.x;
  if (!(std::abs(det) > 1e-20)) {
    out = {};
    return false;
  }
  out.det = det;
  out.dPdu = (e1 * d2.y - e2 * d1.y) / det;
  out.dPdv = (e2 * d1.x - e1 * d2.x) / det;
  return true;
}

// Mass properties of a closed mesh of unit density (Mirtich's / Eberly's
// polyhedral integrals): volume, centre of mass and the inertia tensor about it.
struct MassProperties {
  double volume = 0;
  glm::dvec3 centerOfMass{0};
  glm::dmat3 inertia{1};  // per unit density, about the centre of mass
};
MassProperties polyhedralMassProperties(const TriangleMesh& mesh);

// A torus around y (ring radius R, tube radius r), outward winding, with the
// periodic (u, v) parameterisation as uvs: one-to-one, but split at the seams.
// (The other primitives' meshes come with charts for their maps: engine/primitives.h.)
TriangleMesh torusMesh(float R, float r, int nu, int nv);

}  // namespace crumple
