#include <crumple/physics/sdf_grid.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <array>
#include <map>
#include <memory>
#include <numeric>

namespace crumple {

namespace {

// Ericson, Real-Time Collision Detection 5.1.5; returns barycentrics (u, v, w) of the closest point.
glm::dvec3 closestOnTriangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return {1, 0, 0};
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {1 - v - w, v, w};
}

double boxDistance2(const glm::dvec3& p, const glm::dvec3& lo, const glm::dvec3& hi) {
  const glm::dvec3 d = glm::max(glm::max(lo - p, p - hi), glm::dvec3(0));
  return glm::dot(d, d);
}

}  // namespace

TriangleBvh::TriangleBvh(const TriangleMesh& mesh) {
  const size_t n = mesh.triangles.size();
  a_.resize(n);
  b_.resize(n);
  c_.resize(n);
  centroid_.resize(n);
  for (size_t i = 0; i < n; ++i) {
    a_[i] = mesh.positions[mesh.triangles[i].x];
    b_[i] = mesh.positions[mesh.triangles[i].y];
    c_[i] = mesh.positions[mesh.triangles[i].z];
    centroid_[i] = (a_[i] + b_[i] + c_[i]) / 3.0;
  }
  order_.resize(n);
  std::iota(order_.begin(), order_.end(), 0);
  nodes_.reserve(2 * n + 1);
  if (n) build(0, static_cast<int>(n));
}

int TriangleBvh::build(int first, int count) {
  Node node;
  node.lo = glm::dvec3(std::numeric_limits<double>::max());
  node.hi = -node.lo;
  for (int i = first; i < first + count; ++i) {
    const int t = order_[i];
    node.lo = glm::min(node.lo, glm::min(a_[t], glm::min(b_[t], c_[t])));
    node.hi = glm::max(node.hi, glm::max(a_[t], glm::max(b_[t], c_[t])));
  }
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(node);
  if (count <= 4) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  const glm::dvec3 ext = node.hi - node.lo;
  const int axis = ext.x > ext.y ? (ext.x > ext.z ? 0 : 2) : (ext.y > ext.z ? 1 : 2);
  const int mid = first + count / 2;
  std::nth_element(order_.begin() + first, order_.begin() + mid, order_.begin() + first + count, [&](int x, int y) {
    if (centroid_[x][axis] != centroid_[y][axis]) return centroid_[x][axis] < centroid_[y][axis];
    return x < y;  // deterministic ties
  });
  const int left = build(first, mid - first);
  const int right = build(mid, first + count - mid);
  nodes_[index].left = left;
  nodes_[index].right = right;
  return index;
}

TriangleBvh::Hit TriangleBvh::closest(const glm::dvec3& p) const {
  return closest(p, std::numeric_limits<double>::max());
}

TriangleBvh::Hit TriangleBvh::closest(const glm::dvec3& p, double within2) const {
  Hit best;
  // (A triangle at exactly within2 counts: the bound is the next double up.)
  best.distance2 = std::nextafter(within2, std::numeric_limits<double>::max());
  if (nodes_.empty()) return best;
  auto consider = [&](int t) {
    const glm::dvec3 bc = closestOnTriangle(p, a_[t], b_[t], c_[t]);
    const glm::dvec3 q = bc.x * a_[t] + bc.y * b_[t] + bc.z * c_[t];
    const double d2 = glm::dot(q - p, q - p);
    if (d2 < best.distance2) best = {d2, q, t, bc};
  };
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top) {
    const Node& node = nodes_[stack[--top]];
    if (boxDistance2(p, node.lo, node.hi) >= best.distance2) continue;
    if (node.left < 0) {
      for (int i = node.first; i < node.first + node.count; ++i) consider(order_[i]);
      continue;
    }
    const double dl = boxDistance2(p, nodes_[node.left].lo, nodes_[node.left].hi);
    const double dr = boxDistance2(p, nodes_[node.right].lo, nodes_[node.right].hi);
    if (top + 2 > 128) continue;  // cannot happen for balanced trees under 2^64 triangles
    if (dl < dr) {
      stack[top++] = node.right;
      stack[top++] = node.left;
    } else {
      stack[top++] = node.left;
      stack[top++] = node.right;
    }
  }
  if (best.triangle < 0) best.distance2 = std::numeric_limits<double>::max();
  return best;
}

