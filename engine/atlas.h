// Texture atlases. The deformation stage writes each body's height map through
// its texture coordinates, so every texel must belong to one surface point
// (one-to-one parameterisation; Wrotek et al. section 3). Primitives are built
// from charts; meshes whose UVs are missing or overlap get an automatic atlas:
// charts of connected triangles facing one axis, projected to their plane
// (texel size uniform in metres), packed into the unit square with gutters.
#pragma once
#include <glm/glm.hpp>

#include <vector>

#include <crumple/physics/mesh.h>

namespace crumple {

// Triangles grouped in charts, with flat 2D coordinates (metres) per corner.
struct ChartMesh {
  std::vector<glm::vec3> positions;  // 3 per triangle
  std::vector<glm::vec3> normals;    // 3 per triangle
  std::vector<glm::vec2> chartUV;    // 3 per triangle, metres
  std::vector<int> chart;            // 1 per triangle
  std::vector<glm::vec3> colors;     // 3 per triangle, or empty
  std::vector<glm::vec2> materialUvs;  // 3 per triangle, or empty (TriangleMesh::materialUvs)
  std::vector<int> materialIds;        // 3 per triangle, or empty
  void addTriangle(int chartId, const glm::vec3 p[3], const glm::vec3 n[3], const glm::vec2 uv[3],
                   const glm::vec3* color = nullptr, const glm::vec2* materialUv = nullptr,
                   const int* materialId = nullptr);
  size_t triangleCount() const { return chart.size(); }
};

// Packs the charts into [0,1]^2, gutters of `gutterTexels` at `resolution`,
// and returns an indexed mesh (corners welded where position, normal and uv agree).
TriangleMesh packCharts(const ChartMesh& charts, int resolution, int gutterTexels = 3);

struct AtlasCheck {
  bool oneToOne = false;
  long overlappingTexels = 0;  // texels covered by more than one triangle
  long coveredTexels = 0;
  int outsideTriangles = 0;    // triangles with uv outside [0,1]
  int collapsedTriangles = 0;  // zero uv area but real surface area
  bool missing = false;        // no uvs at all
};
// Rasterises every triangle in uv space at `resolution` and counts texels hit twice.
AtlasCheck checkAtlas(const TriangleMesh& mesh, int resolution);

// A fresh one-to-one atlas for a mesh (its uvs are ignored).
TriangleMesh generateAtlas(const TriangleMesh& mesh, int resolution);

}  // namespace crumple
