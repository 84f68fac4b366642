#include <crumple/engine/atlas.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <limits>
#include <tuple>

namespace crumple {

void ChartMesh::addTriangle(int chartId, const glm::vec3 p[3], const glm::vec3 n[3], const glm::vec2 uv[3],
                            const glm::vec3* color, const glm::vec2* materialUv, const int* materialId) {
  for (int k = 0; k < 3; ++k) {
    positions.push_back(p[k]);
    normals.push_back(n[k]);
    chartUV.push_back(uv[k]);
    if (color) colors.push_back(color[k]);
    if (materialUv && materialId) {
      materialUvs.push_back(materialUv[k]);
      materialIds.push_back(materialId[k]);
    }
  }
  chart.push_back(chartId);
}

namespace {

struct Rect {
  int chart;
  glm::vec2 lo, size;  // chart bounds in metres
  bool rotated = false;
  glm::vec2 at{0};  // packed position (uv) of the lower-left corner
};

// Shelf packing at `scale` (uv per metre); returns false if it does not fit.
bool shelfPack(std::vector<Rect>& rects, double scale, double gutter) {
  double x = gutter, y = gutter, shelf = 0;
  for (Rect& r : rects) {
    const double w = (r.rotated ? r.size.y : r.size.x) * scale, h = (r.rotated ? r.size.x : r.size.y) * scale;
    if (w + 2 * gutter > 1 || h + 2 * gutter > 1) return false;
    if (x + w + gutter > 1) {
      x = gutter;
      y += shelf + gutter;
      shelf = 0;
    }
    if (y + h + gutter > 1) return false;
    r.at = glm::vec2(static_cast<float>(x), static_cast<float>(y));
    x += w + gutter;
    shelf = std::max(shelf, h);
  }
  return true;
}

}  // namespace

TriangleMesh packCharts(const ChartMesh& cm, int resolution, int gutterTexels) {
  const int nCharts = cm.chart.empty() ? 0 : *std::max_element(cm.chart.begin(), cm.chart.end()) + 1;
  std::vector<Rect> rects(static_cast<size_t>(nCharts));
  std::vector<glm::vec2> lo(static_cast<size_t>(nCharts), glm::vec2(1e30f)),
      hi(static_cast<size_t>(nCharts), glm::vec2(-1e30f));
  for (size_t t = 0; t < cm.chart.size(); ++t) {
    const auto c = static_cast<size_t>(cm.chart[t]);
    for (int k = 0; k < 3; ++k) {
      lo[c] = glm::min(lo[c], cm.chartUV[t * 3 + k]);
      hi[c] = glm::max(hi[c], cm.chartUV[t * 3 + k]);
    }
  }
  double area = 0;
  for (int c = 0; c < nCharts; ++c) {
    Rect& r = rects[static_cast<size_t>(c)];
    r.chart = c;
    r.lo = lo[static_cast<size_t>(c)];
    r.size = glm::max(hi[static_cast<size_t>(c)] - lo[static_cast<size_t>(c)], glm::vec2(1e-6f));
    r.rotated = r.size.y > r.size.x;  // lay long charts flat
    area += static_cast<double>(r.size.x) * r.size.y;
  }
  std::vector<Rect> order = rects;
  std::stable_sort(order.begin(), order.end(), [](const Rect& a, const Rect& b) {
    return std::min(a.size.x, a.size.y) > std::min(b.size.x, b.size.y);
  });
  const double gutter = static_cast<double>(gutterTexels) / resolution;
  // Largest scale that fits, by bisection between a surely-fitting and a surely-failing scale.
  double good = 0, bad = 1.0 / std::sqrt(std::max(area, 1e-12));
  while (shelfPack(order, bad, gutter)) bad *= 2;
  good = bad / 2;
  while (!shelfPack(order, good, gutter) && good > 1e-12) good /= 2;
  for (int it = 0; it < 30; ++it) {
    const double mid = 0.5 * (good + bad);
    (shelfPack(order, mid, gutter) ? good : bad) = mid;
  }
  shelfPack(order, good, gutter);
  for (const Rect& r : order) rects[static_cast<size_t>(r.chart)] = r;

  TriangleMesh out;
  // Corners weld where position, normal and uv agree (and the file's material uv and material, when it has them).
  const bool looks = cm.materialUvs.size() == cm.positions.size() && cm.materialIds.size() == cm.positions.size();
  std::map<std::tuple<float, float, float, float, float, float, float, float, float, float, int>, unsigned> weld;
  for (size_t t = 0; t < cm.chart.size(); ++t) {
    const Rect& r = rects[static_cast<size_t>(cm.chart[t])];
    unsigned idx[3];
    for (int k = 0; k < 3; ++k) {
      glm::vec2 local = cm.chartUV[t * 3 + k] - r.lo;
      if (r.rotated) local = glm::vec2(r.size.y - local.y, local.x);
      const glm::vec2 uv = r.at + local * static_cast<float>(good);
      const glm::vec3& p = cm.positions[t * 3 + k];
      const glm::vec3& n = cm.normals[t * 3 + k];
      const glm::vec2 muv = looks ? cm.materialUvs[t * 3 + k] : glm::vec2(0);
      const int mid = looks ? cm.materialIds[t * 3 + k] : -1;
      auto [it, inserted] = weld.try_emplace({p.x, p.y, p.z, n.x, n.y, n.z, uv.x, uv.y, muv.x, muv.y, mid},
                                             static_cast<unsigned>(out.positions.size()));
      if (inserted) {
        out.positions.push_back(p);
        out.normals.push_back(n);
        out.uvs.push_back(uv);
        if (!cm.colors.empty()) out.colors.push_back(cm.colors[t * 3 + k]);
        if (looks) {
          out.materialUvs.push_back(muv);
          out.materialIds.push_back(mid);
        }
      }
      idx[k] = it->second;
    }
    out.triangles.push_back({idx[0], idx[1], idx[2]});
  }
  return out;
}

AtlasCheck checkAtlas(const TriangleMesh& mesh, int resolution) {
  AtlasCheck check;
  if (mesh.uvs.size() != mesh.positions.size() || mesh.uvs.empty()) {
    check.missing = true;
    return check;
  }
  const int R = resolution;
  std::vector<uint8_t> hits(static_cast<size_t>(R) * R, 0);
  // Texel centres, nudged by an irrational offset so that a centre lying
  // exactly on an edge shared by two triangles is not counted twice.
  const double jitter = 1e-4 * std::sqrt(2.0);
  for (const auto& t : mesh.triangles) {
    const glm::dvec2 a = glm::dvec2(mesh.uvs[t.x]) * double(R), b = glm::dvec2(mesh.uvs[t.y]) * double(R),
                     c = glm::dvec2(mesh.uvs[t.z]) * double(R);
    const double area2 = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    const glm::vec3 e1 = mesh.positions[t.y] - mesh.positions[t.x], e2 = mesh.positions[t.z] - mesh.positions[t.x];
    const double surface = glm::length(glm::cross(e1, e2));
    for (const glm::dvec2& p : {a, b, c}) {
      if (p.x < 0 || p.y < 0 || p.x > R || p.y > R) {
        ++check.outsideTriangles;
        break;
      }
    }
    if (std::abs(area2) < 1e-12) {
      if (surface > 1e-10) ++check.collapsedTriangles;
      continue;
    }
    const double sign = area2 > 0 ? 1 : -1;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({a.x, b.x, c.x}))));
    const int x1 = std::min(R - 1, static_cast<int>(std::ceil(std::max({a.x, b.x, c.x}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({a.y, b.y, c.y}))));
    const int y1 = std::min(R - 1, static_cast<int>(std::ceil(std::max({a.y, b.y, c.y}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const glm::dvec2 p(x + 0.5 + jitter, y + 0.5 + jitter * 1.7);
        const double w0 = sign * ((b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x));
        const double w1 = sign * ((c.x - b.x) * (p.y - b.y) - (c.y - b.y) * (p.x - b.x));
        const double w2 = sign * ((a.x - c.x) * (p.y - c.y) - (a.y - c.y) * (p.x - c.x));
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        uint8_t& h = hits[static_cast<size_t>(y) * R + x];
        if (h < 255) ++h;
      }
    }
  }
  for (uint8_t h : hits) {
    check.coveredTexels += h > 0;
    check.overlappingTexels += h > 1;
  }
  check.oneToOne = check.overlappingTexels == 0 && check.outsideTriangles == 0 && check.collapsedTriangles == 0;
  return check;
}

namespace {
// What the charts are made from: each triangle's dominant axis (and sign) and face normal, and the triangles
// across each of its edges (positions welded, so that uv seams do not cut them apart).
struct Faces {
  std::vector<int> axis;
  std::vector<glm::vec3> normal;
  std::vector<std::vector<int>> adjacent;
};

Faces facesOf(const TriangleMesh& mesh) {
  std::map<std::tuple<float, float, float>, unsigned> weld;
  std::vector<unsigned> vid(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const auto& p = mesh.positions[i];
    vid[i] = weld.try_emplace({p.x, p.y, p.z}, static_cast<unsigned>(weld.size())).first->second;
  }
  const size_t nt = mesh.triangles.size();
  Faces f;
  f.axis.resize(nt);
  f.normal.resize(nt);
  for (size_t t = 0; t < nt; ++t) {
    const auto& tri = mesh.triangles[t];
    const glm::vec3 n =
        glm::cross(mesh.positions[tri.y] - mesh.positions[tri.x], mesh.positions[tri.z] - mesh.positions[tri.x]);
    f.normal[t] = n;
    const glm::vec3 a = glm::abs(n);
    const int ax = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
    f.axis[t] = ax * 2 + (n[ax] < 0 ? 1 : 0);
  }
  std::map<std::pair<unsigned, unsigned>, std::vector<int>> edges;
  for (size_t t = 0; t < nt; ++t) {
    const unsigned v[3] = {vid[mesh.triangles[t].x], vid[mesh.triangles[t].y], vid[mesh.triangles[t].z]};
    for (int k = 0; k < 3; ++k)
      edges[{std::min(v[k], v[(k + 1) % 3]), std::max(v[k], v[(k + 1) % 3])}].push_back(static_cast<int>(t));
  }
  f.adjacent.resize(nt);
  for (const auto& [e, tris] : edges)
    for (int a : tris)
      for (int b : tris)
        if (a != b) f.adjacent[static_cast<size_t>(a)].push_back(b);
  return f;
}

// Flood fill from each unassigned triangle: the connected triangles that `same` admits get its chart. Returns
// the next free chart number.
template <typename Same>
int flood(const Faces& f, std::vector<int>& chartOf, int first, Same&& same) {
  int next = first;
  std::vector<int> stack;
  for (size_t seed = 0; seed < chartOf.size(); ++seed) {
    if (chartOf[seed] >= 0 || !same(seed, seed)) continue;
    chartOf[seed] = next;
    stack.assign(1, static_cast<int>(seed));
    while (!stack.empty()) {
      const size_t t = static_cast<size_t>(stack.back());
      stack.pop_back();
      for (int u : f.adjacent[t]) {
        const size_t uu = static_cast<size_t>(u);
        if (chartOf[uu] < 0 && same(seed, uu)) {
          chartOf[uu] = next;
          stack.push_back(u);
        }
      }
    }
    ++next;
  }
  return next;
}

// A point projected onto the plane of a dominant axis (right-handed in-plane axes: charts are not mirrored).
glm::vec2 project(const glm::vec3& p, int ax) {
  const int a = ax / 2;
  const bool neg = ax % 2;
  glm::vec2 q = a == 0 ? glm::vec2(p.z, p.y) : a == 1 ? glm::vec2(p.x, p.z) : glm::vec2(p.x, p.y);
  if ((a == 0) != neg) q.x = -q.x;
  if (a == 1) q.y = -q.y;
  return q;
}

// The mesh's triangles as charts (chartIds), each projected on its axis, with their normals, colours and looks.
ChartMesh buildCharts(const TriangleMesh& mesh, const Faces& f, const std::vector<int>& chartIds) {
  ChartMesh cm;
  const bool coloured = mesh.colors.size() == mesh.positions.size();
  const bool looks =
      mesh.materialUvs.size() == mesh.positions.size() && mesh.materialIds.size() == mesh.positions.size();
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const glm::vec3 p[3] = {mesh.positions[tri.x], mesh.positions[tri.y], mesh.positions[tri.z]};
    glm::vec3 n[3];
    for (int k = 0; k < 3; ++k) {
      const unsigned vi = k == 0 ? tri.x : k == 1 ? tri.y : tri.z;
      n[k] = mesh.normals.size() == mesh.positions.size() ? mesh.normals[vi] : glm::normalize(f.normal[t]);
    }
    glm::vec2 uv[3];
    for (int k = 0; k < 3; ++k) uv[k] = project(p[k], f.axis[t]);
    const glm::vec3 c[3] = {coloured ? mesh.colors[tri.x] : glm::vec3(1), coloured ? mesh.colors[tri.y] : glm::vec3(1),
                            coloured ? mesh.colors[tri.z] : glm::vec3(1)};
    glm::vec2 muv[3] = {};
    int mid[3] = {-1, -1, -1};
    if (looks) {
      const unsigned vs[3] = {tri.x, tri.y, tri.z};
      for (int k = 0; k < 3; ++k) muv[k] = mesh.materialUvs[vs[k]], mid[k] = mesh.materialIds[vs[k]];
    }
    cm.addTriangle(chartIds[t], p, n, uv, coloured ? c : nullptr, looks ? muv : nullptr, looks ? mid : nullptr);
  }
  return cm;
}

// The charts (of `ids`, numbered below `count`) whose own triangles overlap in the packed atlas, each checked alone.
std::vector<char> foldedCharts(const TriangleMesh& packed, const std::vector<int>& ids, int count, int resolution) {
  std::vector<char> bad(static_cast<size_t>(count), 0);
  for (int c = 0; c < count; ++c) {
    TriangleMesh one;
    for (size_t t = 0; t < ids.size(); ++t) {
      if (ids[t] != c) continue;
      const unsigned base = static_cast<unsigned>(one.positions.size());
      const auto& tri = packed.triangles[t];
      for (unsigned v : {tri.x, tri.y, tri.z}) {
        one.positions.push_back(packed.positions[v]);
        one.uvs.push_back(packed.uvs[v]);
      }
      one.triangles.push_back({base, base + 1, base + 2});
    }
    if (!one.triangles.empty() && !checkAtlas(one, resolution).oneToOne) bad[static_cast<size_t>(c)] = 1;
  }
  return bad;
}
}  // namespace