void TriangleBvh::near(const glm::dvec3& p, double within2, std::vector<std::pair<double, int>>& out) const {
  out.clear();
  if (nodes_.empty()) return;
  // (Written out per axis: a third of glm's vector form, and a list asks some fifty boxes.)
  auto outside = [&](const Node& node) {
    const double dx = std::max(std::max(node.lo.x - p.x, p.x - node.hi.x), 0.0);
    const double dy = std::max(std::max(node.lo.y - p.y, p.y - node.hi.y), 0.0);
    const double dz = std::max(std::max(node.lo.z - p.z, p.z - node.hi.z), 0.0);
    return dx * dx + dy * dy + dz * dz > within2;
  };
  if (outside(nodes_[0])) return;
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top) {
    const Node& node = nodes_[stack[--top]];
    if (node.left >= 0) {
      if (top + 2 > 128) continue;  // (as in closest)
      if (!outside(nodes_[node.left])) stack[top++] = node.left;
      if (!outside(nodes_[node.right])) stack[top++] = node.right;
      continue;
    }
    for (int i = node.first; i < node.first + node.count; ++i) {
      const int t = order_[i];
      const glm::dvec3 bc = closestOnTriangle(p, a_[t], b_[t], c_[t]);
      const glm::dvec3 q = bc.x * a_[t] + bc.y * b_[t] + bc.z * c_[t];
      const double d2 = glm::dot(q - p, q - p);
      if (d2 <= within2) out.emplace_back(d2, t);
    }
  }
}

NearTriangles::NearTriangles(const TriangleMesh& mesh, double cell, double reach)
    : bvh_(mesh),
      cell_(cell),
      reach_(reach),
      reachBound_(std::nextafter(reach * reach, std::numeric_limits<double>::max())) {
  static std::atomic<uint64_t> made{0};
  id_ = ++made;
  corners_.reserve(mesh.triangles.size());
  for (const glm::uvec3& t : mesh.triangles)
    corners_.push_back({mesh.positions[t.x], mesh.positions[t.y], mesh.positions[t.z]});
}

// Per thread, the cells' lists of the last few NearTriangles asked (a contact asks two bodies' in turn): an
// open-addressed table of cells, each a run of entries (a triangle's corners beside its bound: one pass over memory
// a query). The entries lie in chunks that are never moved (a list is made once and read many times: a growing
// array would copy every list made so far each time it grew) and are reused after a clear.
struct NearTriangles::Entry {
  double bound;  // the triangle's distance from the cell's centre
  uint32_t triangle;
  glm::vec3 a, b, c;
};

struct NearTriangles::Kept {
  static constexpr size_t kChunk = 4096;  // entries
  uint64_t id = 0, used = 0;
  std::vector<uint64_t> keys;  // 0: empty
  std::vector<const Entry*> first;
  std::vector<uint32_t> count;
  size_t cells = 0, entries = 0;
  std::vector<std::pair<std::unique_ptr<Entry[]>, size_t>> chunks;  // storage, its size
  size_t chunk = 0, filled = 0;                                     // the chunk being filled, and how far
  void clear() {
    keys.assign(1024, 0);
    first.assign(1024, nullptr);
    count.assign(1024, 0);
    cells = entries = 0;
    chunk = filled = 0;
  }
  // Room for n entries side by side.
  Entry* take(size_t n) {
    if (chunk < chunks.size() && filled + n > chunks[chunk].second) {
      ++chunk;
      filled = 0;
    }
    if (chunk == chunks.size()) chunks.emplace_back();
    if (n > chunks[chunk].second) {  // (new, or one kept from before a clear that is too small)
      const size_t size = std::max(kChunk, n);
      chunks[chunk] = {std::make_unique_for_overwrite<Entry[]>(size), size};
    }
    Entry* room = chunks[chunk].first.get() + filled;
    filled += n;
    entries += n;
    return room;
  }
};

