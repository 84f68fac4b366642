// Silhouettes that show dents (RendererSettings::displace): a plate with a groove across it, seen nearly edge-on,
// has a straight far edge under POM alone and a notch of the groove's depth with displacement.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>

#include <crumple/deform/surface.h>
#include <crumple/engine/primitives.h>
#include "gl_fixture.h"
#include <crumple/render/renderer.h>

using namespace crumple;
using namespace crumple::gl;
using namespace crumple::render;

namespace {

// A 2 x 2 m quad on y = 0, two triangles, uv (x + 1) / 2, (z + 1) / 2.
TriangleMesh quad() {
  TriangleMesh m;
  for (int k = 0; k < 4; ++k) {
    const float x = (k == 1 || k == 2) ? 1.0f : -1.0f, z = k >= 2 ? 1.0f : -1.0f;
    m.positions.push_back({x, 0, z});
    m.normals.push_back({0, 1, 0});
    m.uvs.push_back({0.5f * (x + 1), 0.5f * (z + 1)});
  }
  m.triangles = {{0, 2, 1}, {0, 3, 2}};
  return m;
}

// The image row (0 at the top) where world point p lands.
float rowOf(const View& v, int w, int h, glm::vec3 p) {
  const glm::mat4 vp = glm::perspective(glm::radians(v.fovDegrees), float(w) / float(h), v.zNear, v.zFar) *
                       glm::lookAt(v.eye, v.target, v.up);
  const glm::vec4 c = vp * glm::vec4(p, 1);
  return (0.5f - 0.5f * c.y / c.w) * h;
}

// The first row from the top, in column x, that differs from the empty frame.
int topCovered(const Image& img, const Image& empty, int x) {
  for (int y = 0; y < img.height; ++y) {
    float d = 0;
    for (int c = 0; c < 3; ++c) d += std::abs(img.at(x, y, c) - empty.at(x, y, c));
    if (d > 0.15f) return y;
  }
  return img.height;
}

}  // namespace

TEST_CASE("displacement: a groove across a plate notches its silhouette by the groove's depth") {
  test::glContext();
  const TriangleMesh mesh = quad();
  deform::GpuMesh gpu(mesh);
  // Height map: 0.5 (flat) except a groove, h = 0 for u in [0.4, 0.6], all v: (0 - 0.5) k deep.
  const int n = 128;
  const float k = 0.3f;
  std::vector<float> heights(static_cast<size_t>(n) * n, 0.5f);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      if ((x + 0.5f) / n >= 0.4f && (x + 0.5f) / n <= 0.6f) heights[static_cast<size_t>(y) * n + x] = 0.0f;
  Texture2D height(n, n, GL_R32F), normal(n, n, GL_RGBA8);
  height.upload(GL_RED, GL_FLOAT, heights.data());
  height.setFilter(GL_LINEAR, GL_LINEAR);
  height.setWrap(GL_CLAMP_TO_EDGE);
  std::vector<unsigned char> flat(static_cast<size_t>(n) * n * 4);
  for (size_t i = 0; i < flat.size(); i += 4) flat[i] = 128, flat[i + 1] = 128, flat[i + 2] = 255, flat[i + 3] = 255;
  normal.upload(GL_RGBA, GL_UNSIGNED_BYTE, flat.data());

  RenderItem it;
  it.vao = gpu.vao.id();
  it.indexCount = gpu.indexCount;
  it.height = height.id();
  it.normal = normal.id();
  it.bumpDepth = k;
  it.color = {0.8f, 0.3f, 0.2f};
  it.boundsMin = {-1, -0.2f, -1};
  it.boundsMax = {1, 0.2f, 1};

  View view;
  view.eye = {0.0f, 0.45f, 3.2f};
  view.target = {0.0f, 0.0f, -1.0f};
  view.fovDegrees = 30;
  const int w = 240, h = 160;
  Renderer r(w, h);
  r.settings().shadows = false;
  r.draw({}, view);
  const Image empty = r.readPixels();
  r.draw({it}, view);
  const Image pom = r.readPixels();
  r.settings().displace = true;
  r.draw({it}, view);
  const Image displaced = r.readPixels();
  r.savePng((std::filesystem::temp_directory_path() / "crumple-displace-groove.png").string());

  const int centre = w / 2;                                      // x = 0: the groove's middle
  const int side = static_cast<int>(w * 0.5f + 0.25f * w * 0.5f);  // well outside the groove
  const float edge = rowOf(view, w, h, {0, 0, -1});
  const float notch = rowOf(view, w, h, {0, -0.5f * k, -1});
  MESSAGE("far edge predicted at row " << edge << ", the groove's floor there at row " << notch);
  MESSAGE("POM alone: rows " << topCovered(pom, empty, centre) << " (groove) and " << topCovered(pom, empty, side));
  MESSAGE("displaced: rows " << topCovered(displaced, empty, centre) << " (groove) and "
                             << topCovered(displaced, empty, side));
  REQUIRE(notch - edge > 8.0f);  // the notch is worth measuring
  // POM alone: the silhouette is the flat quad's far edge, groove or not.
  CHECK(std::abs(topCovered(pom, empty, centre) - edge) <= 1.5f);
  CHECK(std::abs(topCovered(pom, empty, side) - edge) <= 1.5f);
  // Displaced: the edge drops by the groove's depth in the groove, stays outside it.
  CHECK(std::abs(topCovered(displaced, empty, centre) - notch) <= 1.5f);
  CHECK(std::abs(topCovered(displaced, empty, side) - edge) <= 1.5f);
}