// Charts: connected triangles that face the same axis. A chart whose projection folds over itself (a lip over
// a bumper, both facing one axis) is cut into pieces: its connected triangles within one cube of a sixteenth of
// the mesh's size, so layers further apart than that part; pieces that still fold are split into triangles, and
// if the atlas still overlaps, every triangle is a chart of its own.
TriangleMesh generateAtlas(const TriangleMesh& mesh, int resolution) {
  const Faces f = facesOf(mesh);
  const size_t nt = mesh.triangles.size();
  std::vector<int> ids(nt, -1);
  flood(f, ids, 0, [&](size_t seed, size_t t) { return f.axis[t] == f.axis[seed]; });
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const glm::vec3 size = hi - lo;
  const float cell = std::max(std::max({size.x, size.y, size.z}) / 16.0f, 1e-6f);
  for (int attempt = 0; attempt < 4; ++attempt) {
    TriangleMesh packed = packCharts(buildCharts(mesh, f, ids), resolution);
    const AtlasCheck check = checkAtlas(packed, resolution);
    if (check.oneToOne || attempt == 3) return packed;
    int next = *std::max_element(ids.begin(), ids.end()) + 1;
    const std::vector<char> bad = foldedCharts(packed, ids, next, resolution);
    bool any = false;
    if (attempt == 0) {
      // Pieces: flood fill over the bad charts' triangles, within one chart and one cube (of the centroid).
      std::vector<glm::ivec3> cube(nt);
      for (size_t t = 0; t < nt; ++t) {
        const auto& tri = mesh.triangles[t];
        const glm::vec3 c = (mesh.positions[tri.x] + mesh.positions[tri.y] + mesh.positions[tri.z]) / 3.0f;
        cube[t] = glm::ivec3(glm::floor((c - lo) / cell));
      }
      std::vector<int> piece(nt, -1);
      const int first = next;
      next = flood(f, piece, next, [&](size_t seed, size_t t) {
        return bad[static_cast<size_t>(ids[seed])] && ids[t] == ids[seed] && cube[t] == cube[seed];
      });
      any = next > first;
      for (size_t t = 0; t < nt; ++t)
        if (piece[t] >= 0) ids[t] = piece[t];
    } else {
      for (size_t t = 0; t < nt; ++t) {
        if (bad[static_cast<size_t>(ids[t])] || attempt == 2) {
          ids[t] = next++;
          any = true;
        }
      }
    }
    if (!any) return packed;
  }
  return packCharts(buildCharts(mesh, f, ids), resolution);
}

}  // namespace crumple
