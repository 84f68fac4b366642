// A signed distance field sampled on a regular grid in a mesh's frame,
// built from exact closest-triangle queries through a BVH, with the sign from
// angle-weighted pseudo-normals (Baerentzen & Aanaes 2005). Trilinear lookups.
#pragma once
#include <glm/glm.hpp>

#include <vector>

#include <crumple/physics/mesh.h>

namespace crumple {

// Closest-triangle queries over a triangle mesh.
class TriangleBvh {
 public:
  explicit TriangleBvh(const TriangleMesh& mesh);
  struct Hit {
    double distance2 = 0;
    glm::dvec3 point{0};
    int triangle = -1;
    glm::dvec3 barycentric{0};
  };
  Hit closest(const glm::dvec3& p) const;
  // The nearest triangle no further than sqrt(within2) (its distance2 <= within2; else triangle -1): nodes
  // further than that are never opened, so a point off the surface costs a few box tests.
  Hit closest(const glm::dvec3& p, double within2) const;

 private:
  struct Node {
    glm::dvec3 lo, hi;
    int left = -1, right = -1;  // children, or -1
    int first = 0, count = 0;   // leaf triangle range in order_
  };
  int build(int first, int count);
  std::vector<Node> nodes_;
  std::vector<int> order_;
  std::vector<glm::dvec3> a_, b_, c_;
  std::vector<glm::dvec3> centroid_;
};

class SdfGrid {
 public:
  SdfGrid(const TriangleMesh& mesh, int resolution);
  // Signed distance (negative inside). Outside the grid, the distance to the
  // grid box is added to the clamped lookup, which keeps it an upper bound.
  double distance(const glm::dvec3& p, glm::dvec3* gradient) const;
  glm::ivec3 dims() const { return dims_; }
  // Exact signed distance through the BVH (used to build the grid and by tests).
  double exactDistance(const glm::dvec3& p) const;

 private:
  double node(int i, int j, int k) const { return values_[(static_cast<size_t>(k) * dims_.y + j) * dims_.x + i]; }
  TriangleBvh bvh_;
  std::vector<glm::dvec3> faceNormal_, vertexNormal_;
  std::vector<glm::dvec3> edgeNormal_;  // 3 per triangle (edge i opposite vertex (i+2)%3 ... see cpp)
  std::vector<glm::dvec3> positions_;
  std::vector<glm::uvec3> triangles_;
  glm::dvec3 origin_{0};
  double cell_ = 1;
  glm::ivec3 dims_{0};
  std::vector<double> values_;
};

}  // namespace crumple
