// Primitive meshes and atlases: closed, outward, and one texel per surface point.
#include <doctest/doctest.h>

#include <cmath>
#include <glm/gtc/constants.hpp>

#include <crumple/engine/atlas.h>
#include <crumple/engine/primitives.h>
#include "test_meshes.h"

using namespace crumple;
using doctest::Approx;

namespace {
void checkClosedOutward(const TriangleMesh& m, double expectedVolume, double tolerance) {
  const MassProperties mp = polyhedralMassProperties(m);
  CHECK(mp.volume == Approx(expectedVolume).epsilon(tolerance));
  int disagree = 0;
  for (const auto& t : m.triangles) {
    const glm::vec3 fn = glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]);
    const glm::vec3 vn = m.normals[t.x] + m.normals[t.y] + m.normals[t.z];
    if (glm::dot(fn, vn) <= 0) ++disagree;
  }
  CHECK(disagree == 0);
}
}  // namespace

TEST_CASE("primitive meshes are closed, face outwards and have one-to-one atlases") {
  const double pi = glm::pi<double>();
  SUBCASE("box") {
    const TriangleMesh m = boxMesh({2, 0.5, 1}, 512);
    checkClosedOutward(m, 1.0, 1e-5);
    const AtlasCheck c = checkAtlas(m, 512);
    CHECK(c.oneToOne);
    CHECK(c.overlappingTexels == 0);
    CHECK(c.coveredTexels > 512 * 512 / 3);  // the packer uses a good part of the map
  }
  SUBCASE("sphere") {
    const TriangleMesh m = sphereMesh(0.5, 512);
    checkClosedOutward(m, 4.0 / 3 * pi * 0.125, 0.01);
    CHECK(checkAtlas(m, 512).oneToOne);
  }
  SUBCASE("cylinder") {
    const TriangleMesh m = cylinderMesh(0.3, 1.2, 512);
    checkClosedOutward(m, pi * 0.09 * 1.2, 0.01);
    CHECK(checkAtlas(m, 512).oneToOne);
  }
  SUBCASE("capsule") {
    const TriangleMesh m = capsuleMesh(0.3, 0.8, 512);
    checkClosedOutward(m, pi * 0.09 * 0.8 + 4.0 / 3 * pi * 0.027, 0.01);
    CHECK(checkAtlas(m, 512).oneToOne);
  }
}

TEST_CASE("an atlas check finds texels used twice") {
  TriangleMesh m = boxMesh({1, 1, 1}, 256);
  CHECK(checkAtlas(m, 256).oneToOne);
  // Mirror the whole map onto its left half: faces now share texels.
  for (auto& uv : m.uvs) uv.x = std::min(uv.x, 1.0f - uv.x);
  const AtlasCheck c = checkAtlas(m, 256);
  CHECK_FALSE(c.oneToOne);
  CHECK(c.overlappingTexels > 100);
}

TEST_CASE("automatic atlas: a torus without uvs gets a one-to-one map") {
  TriangleMesh torus = test::torusMesh(0.5, 0.2, 32, 16);
  torus.uvs.clear();
  CHECK(checkAtlas(torus, 512).missing);
  const TriangleMesh atlas = generateAtlas(torus, 512);
  const AtlasCheck c = checkAtlas(atlas, 512);
  CHECK(c.oneToOne);
  CHECK(c.coveredTexels > 10000);
  // Same surface: the area and the volume do not change.
  CHECK(polyhedralMassProperties(atlas).volume == Approx(polyhedralMassProperties(torus).volume).epsilon(1e-5));
  CHECK(atlas.triangles.size() == torus.triangles.size());
}

TEST_CASE("automatic atlas repairs overlapping uvs (a tiled texture)") {
  TriangleMesh m = test::torusMesh(0.5, 0.2, 24, 12);
  for (size_t i = 0; i < m.uvs.size(); ++i) m.uvs[i] = glm::fract(m.uvs[i] * 4.0f);  // tiled 4x
  CHECK_FALSE(checkAtlas(m, 256).oneToOne);
  CHECK(checkAtlas(generateAtlas(m, 256), 256).oneToOne);
}
