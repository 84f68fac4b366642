#include <crumple/deform/cpu_reference.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <vector>

#include <crumple/deform/deformer.h>

namespace crumple::deform {

namespace {

float sampleBilinear(const gl::Image* img, glm::dvec2 uv) {
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
  bool front;  // faces the camera (+z in view space)
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

gl::Image referenceDeform(const ReferenceBody& x, const ReferenceBody& other, const glm::dvec3& point,
                              const glm::dvec3& n, double penetration, double depth) {
  gl::Image out = x.height ? *x.height : gl::Image(256, 256, 1, 0.5f);
  const int res = out.width;
  const gl::Image in = out;
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
  const double depthToHeight = range / x.bumpDepth;
  auto raise = [&](const ReferenceBody& b) {
    if (!b.height) return 0.0;
    float highest = 0.5f;
    for (int y = 0; y < b.height->height; ++y)
      for (int x0 = 0; x0 < b.height->width; ++x0) highest = std::max(highest, b.height->at(x0, y));
    return (double(highest) - 0.5) * b.bumpDepthCollide / range;
  };
  const double bound = depth / range + raise(x) + raise(other);
  // The camera's view rectangle in view space.
  const glm::dmat4 inv = glm::inverse(cam.projection);
  const glm::dvec2 vlo(inv * glm::dvec4(-1, -1, 0, 1)), vhi(inv * glm::dvec4(1, 1, 0, 1));
  const std::vector<ViewTriangle> tx = toView(x, modelX, cam.view);
  std::vector<ViewTriangle> to;
  for (const auto& t : toView(other, other.model, cam.view))
    if (!t.front) to.push_back(t);
  // The other body's back faces bucketed on a grid over the view rectangle.
  const int cells = 64;
  const glm::dvec2 cellSize = (vhi - vlo) / double(cells);
  auto cellOf = [&](glm::dvec2 p) {
    return glm::clamp(glm::ivec2(glm::floor((p - vlo) / cellSize)), glm::ivec2(0), glm::ivec2(cells - 1));
  };
  std::vector<std::vector<int>> grid(static_cast<size_t>(cells) * cells);
  for (size_t i = 0; i < to.size(); ++i) {
    if (to[i].hi.x < vlo.x || to[i].hi.y < vlo.y || to[i].lo.x > vhi.x || to[i].lo.y > vhi.y) continue;
    const glm::ivec2 a = cellOf(to[i].lo), b = cellOf(to[i].hi);
    for (int cy = a.y; cy <= b.y; ++cy)
      for (int cx = a.x; cx <= b.x; ++cx) grid[static_cast<size_t>(cy) * cells + cx].push_back(static_cast<int>(i));
  }
  auto windowDepth = [&](const ViewTriangle& t, const glm::dvec3& bc) {
    return (-(bc.x * t.p[0].z + bc.y * t.p[1].z + bc.z * t.p[2].z) - cam.zNear) / range;
  };
  for (const auto& t : tx) {
    if (!t.front || t.hi.x < vlo.x || t.hi.y < vlo.y || t.lo.x > vhi.x || t.lo.y > vhi.y) continue;
    const glm::dvec2 a = t.uv[0] * double(res), b = t.uv[1] * double(res), c = t.uv[2] * double(res);
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area == 0) continue;
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y, b.y, c.y})))),
              y1 = std::min(res - 1, static_cast<int>(std::floor(std::max({a.y, b.y, c.y}))));
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x, b.x, c.x})))),
              x1 = std::min(res - 1, static_cast<int>(std::floor(std::max({a.x, b.x, c.x}))));
    for (int ty = y0; ty <= y1; ++ty)
      for (int tx0 = x0; tx0 <= x1; ++tx0) {
        const glm::dvec2 q(tx0 + 0.5, ty + 0.5);
        const double w0 = ((b.x - q.x) * (c.y - q.y) - (b.y - q.y) * (c.x - q.x)) / area;
        const double w1 = ((c.x - q.x) * (a.y - q.y) - (c.y - q.y) * (a.x - q.x)) / area;
        const double w2 = 1 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const glm::dvec3 bc(w0, w1, w2);
        const glm::dvec3 p = w0 * t.p[0] + w1 * t.p[1] + w2 * t.p[2];
        if (p.x < vlo.x || p.y < vlo.y || p.x > vhi.x || p.y > vhi.y) continue;
        const float h = in.at(tx0, ty);
        const double z = std::clamp(windowDepth(t, bc) - (h - 0.5) * x.bumpDepthCollide / range, 0.0, 1.0);
        // The other body's farthest back face on the ray through p.
        double zB = -1;
        const glm::ivec2 cell = cellOf(glm::dvec2(p));
        for (int i : grid[static_cast<size_t>(cell.y) * cells + cell.x]) {
          glm::dvec3 obc;
          if (!hit(to[static_cast<size_t>(i)], p.x, p.y, obc)) continue;
          const ViewTriangle& o = to[static_cast<size_t>(i)];
          const double zw = windowDepth(o, obc);
          if (zw < 0 || zw > 1) continue;
          const glm::dvec2 uv = obc.x * o.uv[0] + obc.y * o.uv[1] + obc.z * o.uv[2];
          zB = std::max(
              zB, std::clamp(zw + (sampleBilinear(other.height, uv) - 0.5) * other.bumpDepthCollide / range, 0.0, 1.0));
        }
        // X advanced by `depth` into the other: an overlap beyond it and the bumps' reach was there before the
        // push, not this event's (DeformRequest::boundByDepth).
        const double dD = std::min(zB - z, bound);
        if (!(dD > 0)) continue;
        const float h2 = static_cast<float>(std::clamp(h - dD * depthToHeight, 0.0, 1.0));
        out.at(tx0, ty) = std::min(out.at(tx0, ty), h2);
      }
  }
  return out;
}

}  // namespace crumple::deform