TEST_CASE("seam tables: a box's face edges know the next face's uvs, its corners and edge points the others'") {
  test::glContext();
  const TriangleMesh mesh = boxMesh({1, 1, 1}, 256);
  deform::GpuMesh gpu(mesh);
  std::vector<glm::vec4> edges(mesh.triangles.size() * 3), shared(mesh.positions.size() * 2);
  glGetNamedBufferSubData(gpu.seamEdges.id(), 0, static_cast<GLsizeiptr>(edges.size() * sizeof(glm::vec4)), edges.data());
  glGetNamedBufferSubData(gpu.seamVertices.id(), 0, static_cast<GLsizeiptr>(shared.size() * sizeof(glm::vec4)),
                          shared.data());
  // The vertex at a position with a uv (the box's vertices are unique by the two together).
  auto vertexAt = [&](glm::vec3 p, glm::vec2 uv) {
    for (size_t i = 0; i < mesh.positions.size(); ++i)
      if (mesh.positions[i] == p && mesh.uvs[i] == uv) return static_cast<int>(i);
    return -1;
  };
  int twins = 0;
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int e = 0; e < 3; ++e) {
      const glm::vec4 twin = edges[t * 3 + static_cast<size_t>(e)];
      if (twin.x < 0) continue;
      ++twins;
      // The twin's uvs are another chart's vertices at this edge's two ends.
      const uint32_t a = mesh.triangles[t][(e + 1) % 3], b = mesh.triangles[t][(e + 2) % 3];
      CHECK(vertexAt(mesh.positions[a], glm::vec2(twin.x, twin.y)) >= 0);
      CHECK(vertexAt(mesh.positions[b], glm::vec2(twin.z, twin.w)) >= 0);
      CHECK(glm::vec2(twin.x, twin.y) != mesh.uvs[a]);
    }
  // 6 faces of 4 x 4 quads: 16 triangle edges along each face's border, each with its twin; none inside a face.
  CHECK(twins == 6 * 16);
  int corners = 0, edgePoints = 0;
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const int others = static_cast<int>(shared[2 * i + 1].z);
    corners += others == 2;
    edgePoints += others == 1;
    if (others >= 1) CHECK(vertexAt(mesh.positions[i], glm::vec2(shared[2 * i].x, shared[2 * i].y)) >= 0);
  }
  CHECK(corners == 8 * 3);      // three faces at each of the 8 corners
  CHECK(edgePoints == 12 * 3 * 2);  // two faces along each of the 12 edges, 3 points inside each
}
