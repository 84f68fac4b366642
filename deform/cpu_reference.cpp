#include "deform/cpu_reference.h"

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <vector>

#include "deform/deformer.h"

namespace crumple::deform {

namespace {

float sampleBilinear(const render::Image* img, glm::dvec2 uv) {
  if (!img) return 0.5f;
  const double x = uv.x * img->width - 0.5, y = uv.y * img->height - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  auto at = [&](int xi, int yi) {
    return static_cast<double>(img->at(std::clamp(xi, 0, img->width - 1), std::clamp(yi, 0, img->height - 1)));
  };
  return static_cast<float>((at(x0, y0) * (1 - fx) + at(x0 + 1, y0) * fx) * (1 - fy) +
                            (at(x0, y0 + 1) * (1 - fx) + at(x0 + 1, y0 + 1) * fx) * fy);
}

struct ViewTriangle {
  glm::dvec3 p[3];  // view space
  glm::dvec2 uv[3];
  bool front;       // faces the camera (+z in view space)
  glm::dvec2 lo, hi;
};

std::vector<ViewTriangle> toView(const ReferenceBody& b, const glm::dmat4& model, const glm::dmat4& view) {
  std::vector<ViewTriangle> out;
  const glm::dmat4 mv = view * model;
  for (const auto& t : b.mesh->triangles) {
    ViewTriangle v;
    const unsigned idx[3] = {t.x, t.y, t.z};
    for (int k = 0; k < 3; ++k) {
      v.p[k] = glm::dvec3(mv * glm::dvec4(glm::dvec3(b.mesh->positions[idx[k]]), 1));
      v.uv[k] = glm::dvec2(b.mesh->uvs[idx[k]]);
    }
    const double z = (v.p[1].x - v.p[0].x) * (v.p[2].y - v.p[0].y) - (v.p[1].y - v.p[0].y) * (v.p[2].x - v.p[0].x);
    if (z == 0) continue;
    v.front = z > 0;
    v.lo = glm::min(glm::dvec2(v.p[0]), glm::min(glm::dvec2(v.p[1]), glm::dvec2(v.p[2])));
    v.hi = glm::max(glm::dvec2(v.p[0]), glm::max(glm::dvec2(v.p[1]), glm::dvec2(v.p[2])));
    out.push_back(v);
  }
  return out;
}

// Ray along -z through (x, y): barycentrics if inside.
bool hit(const ViewTriangle& t, double x, double y, glm::dvec3& bc) {
  if (x < t.lo.x || x > t.hi.x || y < t.lo.y || y > t.hi.y) return false;
  const glm::dvec2 a(t.p[0]), b(t.p[1]), c(t.p[2]);
  const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
  const double w0 = ((b.x - x) * (c.y - y) - (b.y - y) * (c.x - x)) / area;
  const double w1 = ((c.x - x) * (a.y - y) - (c.y - y) * (a.x - x)) / area;
  const double w2 = 1 - w0 - w1;
  if (w0 < 0 || w1 < 0 || w2 < 0) return false;
  bc = {w0, w1, w2};
  return true;
}

}  // namespace

render::Image referenceDeform(const ReferenceBody& x, const ReferenceBody& other, const glm::dvec3& point,
                              const glm::dvec3& n, double penetration, double depth, int size) {
  render::Image out = x.height ? *x.height : render::Image(256, 256, 1, 0.5f);
  const int res = out.width;
  const render::Image in = out;
  const glm::dmat4 modelX = glm::translate(glm::dmat4(1), n * (depth - penetration)) * x.model;
  // Bounds exactly as the GPU path computes them, from the mesh bounds.
  auto bounds = [](const TriangleMesh& m, const glm::dmat4& model, glm::dvec3 b[2]) {
    b[0] = glm::dvec3(1e300);
    b[1] = glm::dvec3(-1e300);
    const glm::vec3 lo = m.boundsMin(), hi = m.boundsMax();
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 p(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z);
      const glm::dvec3 w = glm::dvec3(model * glm::dvec4(p, 1));
      b[0] = glm::min(b[0], w);
      b[1] = glm::max(b[1], w);
    }
  };
  glm::dvec3 bx[2], bo[2];
  bounds(*x.mesh, modelX, bx);
  bounds(*other.mesh, other.model, bo);
  const AddressCamera cam = addressCamera(point, n, bx, bo);
  const double range = cam.zFar - cam.zNear;
  const std::vector<ViewTriangle> tx = toView(x, modelX, cam.view), to = toView(other, other.model, cam.view);
  // Pixel centres in view space: the projection maps [cx - h, cx + h] to the viewport.
  const glm::dmat4 inv = glm::inverse(cam.projection);
  const double depthToHeight = range / x.bumpDepth;
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const glm::dvec4 ndc((i + 0.5) / size * 2 - 1, (j + 0.5) / size * 2 - 1, 0, 1);
      const glm::dvec4 v = inv * ndc;
      const double px = v.x, py = v.y;
      // Pass A: nearest front face of X.
      double zA = 2;
      glm::dvec2 uvA(-1);
      for (const auto& t : tx) {
        glm::dvec3 bc;
        if (!t.front || !hit(t, px, py, bc)) continue;
        const double d = -(bc.x * t.p[0].z + bc.y * t.p[1].z + bc.z * t.p[2].z);
        const double zw = (d - cam.zNear) / range;
        if (zw < 0 || zw > 1) continue;
        const glm::dvec2 uv = bc.x * t.uv[0] + bc.y * t.uv[1] + bc.z * t.uv[2];
        const double z = std::clamp(zw - (sampleBilinear(x.height, uv) - 0.5) * x.bumpDepthCollide / range, 0.0, 1.0);
        if (z < zA) {
          zA = z;
          uvA = uv;
        }
      }
      if (uvA.x < 0) continue;
      // Pass B: the farthest back face of the other body behind X's depth.
      double zB = zA;
      bool any = false;
      for (const auto& t : to) {
        glm::dvec3 bc;
        if (t.front || !hit(t, px, py, bc)) continue;
        const double d = -(bc.x * t.p[0].z + bc.y * t.p[1].z + bc.z * t.p[2].z);
        const double zw = (d - cam.zNear) / range;
        if (zw < 0 || zw > 1) continue;
        const glm::dvec2 uv = bc.x * t.uv[0] + bc.y * t.uv[1] + bc.z * t.uv[2];
        const double z = std::clamp(zw + (sampleBilinear(other.height, uv) - 0.5) * other.bumpDepthCollide / range, 0.0, 1.0);
        if (z > zB) {
          zB = z;
          any = true;
        }
      }
      if (!any) continue;
      const double dD = zB - zA;
      const int tx0 = std::clamp(static_cast<int>(std::floor(uvA.x * res)), 0, res - 1);
      const int ty0 = std::clamp(static_cast<int>(std::floor(uvA.y * res)), 0, res - 1);
      const float h2 = static_cast<float>(std::clamp(in.at(tx0, ty0) - dD * depthToHeight, 0.0, 1.0));
      out.at(tx0, ty0) = std::min(out.at(tx0, ty0), h2);
    }
  }
  return out;
}

}  // namespace crumple::deform