NearTriangles::Kept& NearTriangles::kept() const {
  thread_local std::array<Kept, 8> slots;
  thread_local uint64_t clock = 0;
  Kept* mine = nullptr;
  for (Kept& k : slots)
    if (k.id == id_) mine = &k;
  if (!mine) {
    mine = &*std::min_element(slots.begin(), slots.end(), [](const Kept& a, const Kept& b) { return a.used < b.used; });
    mine->id = id_;
    mine->clear();
  }
  mine->used = ++clock;
  // (a bound on the memory a thread keeps: 2^16 entries of 48 bytes a slot, ~25 MB for the eight; a dent's cells
  // hold a few thousand lists of about eight)
  if (mine->entries > (size_t(1) << 16)) mine->clear();
  return *mine;
}

std::pair<const NearTriangles::Entry*, uint32_t> NearTriangles::listed(Kept& kept, const glm::i64vec3& c) const {
  const uint64_t key = 1 + ((static_cast<uint64_t>(c.x) & 0x1fffff) | (static_cast<uint64_t>(c.y) & 0x1fffff) << 21 |
                            (static_cast<uint64_t>(c.z) & 0x1fffff) << 42);
  auto slotOf = [&](uint64_t k) {
    const size_t mask = kept.keys.size() - 1;
    size_t s = (k * 0x9E3779B97F4A7C15ull >> 20) & mask;
    while (kept.keys[s] != 0 && kept.keys[s] != k) s = (s + 1) & mask;
    return s;
  };
  size_t s = slotOf(key);
  if (kept.keys[s] == key) return {kept.first[s], kept.count[s]};
  if (2 * (kept.cells + 1) > kept.keys.size()) {  // grow (at half full)
    std::vector<uint64_t> keys(2 * kept.keys.size(), 0);
    std::vector<const Entry*> first(keys.size());
    std::vector<uint32_t> count(keys.size());
    std::swap(keys, kept.keys);
    for (size_t i = 0; i < keys.size(); ++i)
      if (keys[i]) {
        const size_t t = slotOf(keys[i]);
        kept.keys[t] = keys[i];
        first[t] = kept.first[i];
        count[t] = kept.count[i];
      }
    kept.first = std::move(first);
    kept.count = std::move(count);
    s = slotOf(key);
  }
  // Every point of the cell lies within half its diagonal of its centre: a triangle within reach of one lies
  // within reach + that of the centre, and no nearer to any than (its distance from the centre) - that.
  thread_local std::vector<std::pair<double, int>> found;
  const double half = 0.5 * std::sqrt(3.0) * cell_ * (1 + 1e-9);
  const glm::dvec3 centre = centreOf(glm::dvec3(c));
  const double within = reach_ + half;
  bvh_.near(centre, within * within * (1 + 1e-9), found);
  Entry* list = kept.take(found.size());
  for (size_t i = 0; i < found.size(); ++i) {
    const auto [d2, t] = found[i];
    const Corners& k = corners_[static_cast<size_t>(t)];
    list[i] = {std::sqrt(d2), static_cast<uint32_t>(t), k.a, k.b, k.c};
  }
  std::sort(list, list + found.size(), [](const Entry& x, const Entry& y) {
    return x.bound != y.bound ? x.bound < y.bound : x.triangle < y.triangle;
  });
  kept.keys[s] = key;
  kept.first[s] = list;
  kept.count[s] = static_cast<uint32_t>(found.size());
  ++kept.cells;
  return {list, kept.count[s]};
}

