// A signed distance field sampled on a regular grid in a mesh's frame,
// built from exact closest-triangle queries through a BVH, with the sign from
// angle-weighted pseudo-normals (Baerentzen & Aanaes 2005). Trilinear lookups.
#pragma once
#include <glm/glm.hpp>

#include <cstdint>
#include <limits>
#include <utility>
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
  // Every triangle no further than sqrt(within2) from p, as (distance2, triangle), in no particular order.
  void near(const glm::dvec3& p, double within2, std::vector<std::pair<double, int>>& out) const;

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

// The nearest triangle within a reach, cell by cell: the first query in a cell (of `cell` metres) lists, through
// the BVH, the triangles that pass within reach of the cell, nearest its centre first; later queries there test
// those only, until the next could not be nearer than the nearest found (its distance from the centre less the
// query point's). Exact: TriangleBvh's distance, and among equally near triangles the lowest index. The lists are
// kept per thread, each a function of its cell alone (the answers are the same at any thread count); a query in a
// cell already listed costs a hash probe and a few triangles.
class NearTriangles {
 public:
  NearTriangles(const TriangleMesh& mesh, double cell, double reach);
  // The nearest triangle no further than reach (its distance2 <= reach^2), or triangle -1.
  TriangleBvh::Hit closest(const glm::dvec3& p) const;
  double reach() const { return reach_; }

 private:
  struct Entry;
  struct Kept;
  Kept& kept() const;
  // The cell's list: its first entry and its length.
  std::pair<const Entry*, uint32_t> listed(Kept& kept, const glm::i64vec3& cell) const;
  glm::dvec3 centreOf(const glm::dvec3& cell) const { return (cell + 0.5) * cell_; }  // (cell: its integer index)
  struct Corners {
    glm::vec3 a, b, c;
  };
  TriangleBvh bvh_;
  std::vector<Corners> corners_;
  double cell_, reach_;
  double reachBound_;  // the next double above reach^2: a triangle at exactly reach counts
  uint64_t id_;  // unique in the process: which lists a thread keeps are this one's
};

class SdfGrid {
 public:
  // Cells of (longest extent) / resolution, or finer where the body is thin: at least resolution / 4 cells across
  // its thinnest extent, as long as the grid stays within kMaxNodes.
  SdfGrid(const TriangleMesh& mesh, int resolution);
  static constexpr double kMaxNodes = 1 << 19;
  // Signed distance (negative inside). Outside the grid, the distance to the
  // grid box is added to the clamped lookup, which keeps it an upper bound.
  // The gradient is written only where the distance is below gradientBelow.
  double distance(const glm::dvec3& p, glm::dvec3* gradient,
                  double gradientBelow = std::numeric_limits<double>::infinity()) const;
  glm::ivec3 dims() const { return dims_; }
  // A bound on how fast distance() changes: |distance(p) - distance(q)| <= lipschitz() |p - q| everywhere (its
  // rounding aside). Inside a cell the trilinear lookup's gradient is at most the length of the cell's largest
  // node difference per axis, over the cell (the bound is the largest of these over the cells); outside, the
  // distance to the grid box adds at most a unit orthogonal to the clamp's.
  double lipschitz() const { return lipschitz_; }
  // Exact signed distance through the BVH (used to build the grid and by tests).
  double exactDistance(const glm::dvec3& p) const;

 private:
  TriangleBvh bvh_;
  std::vector<glm::dvec3> faceNormal_, vertexNormal_;
  std::vector<glm::dvec3> edgeNormal_;  // 3 per triangle (edge i opposite vertex (i+2)%3 ... see cpp)
  std::vector<glm::dvec3> positions_;
  std::vector<glm::uvec3> triangles_;
  glm::dvec3 origin_{0};
  double cell_ = 1;
  glm::ivec3 dims_{0};
  glm::dvec3 maxg_{0};  // the largest grid coordinate a lookup reads from: dims - 1, less a hair
  double lipschitz_ = 0;
  std::vector<double> values_;
};

}  // namespace crumple
