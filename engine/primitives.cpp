#include <crumple/engine/primitives.h>

#include <cmath>
#include <glm/gtc/constants.hpp>

#include <crumple/engine/atlas.h>

namespace crumple {

namespace {

// A quad of the grid (i, j) -> corner; adds two triangles, counter-clockwise seen from outside.
template <typename Corner>
void addQuad(ChartMesh& cm, int chart, Corner corner, int i, int j, bool flip = false) {
  glm::vec3 p[4], n[4];
  glm::vec2 uv[4];
  corner(i, j, p[0], n[0], uv[0]);
  corner(i + 1, j, p[1], n[1], uv[1]);
  corner(i + 1, j + 1, p[2], n[2], uv[2]);
  corner(i, j + 1, p[3], n[3], uv[3]);
  if (flip) {
    std::swap(p[1], p[3]);
    std::swap(n[1], n[3]);
    std::swap(uv[1], uv[3]);
  }
  const glm::vec3 pa[3] = {p[0], p[1], p[2]}, na[3] = {n[0], n[1], n[2]};
  const glm::vec2 ua[3] = {uv[0], uv[1], uv[2]};
  const glm::vec3 pb[3] = {p[0], p[2], p[3]}, nb[3] = {n[0], n[2], n[3]};
  const glm::vec2 ub[3] = {uv[0], uv[2], uv[3]};
  cm.addTriangle(chart, pa, na, ua);
  cm.addTriangle(chart, pb, nb, ub);
}

// Rings of quads from an outer edge (j = 0) inwards, the last ring a fan of
// triangles to the centre (discs and hemispherical caps).
template <typename Corner>
void addRings(ChartMesh& cm, int chart, Corner corner, int segments, int rings) {
  for (int j = 0; j < rings; ++j)
    for (int i = 0; i < segments; ++i) {
      if (j < rings - 1) {
        addQuad(cm, chart, corner, i, j);
        continue;
      }
      glm::vec3 p[3], nn[3];
      glm::vec2 uv[3];
      corner(i, j, p[0], nn[0], uv[0]);
      corner(i + 1, j, p[1], nn[1], uv[1]);
      corner(i, j + 1, p[2], nn[2], uv[2]);
      cm.addTriangle(chart, p, nn, uv);
    }
}

// Face basis of the cube: normal, u axis, v axis (u x v = normal).
void cubeFace(int f, glm::vec3& n, glm::vec3& u, glm::vec3& v) {
  const int axis = f / 2;
  const float s = f % 2 ? -1.f : 1.f;
  n = glm::vec3(0);
  n[axis] = s;
  u = glm::vec3(0);
  u[(axis + 1) % 3] = 1;
  v = glm::cross(n, u);
}

}  // namespace

TriangleMesh boxMesh(const glm::dvec3& size, int resolution) {
  ChartMesh cm;
  const glm::vec3 h = glm::vec3(size) * 0.5f;
  const int cells = 4;  // a few quads per face, so that vertex lighting and the renderer's tessellation behave
  for (int f = 0; f < 6; ++f) {
    glm::vec3 n, u, v;
    cubeFace(f, n, u, v);
    const float hu = glm::dot(glm::abs(u), h), hv = glm::dot(glm::abs(v), h), hn = glm::dot(glm::abs(n), h);
    auto corner = [&](int i, int j, glm::vec3& p, glm::vec3& nn, glm::vec2& uv) {
      const float a = -hu + 2 * hu * i / cells, b = -hv + 2 * hv * j / cells;
      p = n * hn + u * a + v * b;
      nn = n;
      uv = glm::vec2(a, b);
    };
    for (int j = 0; j < cells; ++j)
      for (int i = 0; i < cells; ++i) addQuad(cm, f, corner, i, j);
  }
  TriangleMesh m = packCharts(cm, resolution);
  return m;
}

TriangleMesh sphereMesh(double radius, int resolution, int segments) {
  ChartMesh cm;
  const float r = static_cast<float>(radius);
  const float q = glm::quarter_pi<float>();
  for (int f = 0; f < 6; ++f) {
    glm::vec3 n, u, v;
    cubeFace(f, n, u, v);
    // Equi-angular cube map: angles a, b in [-pi/4, pi/4] spread texels evenly.
    auto corner = [&](int i, int j, glm::vec3& p, glm::vec3& nn, glm::vec2& uv) {
      const float a = -q + 2 * q * i / segments, b = -q + 2 * q * j / segments;
      nn = glm::normalize(n + u * std::tan(a) + v * std::tan(b));
      p = nn * r;
      uv = glm::vec2(a, b) * r;
    };
    for (int j = 0; j < segments; ++j)
      for (int i = 0; i < segments; ++i) addQuad(cm, f, corner, i, j);
  }
  return packCharts(cm, resolution);
}

namespace {
void addTube(ChartMesh& cm, int chart, float r, float y0, float y1, int segments, int rows) {
  const float twoPi = glm::two_pi<float>();
  auto corner = [&](int i, int j, glm::vec3& p, glm::vec3& nn, glm::vec2& uv) {
    const float a = twoPi * i / segments;
    const float y = y0 + (y1 - y0) * j / rows;
    // Counter-clockwise from outside: angle grows clockwise seen from +y.
    nn = glm::vec3(std::cos(a), 0, -std::sin(a));
    p = glm::vec3(nn.x * r, y, nn.z * r);
    uv = glm::vec2(a * r, y);
  };
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < segments; ++i) addQuad(cm, chart, corner, i, j);
}
void addDisc(ChartMesh& cm, int chart, float r, float y, bool up, int segments) {
  const glm::vec3 n(0, up ? 1 : -1, 0);
  const float twoPi = glm::two_pi<float>();
  const int rings = 4;
  auto corner = [&](int i, int j, glm::vec3& p, glm::vec3& nn, glm::vec2& uv) {
    const float a = twoPi * i / segments * (up ? -1.f : 1.f);
    const float rr = r * (rings - j) / rings;
    p = glm::vec3(rr * std::cos(a), y, rr * std::sin(a));
    nn = n;
    uv = glm::vec2(p.x, up ? -p.z : p.z);
  };
  addRings(cm, chart, corner, segments, rings);
}
// A hemisphere cap at height yc, pointing up or down, by azimuthal equidistant projection.
void addCap(ChartMesh& cm, int chart, float r, float yc, bool up, int segments, int rings) {
  const float twoPi = glm::two_pi<float>(), halfPi = glm::half_pi<float>();
  auto corner = [&](int i, int j, glm::vec3& p, glm::vec3& nn, glm::vec2& uv) {
    const float a = twoPi * i / segments * (up ? 1.f : -1.f);
    const float polar = halfPi * (rings - j) / rings;  // from the pole; j = 0 at the equator
    const float s = std::sin(polar), c = std::cos(polar);
    nn = glm::vec3(s * std::cos(a), up ? c : -c, -s * std::sin(a));
    p = nn * r + glm::vec3(0, yc, 0);
    uv = glm::vec2(std::cos(a), std::sin(a)) * (polar * r);
    if (!up) uv.y = -uv.y;
  };
  addRings(cm, chart, corner, segments, rings);  // the mirrored angle keeps the lower cap outward too
}
}  // namespace

namespace {
// Rows of a tube: one per half radius along it, at most 1024 (a tube 10^8 radii long would take gigabytes).
int tubeRows(double radius, double height) {
  return std::max(1, static_cast<int>(std::ceil(std::min(height / (radius * 0.5), 1024.0))));
}
}  // namespace

TriangleMesh cylinderMesh(double radius, double height, int resolution, int segments) {
  ChartMesh cm;
  const float r = static_cast<float>(radius), hh = static_cast<float>(height / 2);
  addTube(cm, 0, r, -hh, hh, segments, tubeRows(radius, height));
  addDisc(cm, 1, r, hh, true, segments);
  addDisc(cm, 2, r, -hh, false, segments);
  return packCharts(cm, resolution);
}

TriangleMesh capsuleMesh(double radius, double height, int resolution, int segments, int rings) {
  ChartMesh cm;
  const float r = static_cast<float>(radius), hh = static_cast<float>(height / 2);
  if (height > 0)
    addTube(cm, 0, r, -hh, hh, segments, tubeRows(radius, height));
  addCap(cm, 1, r, hh, true, segments, rings);
  addCap(cm, 2, r, -hh, false, segments, rings);
  return packCharts(cm, resolution);
}

}  // namespace crumple