TriangleBvh::Hit NearTriangles::closest(const glm::dvec3& p) const {
  TriangleBvh::Hit best;
  const double reach2 = reach_ * reach_;
  best.distance2 = reachBound_;
  const glm::dvec3 f = glm::floor(p / cell_);
  const double limit = double(1 << 20);  // (21 bits an axis in the key)
  if (!(std::abs(f.x) < limit && std::abs(f.y) < limit && std::abs(f.z) < limit))
    return bvh_.closest(p, reach2);  // (far out: the tree, whose ties may differ)
  Kept& kept = this->kept();
  const auto [list, listed] = this->listed(kept, glm::i64vec3(f));
  // A triangle at distance d from the cell's centre is no nearer to p than d - |p - centre|.
  const double offCentre = glm::length(p - centreOf(f)) * (1 + 1e-9) + 1e-12;
  for (uint32_t i = 0; i < listed; ++i) {
    const Entry& e = list[i];
    const double bound = e.bound - offCentre;
    if (bound > 0 && bound * bound > best.distance2) break;
    const glm::dvec3 a(e.a), b(e.b), c(e.c);
    const glm::dvec3 bc = closestOnTriangle(p, a, b, c);
    const glm::dvec3 q = bc.x * a + bc.y * b + bc.z * c;
    const double d2 = glm::dot(q - p, q - p);
    if (d2 < best.distance2 || (d2 == best.distance2 && static_cast<int>(e.triangle) < best.triangle))
      best = {d2, q, static_cast<int>(e.triangle), bc};
  }
  if (best.triangle < 0) best.distance2 = std::numeric_limits<double>::max();
  return best;
}

