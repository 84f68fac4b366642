// Collision shapes. Every shape answers the same question, the signed distance
// phi(p) (negative inside) and its gradient in the shape's own frame, and offers
// sample points that are tested against other bodies' distance fields
// (Guendelman et al. 2003: vertices of B against phi_A and the reverse).
// Primitives use exact analytic distances; meshes a grid built from the mesh.
#pragma once
#include <glm/glm.hpp>

#include <limits>
#include <memory>
#include <vector>

#include <crumple/physics/mesh.h>
#include <crumple/physics/polytope.h>
#include <crumple/physics/sdf_grid.h>

namespace crumple {

class SampleTree;

enum class ShapeType { Box, Sphere, Capsule, Cylinder, Mesh };
const char* shapeTypeName(ShapeType t);

struct Shape {
  ShapeType type = ShapeType::Box;
  glm::dvec3 halfExtents{0.5};  // box
  double radius = 0.5;          // sphere, capsule, cylinder (axis y)
  double halfHeight = 0.5;      // capsule: half the straight part; cylinder: half the height

  // Points tested against other shapes' fields. A rounded shape (sphere,
  // capsule) tests its core points: the surface point is p - sampleRadius * n.
  std::vector<glm::dvec3> samples;
  // Outward surface normal at each sample (zero where it has none, as at the
  // core points of rounded shapes). Inside another body, the sample's contact
  // normal should oppose it: that breaks the ties of the other body's field.
  std::vector<glm::dvec3> sampleNormals;
  double sampleRadius = 0.0;

  glm::dvec3 boundsMin{0}, boundsMax{0};  // shape frame
  double boundingRadius = 0;              // the farthest point's distance from the shape origin
  MassProperties unitMass;                // density 1
  std::shared_ptr<const SdfGrid> grid;    // meshes only
  // Boxes and convex meshes (of at most 64 faces): vertices, faces and edges.
  // Two such shapes collide by their contact manifold (polytope.h) rather than
  // by samples, and a convex mesh's distance inside is its exact plane distance.
  std::shared_ptr<const ConvexPolytope> polytope;
  // The samples in a tree (shapes of more than SampleTree::kMinSamples samples; made with
  // the samples, unused unless it holds as many as they are): the broad phase's box queries.
  std::shared_ptr<const SampleTree> sampleTree;

  // Signed distance at p (shape frame) and, if asked, its unit gradient. Where
  // the gradient is ambiguous inside (a box's edges), `hint`, a unit direction
  // in the shape frame towards the other body, chooses the face. A nonconvex
  // mesh's field writes the gradient only where the distance is below
  // `gradientBelow` (a caller that needs it only near the surface spares the
  // rest their gradient); every other shape always writes it.
  double distance(const glm::dvec3& p, glm::dvec3* gradient = nullptr, const glm::dvec3* hint = nullptr,
                  double gradientBelow = std::numeric_limits<double>::infinity()) const;
  // How fast distance() can change with the point, at most (0: no bound known): |distance(p) - distance(q)| <=
  // distanceSlope() |p - q|. The analytic shapes' are exact distances (1); a nonconvex mesh's grid has its bound
  // (SdfGrid::lipschitz); a convex mesh takes its face planes inside and the grid outside, which jump where they
  // meet (0).
  double distanceSlope() const;
  // The distance from the shape's thinnest section centre to its surface: the
  // penetration a sample may reach before the field points it out the far side.
  // (The make functions keep it in `cachedHalfThickness`: the narrow phase asks for it per pair and look.)
  double halfThickness() const { return cachedHalfThickness > 0 ? cachedHalfThickness : computeHalfThickness(); }
  double computeHalfThickness() const;
  double cachedHalfThickness = 0;
  // Meshes: the thinnest local half thickness, from the triangles inward (makeMeshShape; 0: unknown).
  double localHalfThickness = 0;
};

std::shared_ptr<Shape> makeBox(const glm::dvec3& size);
std::shared_ptr<Shape> makeSphere(double radius);
std::shared_ptr<Shape> makeCapsule(double radius, double height);  // height of the straight part
std::shared_ptr<Shape> makeCylinder(double radius, double height);
// A closed triangle mesh. `gridResolution` cells along the longest side.
std::shared_ptr<Shape> makeMeshShape(const TriangleMesh& mesh, int gridResolution = 48);

}  // namespace crumple
