// TexelCover (passes.h): the compute gather's tiles of a mesh's texels and the triangles that reach each.
#include <algorithm>
#include <cmath>

#include <crumple/deform/passes.h>

namespace crumple::deform {

namespace {
constexpr int kFloats = 17;  // GpuMesh's floats a vertex: position 0-2, uv 6-7

// Whether the triangle (texel coordinates) overlaps the rectangle [lo, hi] grown by half a texel: separating
// axes, the rectangle's and the triangle's edge normals (texel.geom grows a triangle by half a texel's extent
// along each edge normal).
bool overlaps(const glm::dvec2 t[3], glm::dvec2 lo, glm::dvec2 hi) {
  lo -= 0.5;
  hi += 0.5;
  const glm::dvec2 tlo = glm::min(glm::min(t[0], t[1]), t[2]), thi = glm::max(glm::max(t[0], t[1]), t[2]);
  if (thi.x < lo.x || thi.y < lo.y || tlo.x > hi.x || tlo.y > hi.y) return false;
  const double orient = (t[1].x - t[0].x) * (t[2].y - t[0].y) - (t[1].y - t[0].y) * (t[2].x - t[0].x) > 0 ? 1 : -1;
  for (int e = 0; e < 3; ++e) {
    const glm::dvec2 a = t[e], b = t[(e + 1) % 3];
    const glm::dvec2 n = orient * glm::dvec2(b.y - a.y, a.x - b.x);  // outward
    // The rectangle's corner farthest inside: all of it beyond the edge means no overlap.
    const glm::dvec2 c(n.x > 0 ? lo.x : hi.x, n.y > 0 ? lo.y : hi.y);
    if (glm::dot(n, c - a) > 1e-9 * (std::abs(n.x) + std::abs(n.y))) return false;
  }
  return true;
}
// The box of the triangle's surface points (p[], texel coordinates t[]) whose texel coordinates lie in [lo, hi]:
// the triangle clipped to the rectangle (Sutherland-Hodgman), its corners mapped back by the triangle's affine map.
void clippedBox(const glm::dvec2 t[3], const glm::dvec3 p[3], glm::dvec2 lo, glm::dvec2 hi, glm::dvec3& bmin,
                glm::dvec3& bmax) {
  std::vector<glm::dvec2> poly(t, t + 3), next;
  for (int plane = 0; plane < 4 && !poly.empty(); ++plane) {
    const int axis = plane / 2;
    const double limit = plane % 2 == 0 ? lo[axis] : hi[axis], s = plane % 2 == 0 ? -1 : 1;  // keep s * (x - limit) <= 0
    next.clear();
    for (size_t i = 0; i < poly.size(); ++i) {
      const glm::dvec2 a = poly[i], b = poly[(i + 1) % poly.size()];
      const double da = s * (a[axis] - limit), db = s * (b[axis] - limit);
      if (da <= 0) next.push_back(a);
      if ((da <= 0) != (db <= 0)) next.push_back(a + (b - a) * (da / (da - db)));
    }
    poly.swap(next);
  }
  const double area = (t[1].x - t[0].x) * (t[2].y - t[0].y) - (t[1].y - t[0].y) * (t[2].x - t[0].x);
  for (const glm::dvec2& q : poly) {
    const double w1 = ((q.x - t[0].x) * (t[2].y - t[0].y) - (q.y - t[0].y) * (t[2].x - t[0].x)) / area;
    const double w2 = ((t[1].x - t[0].x) * (q.y - t[0].y) - (t[1].y - t[0].y) * (q.x - t[0].x)) / area;
    const glm::dvec3 w = (1 - w1 - w2) * p[0] + w1 * p[1] + w2 * p[2];
    bmin = glm::min(bmin, w);
    bmax = glm::max(bmax, w);
  }
}

// Triangle `tri`'s corners from the read-back vertices: positions (shape frame) and uvs in texels at `resolution`;
// returns twice its area in texels.
double cornersOf(const std::vector<float>& v, const std::vector<GLuint>& idx, size_t tri, double resolution,
                 glm::dvec3 p[3], glm::dvec2 t[3]) {
  for (int c = 0; c < 3; ++c) {
    const size_t at = static_cast<size_t>(idx[tri * 3 + static_cast<size_t>(c)]) * kFloats;
    p[c] = glm::dvec3(v[at], v[at + 1], v[at + 2]);
    t[c] = glm::dvec2(v[at + 6], v[at + 7]) * resolution;
  }
  return std::abs((t[1].x - t[0].x) * (t[2].y - t[0].y) - (t[1].y - t[0].y) * (t[2].x - t[0].x));
}

// The mesh's vertices (kFloats a vertex) and indices, read back.
void readMesh(const GpuMesh& mesh, std::vector<float>& v, std::vector<GLuint>& idx) {
  v.resize(mesh.vertices.size() / sizeof(float));
  idx.resize(static_cast<size_t>(mesh.indexCount));
  glGetNamedBufferSubData(mesh.vertices.id(), 0, static_cast<GLsizeiptr>(v.size() * sizeof(float)), v.data());
  glGetNamedBufferSubData(mesh.indices.id(), 0, static_cast<GLsizeiptr>(idx.size() * sizeof(GLuint)), idx.data());
}
}  // namespace

std::shared_ptr<const TexelCover> TexelCover::of(const GpuMesh& mesh, int resolution) {
  auto found = mesh.texelCovers.find(resolution);
  if (found != mesh.texelCovers.end()) return found->second;
  std::vector<float> v;
  std::vector<GLuint> idx;
  readMesh(mesh, v, idx);
  auto cover = std::make_shared<TexelCover>();
  cover->resolution = resolution;
  cover->tilesX = (resolution + kTile - 1) / kTile;
  const size_t tiles = cover->tiles();
  std::vector<std::vector<GLuint>> lists(tiles);
  std::vector<glm::vec4> boxes(2 * tiles);
  for (size_t k = 0; k < tiles; ++k) {
    boxes[2 * k] = glm::vec4(1e30f, 1e30f, 1e30f, 0);
    boxes[2 * k + 1] = glm::vec4(-1e30f, -1e30f, -1e30f, 0);
  }
  const double res = resolution;
  for (size_t tri = 0; tri * 3 + 2 < idx.size(); ++tri) {
    glm::dvec2 t[3];
    glm::dvec3 p[3];
    const double area = cornersOf(v, idx, tri, res, p, t);
    if (area < 1e-12) continue;  // texel.geom draws none either
    // A texel's size on this triangle's surface: texels up to half a texel past it extrapolate within this much.
    const double metres = glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
    const double grow = std::sqrt(metres / area) * 1.5;
    const glm::dvec2 tlo = glm::min(glm::min(t[0], t[1]), t[2]) - 0.5, thi = glm::max(glm::max(t[0], t[1]), t[2]) + 0.5;
    const int x0 = std::max(0, static_cast<int>(std::floor(tlo.x)) / kTile);
    const int y0 = std::max(0, static_cast<int>(std::floor(tlo.y)) / kTile);
    const int x1 = std::min(cover->tilesX - 1, static_cast<int>(std::floor(thi.x)) / kTile);
    const int y1 = std::min(cover->tilesX - 1, static_cast<int>(std::floor(thi.y)) / kTile);
    for (int ty = y0; ty <= y1; ++ty)
      for (int tx = x0; tx <= x1; ++tx) {
        // The tile's texel centres: [k * kTile + 0.5, (k + 1) * kTile - 0.5].
        const glm::dvec2 lo(tx * kTile + 0.5, ty * kTile + 0.5), hi(tx * kTile + kTile - 0.5, ty * kTile + kTile - 0.5);
        if (!overlaps(t, lo, hi)) continue;
        const size_t k = static_cast<size_t>(ty) * static_cast<size_t>(cover->tilesX) + static_cast<size_t>(tx);
        lists[k].push_back(static_cast<GLuint>(tri));
        // The part of the triangle over the tile's texels (their squares, a texel more for the conservative
        // reach), its surface points grown by a texel and a half on the surface (points extrapolated past it).
        glm::dvec3 bmin(1e300), bmax(-1e300);
        clippedBox(t, p, lo - 1.5, hi + 1.5, bmin, bmax);
        if (bmin.x > bmax.x) continue;
        boxes[2 * k] = glm::vec4(glm::min(glm::vec3(boxes[2 * k]), glm::vec3(bmin - grow)), 0);
        boxes[2 * k + 1] = glm::vec4(glm::max(glm::vec3(boxes[2 * k + 1]), glm::vec3(bmax + grow)), 0);
      }
  }
  std::vector<GLuint> start(tiles + 1, 0), all;
  for (size_t k = 0; k < tiles; ++k) {
    start[k] = static_cast<GLuint>(all.size());
    all.insert(all.end(), lists[k].begin(), lists[k].end());
  }
  start[tiles] = static_cast<GLuint>(all.size());
  if (all.empty()) all.push_back(0);
  cover->start = gl::Buffer::fromVector(start);
  cover->triangles = gl::Buffer::fromVector(all);
  cover->boxes = gl::Buffer::fromVector(boxes);
  cover->listed = start[tiles];
  mesh.texelCovers[resolution] = cover;
  return cover;
}

std::shared_ptr<const ChartCover> ChartCover::of(const GpuMesh& mesh, int resolution) {
  auto found = mesh.chartCovers.find(resolution);
  if (found != mesh.chartCovers.end()) return found->second;
  std::vector<float> v;
  std::vector<GLuint> idx;
  readMesh(mesh, v, idx);
  const size_t r = static_cast<size_t>(resolution);
  std::vector<float> level(r * r, 0.0f);
  for (size_t tri = 0; tri * 3 + 2 < idx.size(); ++tri) {
    glm::dvec2 t[3];
    glm::dvec3 p[3];
    if (cornersOf(v, idx, tri, static_cast<double>(resolution), p, t) < 1e-12) continue;  // (the gather draws none)
    const glm::dvec2 tlo = glm::min(glm::min(t[0], t[1]), t[2]) - 0.5, thi = glm::max(glm::max(t[0], t[1]), t[2]) + 0.5;
    const int x0 = std::max(0, static_cast<int>(std::floor(tlo.x))),
              y0 = std::max(0, static_cast<int>(std::floor(tlo.y)));
    const int x1 = std::min(resolution - 1, static_cast<int>(std::floor(thi.x)));
    const int y1 = std::min(resolution - 1, static_cast<int>(std::floor(thi.y)));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        float& c = level[static_cast<size_t>(y) * r + static_cast<size_t>(x)];
        if (c == 0.0f && overlaps(t, glm::dvec2(x + 0.5, y + 0.5), glm::dvec2(x + 0.5, y + 0.5))) c = 1.0f;
      }
  }
  auto cover = std::make_shared<ChartCover>();
  for (float c : level) cover->covered += c > 0 ? 1 : 0;
  // Each level above: its texel's children's mean (level sizes as GL's: max(1, size >> 1)).
  std::vector<float> all;
  size_t w = r;
  for (;;) {
    cover->offsets.push_back(static_cast<GLuint>(all.size()));
    all.insert(all.end(), level.begin(), level.end());
    if (w == 1) break;
    const size_t up = std::max<size_t>(1, w / 2);
    std::vector<float> next(up * up, 0.0f);
    for (size_t y = 0; y < up; ++y)
      for (size_t x = 0; x < up; ++x) {
        double sum = 0;
        int n = 0;
        for (size_t j = 2 * y; j < std::min(w, 2 * y + 2); ++j)
          for (size_t i = 2 * x; i < std::min(w, 2 * x + 2); ++i, ++n) sum += level[j * w + i];
        next[y * up + x] = static_cast<float>(sum / n);
      }
    level.swap(next);
    w = up;
  }
  cover->cover = gl::Buffer::fromVector(all);
  mesh.chartCovers[resolution] = cover;
  return cover;
}

}  // namespace crumple::deform