SdfGrid::SdfGrid(const TriangleMesh& mesh, int resolution) : bvh_(mesh) {
  // Weld positions so that seams (split for UVs) do not break the pseudo-normals.
  std::map<std::tuple<float, float, float>, unsigned> weld;
  std::vector<unsigned> remap(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const auto& p = mesh.positions[i];
    auto [it, inserted] = weld.try_emplace({p.x, p.y, p.z}, static_cast<unsigned>(positions_.size()));
    if (inserted) positions_.push_back(glm::dvec3(p));
    remap[i] = it->second;
  }
  triangles_.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) triangles_.push_back({remap[t.x], remap[t.y], remap[t.z]});

  faceNormal_.resize(triangles_.size());
  vertexNormal_.assign(positions_.size(), glm::dvec3(0));
  edgeNormal_.assign(triangles_.size() * 3, glm::dvec3(0));
  std::map<std::pair<unsigned, unsigned>, glm::dvec3> edgeSum;
  for (size_t f = 0; f < triangles_.size(); ++f) {
    const auto& t = triangles_[f];
    const glm::dvec3 v[3] = {positions_[t.x], positions_[t.y], positions_[t.z]};
    const glm::dvec3 cr = glm::cross(v[1] - v[0], v[2] - v[0]);
    const double len = glm::length(cr);
    const glm::dvec3 n = len > 0 ? cr / len : glm::dvec3(0);
    faceNormal_[f] = n;
    const unsigned idx[3] = {t.x, t.y, t.z};
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 e1 = v[(k + 1) % 3] - v[k], e2 = v[(k + 2) % 3] - v[k];
      const double l1 = glm::length(e1), l2 = glm::length(e2);
      if (l1 > 0 && l2 > 0) {
        const double angle = std::acos(std::clamp(glm::dot(e1, e2) / (l1 * l2), -1.0, 1.0));
        vertexNormal_[idx[k]] += angle * n;
      }
      const unsigned a = idx[k], b = idx[(k + 1) % 3];
      edgeSum[{std::min(a, b), std::max(a, b)}] += n;
    }
  }
  for (size_t f = 0; f < triangles_.size(); ++f) {
    const unsigned idx[3] = {triangles_[f].x, triangles_[f].y, triangles_[f].z};
    for (int k = 0; k < 3; ++k) {
      const unsigned a = idx[k], b = idx[(k + 1) % 3];
      edgeNormal_[f * 3 + k] = edgeSum[{std::min(a, b), std::max(a, b)}];  // edge (k, k+1)
    }
  }

  const glm::dvec3 lo = glm::dvec3(mesh.boundsMin()), hi = glm::dvec3(mesh.boundsMax());
  const glm::dvec3 ext = hi - lo;
  const double longest = std::max({ext.x, ext.y, ext.z, 1e-9});
  cell_ = longest / std::max(4, resolution);
  // A long thin body keeps at least a quarter of the resolution across its thinnest extent (a 4 m guard-rail
  // beam 0.18 m deep: 12 cells through its profile, not 2, which smoothed its W away), within a budget of nodes.
  const double shortest = std::max(std::min({ext.x, ext.y, ext.z}), 1e-9);
  const double across = shortest / std::max(1, resolution / 4);
  if (across < cell_) {
    auto nodes = [&](double c) {
      const glm::dvec3 n = glm::ceil((ext + 4 * c) / c) + 1.0;
      return n.x * n.y * n.z;
    };
    const double coarse = cell_;
    cell_ = across;
    while (nodes(cell_) > kMaxNodes && cell_ < coarse) cell_ = std::min(coarse, cell_ * 1.125);
  }
  const double pad = 2 * cell_;
  origin_ = lo - pad;
  dims_ = glm::ivec3(glm::ceil((ext + 2 * pad) / cell_)) + 1;
  maxg_ = glm::dvec3(dims_ - 1) - 1e-9;
  values_.resize(static_cast<size_t>(dims_.x) * dims_.y * dims_.z);
  for (int k = 0; k < dims_.z; ++k)
    for (int j = 0; j < dims_.y; ++j)
      for (int i = 0; i < dims_.x; ++i)
        values_[(static_cast<size_t>(k) * dims_.y + j) * dims_.x + i] =
            exactDistance(origin_ + cell_ * glm::dvec3(i, j, k));
  // Within a cell the lookup's derivative along an axis is a weighted mean of the cell's four node differences
  // along that axis: at most the largest of them, per metre. The bound on the gradient is the largest, over the
  // cells, of the length of those three.
  auto at = [&](int i, int j, int k) { return values_[(static_cast<size_t>(k) * dims_.y + j) * dims_.x + i]; };
  double steepest = 0;
  for (int k = 0; k + 1 < dims_.z; ++k)
    for (int j = 0; j + 1 < dims_.y; ++j)
      for (int i = 0; i + 1 < dims_.x; ++i) {
        glm::dvec3 d(0);
        for (int b = 0; b < 2; ++b)
          for (int a = 0; a < 2; ++a) {
            d.x = std::max(d.x, std::abs(at(i + 1, j + a, k + b) - at(i, j + a, k + b)));
            d.y = std::max(d.y, std::abs(at(i + a, j + 1, k + b) - at(i + a, j, k + b)));
            d.z = std::max(d.z, std::abs(at(i + a, j + b, k + 1) - at(i + a, j + b, k)));
          }
        steepest = std::max(steepest, glm::dot(d, d));
      }
  lipschitz_ = std::sqrt(steepest / (cell_ * cell_) + 1.0);
}

