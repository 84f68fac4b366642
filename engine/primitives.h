// Render meshes of the primitive shapes with one-to-one atlases (charts packed
// by packCharts). Axis conventions match physics/shape.h: capsules and
// cylinders stand along y.
#pragma once
#include <glm/glm.hpp>

#include <crumple/physics/mesh.h>

namespace crumple {

TriangleMesh boxMesh(const glm::dvec3& size, int resolution);
TriangleMesh sphereMesh(double radius, int resolution, int segments = 16);  // cube-sphere, 6 charts
TriangleMesh cylinderMesh(double radius, double height, int resolution, int segments = 48);
// torusMesh: physics/mesh.h.
TriangleMesh capsuleMesh(double radius, double height, int resolution, int segments = 48, int rings = 12);

}  // namespace crumple
