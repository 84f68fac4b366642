// Silhouettes that show dents (RendererSettings::displace): a plate with a groove across it, seen nearly edge-on,
// has a straight far edge under POM alone and a notch of the groove's depth with displacement.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>

#include <crumple/deform/surface.h>
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