double SdfGrid::exactDistance(const glm::dvec3& p) const {
  const TriangleBvh::Hit hit = bvh_.closest(p);
  if (hit.triangle < 0) return std::numeric_limits<double>::max();
  // Feature of the closest point: face interior, an edge, or a vertex.
  const double tol = 1e-9;
  const glm::dvec3& bc = hit.barycentric;
  const int zeros = (bc.x <= tol) + (bc.y <= tol) + (bc.z <= tol);
  glm::dvec3 pseudo;
  const auto& t = triangles_[static_cast<size_t>(hit.triangle)];
  if (zeros == 0) {
    pseudo = faceNormal_[static_cast<size_t>(hit.triangle)];
  } else if (zeros == 1) {
    // The edge opposite the zero barycentric: (y,z) if x==0 -> edge k=1; (x,z) if y==0 -> k=2; (x,y) if z==0 -> k=0.
    const int k = bc.x <= tol ? 1 : (bc.y <= tol ? 2 : 0);
    pseudo = edgeNormal_[static_cast<size_t>(hit.triangle) * 3 + k];
  } else {
    const unsigned v = bc.x > tol ? t.x : (bc.y > tol ? t.y : t.z);
    pseudo = vertexNormal_[v];
  }
  const double d = std::sqrt(hit.distance2);
  return glm::dot(p - hit.point, pseudo) < 0 ? -d : d;
}

double SdfGrid::distance(const glm::dvec3& p, glm::dvec3* gradient, double gradientBelow) const {
  const glm::dvec3 g = (p - origin_) / cell_;
  // Inside the grid, the common case: the distance to its box is 0 (no square root), and the point is finite.
  const bool inside = g.x >= 0 && g.y >= 0 && g.z >= 0 && g.x <= maxg_.x && g.y <= maxg_.y && g.z <= maxg_.z;
  glm::dvec3 gc = g;
  double outside = 0;
  if (!inside) {
    // A point that is not finite is nowhere: outside, touching nothing (never a grid index).
    if (!std::isfinite(g.x) || !std::isfinite(g.y) || !std::isfinite(g.z)) {
      if (gradient) *gradient = glm::dvec3(0, 1, 0);
      return std::numeric_limits<double>::infinity();
    }
    gc = glm::clamp(g, glm::dvec3(0), maxg_);
    outside = glm::length((g - gc) * cell_);
  }
  // gc >= 0: truncation is the floor.
  const int ix = static_cast<int>(gc.x), iy = static_cast<int>(gc.y), iz = static_cast<int>(gc.z);
  const glm::dvec3 f = gc - glm::dvec3(ix, iy, iz);
  // The cell's eight nodes: c[dz][dy][dx] at base + dx + dy * rowStride + dz * sliceStride.
  const size_t row = static_cast<size_t>(dims_.x), slice = row * static_cast<size_t>(dims_.y);
  const double* v = values_.data() + (static_cast<size_t>(iz) * dims_.y + iy) * row + ix;
  const double c000 = v[0], c001 = v[1], c010 = v[row], c011 = v[row + 1];
  const double c100 = v[slice], c101 = v[slice + 1], c110 = v[slice + row], c111 = v[slice + row + 1];
  const double c00 = c000 * (1 - f.x) + c001 * f.x;
  const double c10 = c010 * (1 - f.x) + c011 * f.x;
  const double c01 = c100 * (1 - f.x) + c101 * f.x;
  const double c11 = c110 * (1 - f.x) + c111 * f.x;
  const double c0 = c00 * (1 - f.y) + c10 * f.y;
  const double c1 = c01 * (1 - f.y) + c11 * f.y;
  const double value = c0 * (1 - f.z) + c1 * f.z;
  if (gradient && value + outside < gradientBelow) {
    // Analytic gradient of the trilinear interpolant.
    const double gx = ((c001 - c000) * (1 - f.y) + (c011 - c010) * f.y) * (1 - f.z) +
                      ((c101 - c100) * (1 - f.y) + (c111 - c110) * f.y) * f.z;
    const double gy = (c10 - c00) * (1 - f.z) + (c11 - c01) * f.z;
    const double gz = c1 - c0;
    glm::dvec3 grad(gx, gy, gz);
    if (outside > 0) grad += (g - gc);  // points away from the grid
    const double len = glm::length(grad);
    *gradient = len > 1e-12 ? grad / len : glm::dvec3(0, 1, 0);
  }
  return value + outside;
}

}  // namespace crumple
