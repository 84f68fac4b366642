// The world feels its dents (Simulation's part): the deformer logs the texels its commits change in felt maps; after
// a step's deformations a fence follows them, and the next step takes the log in before its physics (the texels
// that changed, per tile, and the triangles' parts over them); the narrow phase asks surfaceDepth how far below the
// undented surface the dented one lies (World::setSurfaceDepth). docs/architecture.md ("Maps between the GPU and
// the physics") tells the whole.
#include <crumple/engine/simulation.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace crumple {

void Simulation::prepareDents() {
  std::map<int, std::shared_ptr<const std::vector<float>>> flat;  // by resolution
  for (size_t i = 0; i < dents_.size(); ++i) {
    DentCopy& d = dents_[i];
    if (!d.feel) continue;
    const BodyRuntime& body = bodies_[i];
    d.resolution = body.surface->resolution();
    const int r = d.resolution;
    const size_t texels = static_cast<size_t>(r) * static_cast<size_t>(r);
    const auto image = imageStarts_.find(i);
    if (image != imageStarts_.end() && image->second->size() == texels) {
      d.start = image->second;
    } else {
      std::shared_ptr<const std::vector<float>>& level = flat[r];
      if (!level) level = std::make_shared<const std::vector<float>>(texels, 0.5f);
      d.start = level;
    }
    std::shared_ptr<const DentMesh>& shared = dentMeshes_[{body.mesh.get(), r}];
    if (!shared) {
      const TriangleMesh& mesh = *body.mesh;
      auto made = std::make_shared<DentMesh>();
      made->near = std::make_shared<const NearTriangles>(mesh, kNearCell, kOnSurface);
      made->triangleTexels.reserve(mesh.triangles.size());
      made->frames.reserve(mesh.triangles.size());
      for (const glm::uvec3& t : mesh.triangles) {
        const glm::dvec2 a(mesh.uvs[t.x]), b(mesh.uvs[t.y]), c(mesh.uvs[t.z]);
        const glm::ivec2 tlo = glm::clamp(glm::ivec2(glm::floor(glm::min(a, glm::min(b, c)) * double(r))) - 1, 0, r - 1);
        const glm::ivec2 thi = glm::clamp(glm::ivec2(glm::floor(glm::max(a, glm::max(b, c)) * double(r))) + 1, 0, r - 1);
        made->triangleTexels.emplace_back(tlo, thi);
        uvFrame(mesh, t, made->frames.emplace_back());
      }
      shared = std::move(made);
    }
    d.mesh = shared;
  }
  imageStarts_.clear();
}

void Simulation::beforeDent(int i) {
  DentCopy& d = dents_[static_cast<size_t>(i)];
  if (d.feel) d.pending = true;
}

void Simulation::readBackDents() {
  for (size_t i = 0; i < dents_.size(); ++i)
    if (dents_[i].pending) dents_[i].k = bodies_[i].surface->bumpDepth();
  if (dentFence_) glDeleteSync(dentFence_);
  dentFence_ = deformer_->fenceChanges();
}

float Simulation::DentCopy::height(int x, int y) const {
  const Tile& t = tiles[static_cast<size_t>(y / kDentTile) * static_cast<size_t>(across) + static_cast<size_t>(x / kDentTile)];
  if (t.texels.empty()) return (*start)[static_cast<size_t>(y) * static_cast<size_t>(resolution) + static_cast<size_t>(x)];
  return t.texels[static_cast<size_t>(y % kDentTile) * kDentTile + static_cast<size_t>(x % kDentTile)];
}

void Simulation::DentCopy::set(int x, int y, float h) {
  const size_t at = static_cast<size_t>(y / kDentTile) * static_cast<size_t>(across) + static_cast<size_t>(x / kDentTile);
  Tile& t = tiles[at];
  if (t.texels.empty()) {  // its texels as they started (those past the map's edge unused)
    t.texels.assign(static_cast<size_t>(kDentTile) * kDentTile, 0.5f);
    const int x0 = x / kDentTile * kDentTile, y0 = y / kDentTile * kDentTile;
    for (int ty = y0; ty < std::min(resolution, y0 + kDentTile); ++ty)
      for (int tx = x0; tx < std::min(resolution, x0 + kDentTile); ++tx)
        t.texels[static_cast<size_t>(ty - y0) * kDentTile + static_cast<size_t>(tx - x0)] =
            (*start)[static_cast<size_t>(ty) * static_cast<size_t>(resolution) + static_cast<size_t>(tx)];
  }
  t.texels[static_cast<size_t>(y % kDentTile) * kDentTile + static_cast<size_t>(x % kDentTile)] = h;
  if (!t.moved) {
    t.moved = true;
    moved.push_back(at);
  }
}

void Simulation::takeInDents() {
  if (!dentFence_) return;
  // Fenced a step ago: on a GPU long done (the wait returns at once); the flush makes sure it was sent.
  const auto waitStart = std::chrono::steady_clock::now();
  glClientWaitSync(dentFence_, GL_SYNC_FLUSH_COMMANDS_BIT, 10'000'000'000ull);
  timings_.dentWaitMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - waitStart).count();
  glDeleteSync(dentFence_);
  dentFence_ = nullptr;
  auto due = [&](DentCopy& d, size_t i) {  // its changes are taken in now
    if (!d.pending) d.k = bodies_[i].surface->bumpDepth();  // (logged without beforeDent: taken in all the same)
    d.pending = true;
    if (!d.tiles.empty()) return;
    d.across = (d.resolution + kDentTile - 1) / kDentTile;
    d.tiles.resize(static_cast<size_t>(d.across) * static_cast<size_t>(d.across));
  };
  for (size_t i = 0; i < dents_.size(); ++i)
    if (dents_[i].pending) due(dents_[i], i);
  const deform::Deformer::Changes log = deformer_->changes();
  if (log.overflowed) {
    for (size_t i = 0; i < dents_.size(); ++i)
      if (dents_[i].pending) takeInFullMap(dents_[i], static_cast<int>(i));
  } else {
    // In the order the commits ran (within one commit a texel comes once): the last of a texel's entries holds.
    for (size_t e = 0; e < log.count; ++e) {
      const GLuint* entry = log.entries + 3 * e;
      if (entry[0] >= dents_.size()) continue;
      DentCopy& d = dents_[entry[0]];
      const size_t texels = static_cast<size_t>(d.resolution) * static_cast<size_t>(d.resolution);
      if (!d.feel || entry[1] >= texels) continue;
      due(d, entry[0]);
      float h;
      std::memcpy(&h, &entry[2], sizeof h);
      d.set(static_cast<int>(entry[1] % static_cast<GLuint>(d.resolution)),
            static_cast<int>(entry[1] / static_cast<GLuint>(d.resolution)), h);
    }
    timings_.dentTexels += static_cast<long>(log.count);
  }
  deformer_->clearChanges();
  for (size_t i = 0; i < dents_.size(); ++i) {
    DentCopy& d = dents_[i];
    if (!d.pending) continue;
    d.pending = false;
    ++timings_.dentReads;
    measureTiles(d);
    findDentedTriangles(d, static_cast<int>(i));
  }
}

// A step whose commits changed more texels than the change log holds: each map dented in it comes back whole
// (a wait on the GPU, once), and its texels that differ from the copy are taken in.
void Simulation::takeInFullMap(DentCopy& d, int i) {
  ++timings_.dentFullReads;
  const gl::Image map = bodies_[static_cast<size_t>(i)].surface->downloadHeight();
  const int r = d.resolution;
  for (int y = 0; y < r; ++y)
    for (int x0 = 0; x0 < r; x0 += kDentTile) {  // a tile's row at a time: most are as they were
      const float* row = map.pixels.data() + static_cast<size_t>(y) * static_cast<size_t>(r) + static_cast<size_t>(x0);
      const int n = std::min(kDentTile, r - x0);
      const DentCopy::Tile& tile = d.tiles[static_cast<size_t>(y / kDentTile) * static_cast<size_t>(d.across) +
                                           static_cast<size_t>(x0 / kDentTile)];
      const float* now = tile.texels.empty()
                             ? d.start->data() + static_cast<size_t>(y) * static_cast<size_t>(r) + static_cast<size_t>(x0)
                             : tile.texels.data() + static_cast<size_t>(y % kDentTile) * kDentTile;
      if (std::memcmp(row, now, static_cast<size_t>(n) * sizeof(float)) == 0) continue;
      for (int k = 0; k < n; ++k)
        if (row[k] != d.height(x0 + k, y)) d.set(x0 + k, y, row[k]);
    }
}

// The moved tiles measured again against the start (an atlas spreads one dent over charts far apart in uv: the
// rectangle around the change can cover the whole map while the tiles cover the dent), and the rectangle around
// all tiles' changes.
void Simulation::measureTiles(DentCopy& d) {
  const int r = d.resolution;
  const std::vector<float>& start = *d.start;
  for (size_t at : d.moved) {
    DentCopy::Tile& tile = d.tiles[at];
    tile.moved = false;
    tile.lo = glm::ivec2(0);
    tile.hi = glm::ivec2(-1);
    tile.highest = 0.5f;
    const int x0 = static_cast<int>(at % static_cast<size_t>(d.across)) * kDentTile;
    const int y0 = static_cast<int>(at / static_cast<size_t>(d.across)) * kDentTile;
    for (int y = y0; y < std::min(r, y0 + kDentTile); ++y)
      for (int x = x0; x < std::min(r, x0 + kDentTile); ++x) {
        const float h = tile.texels[static_cast<size_t>(y - y0) * kDentTile + static_cast<size_t>(x - x0)];
        if (h == start[static_cast<size_t>(y) * static_cast<size_t>(r) + static_cast<size_t>(x)]) continue;
        tile.lo = tile.hi.x < tile.lo.x ? glm::ivec2(x, y) : glm::min(tile.lo, glm::ivec2(x, y));
        tile.hi = glm::max(tile.hi, glm::ivec2(x, y));
        tile.highest = std::max(tile.highest, h);
      }
  }
  d.moved.clear();
  d.lo = glm::ivec2(r);
  d.hi = glm::ivec2(-1);
  for (const DentCopy::Tile& tile : d.tiles)
    if (tile.hi.x >= tile.lo.x) {
      d.lo = glm::min(d.lo, tile.lo);
      d.hi = glm::max(d.hi, tile.hi);
    }
}

namespace {
// The part of the triangle with corners p and their uvs whose uv lies in [lo, hi] (clipped in uv, each corner's
// position carried along: the map from uv to the surface is affine on the triangle), as the box around it; false
// where none does.
bool clippedBox(const glm::dvec3 (&p)[3], const glm::dvec2 (&uv)[3], const glm::dvec2& lo, const glm::dvec2& hi,
                glm::dvec3& boxLo, glm::dvec3& boxHi) {
  struct Corner {
    glm::dvec2 uv;
    glm::dvec3 p;
  };
  Corner buffer[2][9];  // a triangle clipped by four half-planes has at most seven corners
  int n = 3;
  for (int k = 0; k < 3; ++k) buffer[0][k] = {uv[k], p[k]};
  int from = 0;
  for (int plane = 0; plane < 4 && n > 0; ++plane) {
    const int axis = plane / 2;
    const bool below = plane % 2 == 1;  // keep uv[axis] <= hi[axis], else uv[axis] >= lo[axis]
    auto inside = [&](const Corner& c) { return below ? c.uv[axis] <= hi[axis] : c.uv[axis] >= lo[axis]; };
    const double bound = below ? hi[axis] : lo[axis];
    const Corner* in = buffer[from];
    Corner* out = buffer[1 - from];
    int m = 0;
    for (int k = 0; k < n; ++k) {
      const Corner& s = in[k];
      const Corner& e = in[(k + 1) % n];
      const bool sIn = inside(s), eIn = inside(e);
      if (sIn) out[m++] = s;
      if (sIn != eIn) {
        const double t = (bound - s.uv[axis]) / (e.uv[axis] - s.uv[axis]);
        out[m++] = {s.uv + t * (e.uv - s.uv), s.p + t * (e.p - s.p)};
      }
    }
    n = m;
    from = 1 - from;
  }
  if (n == 0) return false;
  boxLo = boxHi = buffer[from][0].p;
  for (int k = 1; k < n; ++k) {
    boxLo = glm::min(boxLo, buffer[from][k].p);
    boxHi = glm::max(boxHi, buffer[from][k].p);
  }
  return true;
}
}  // namespace

// The parts of the triangles that lie over changed texels (a lookup at a surface point reads the four texel
// centres around its uv: it reads a changed texel from within a texel and a half of it), each as a box: a lookup
// whose nearest triangle is one of these triangles reads the map there; the boxes, grown by kOnSurface, are where
// lookups happen at all.
void Simulation::findDentedTriangles(DentCopy& d, int i) {
  const TriangleMesh& mesh = *bodies_[static_cast<size_t>(i)].mesh;
  const int r = d.resolution;
  const int across = (r + kDentTile - 1) / kDentTile;
  float highest = 0.5f;
  for (const DentCopy::Tile& tile : d.tiles) highest = std::max(highest, tile.highest);
  d.boxLo = glm::dvec3(1e300);
  d.boxHi = glm::dvec3(-1e300);
  d.overChange.assign(mesh.triangles.size(), 0);
  std::vector<std::pair<glm::dvec3, glm::dvec3>>& pieces = d.pieces;
  pieces.clear();
  if (d.hi.x >= d.lo.x) {
    // A changed texel x is read by a lookup at u r in [x - 0.5, x + 1.5) (past the map's edge: clamped to it).
    auto uvOf = [&](int texel, double past, bool first, bool last) {
      if (first && past < 0) return -1e300;
      if (last && past > 0) return 1e300;
      return (texel + 0.5 + past) / r + (past < 0 ? -1e-9 : 1e-9);
    };
    for (size_t ti = 0; ti < mesh.triangles.size(); ++ti) {
      const glm::ivec4& texels = d.mesh->triangleTexels[ti];
      const glm::ivec2 tlo(texels.x, texels.y), thi(texels.z, texels.w);
      if (thi.x < d.lo.x || thi.y < d.lo.y || tlo.x > d.hi.x || tlo.y > d.hi.y) continue;
      const glm::uvec3& t = mesh.triangles[ti];
      const glm::dvec3 p[3] = {glm::dvec3(mesh.positions[t.x]), glm::dvec3(mesh.positions[t.y]),
                               glm::dvec3(mesh.positions[t.z])};
      const glm::dvec2 uv[3] = {glm::dvec2(mesh.uvs[t.x]), glm::dvec2(mesh.uvs[t.y]), glm::dvec2(mesh.uvs[t.z])};
      for (int ty = tlo.y / kDentTile; ty <= thi.y / kDentTile; ++ty)
        for (int tx = tlo.x / kDentTile; tx <= thi.x / kDentTile; ++tx) {
          const DentCopy::Tile& tile = d.tiles[static_cast<size_t>(ty) * static_cast<size_t>(across) + static_cast<size_t>(tx)];
          // (a tile changed away from the triangle: its lookups there read none of the changed texels)
          if (tile.hi.x < tile.lo.x || thi.x < tile.lo.x - 1 || thi.y < tile.lo.y - 1 || tlo.x > tile.hi.x + 2 ||
              tlo.y > tile.hi.y + 2)
            continue;
          const glm::dvec2 lo(uvOf(tile.lo.x, -1, tile.lo.x == 0, false), uvOf(tile.lo.y, -1, tile.lo.y == 0, false));
          const glm::dvec2 hi(uvOf(tile.hi.x, 1, false, tile.hi.x == r - 1),
                              uvOf(tile.hi.y, 1, false, tile.hi.y == r - 1));
          glm::dvec3 lo3, hi3;
          if (!clippedBox(p, uv, lo, hi, lo3, hi3)) continue;
          pieces.emplace_back(lo3, hi3);
          d.overChange[ti] = 1;
          d.boxLo = glm::min(d.boxLo, lo3);
          d.boxHi = glm::max(d.boxHi, hi3);
        }
    }
    const double grow = std::max(d.k, kOnSurface) * (1 + 1e-9) + 1e-12;
    d.boxLo -= grow;
    d.boxHi += grow;
    markNearChange(d);
  }
  const bool dented = d.boxHi.x >= d.boxLo.x;
  world_.setDented(bodies_[static_cast<size_t>(i)].index, dented ? d.k * std::max(0.0, double(highest) - 0.5) : -1.0,
                   {d.boxLo, d.boxHi});
}

// DentCopy::grid: the cells that a part of a triangle over changed texels, its box grown by kOnSurface, meets (a
// lookup reads a changed texel only where its nearest triangle's point within kOnSurface lies in such a part).
void Simulation::markNearChange(DentCopy& d) {
  const glm::dvec3 size = d.boxHi - d.boxLo;
  d.gridCell = std::max(kGridCell, std::cbrt(size.x * size.y * size.z / kGridCells));
  d.gridLo = d.boxLo;
  d.gridDims = glm::max(glm::ivec3(glm::ceil(size / d.gridCell)), 1);
  d.grid.assign(static_cast<size_t>(d.gridDims.x) * static_cast<size_t>(d.gridDims.y) * static_cast<size_t>(d.gridDims.z), 0);
  const double grow = kOnSurface * (1 + 1e-9) + 1e-12;
  for (const auto& [pieceLo, pieceHi] : d.pieces) {
    const glm::dvec3 lo = pieceLo - grow, hi = pieceHi + grow;
    const glm::ivec3 clo = glm::clamp(glm::ivec3(glm::floor((lo - d.gridLo) / d.gridCell)), glm::ivec3(0), d.gridDims - 1);
    const glm::ivec3 chi = glm::clamp(glm::ivec3(glm::floor((hi - d.gridLo) / d.gridCell)), glm::ivec3(0), d.gridDims - 1);
    for (int z = clo.z; z <= chi.z; ++z)
      for (int y = clo.y; y <= chi.y; ++y)
        std::fill_n(d.grid.begin() + static_cast<std::ptrdiff_t>(d.gridIndex({clo.x, y, z})), chi.x - clo.x + 1, 1);
  }
}

double Simulation::surfaceDepth(int i, const glm::dvec3& p, const glm::dvec3& n, glm::dvec3& bent) const {
  bent = n;
  if (i < 0) return 0;
  const DentCopy& d = dents_[static_cast<size_t>(i)];
  // Only points over dented texels look anything up.
  if (!d.mesh || p.x < d.boxLo.x || p.y < d.boxLo.y || p.z < d.boxLo.z || p.x > d.boxHi.x || p.y > d.boxHi.y ||
      p.z > d.boxHi.z)
    return 0;
  const glm::ivec3 cell = glm::clamp(glm::ivec3(glm::floor((p - d.gridLo) / d.gridCell)), glm::ivec3(0), d.gridDims - 1);
  if (!d.grid[d.gridIndex(cell)]) return 0;
  return lookUpDepth(d, i, p, n, bent);
}

double Simulation::lookUpDepth(const DentCopy& d, int i, const glm::dvec3& p, const glm::dvec3& n, glm::dvec3& bent) const {
  const TriangleMesh& mesh = *bodies_[static_cast<size_t>(i)].mesh;
  // The nearest triangle of the mesh (exact; among equally near ones, as where a mesh holds a face twice, the
  // lowest index). Where it is not over the changed tiles, or further than kOnSurface (more than the collision
  // shape's own error off the surface there), the point lies over the rest of the surface, where the map is as it
  // started: it feels nothing, as points outside the box do. (The triangles over the change reach past it by the
  // rest of its tiles and a texel: a point near their edge reads texels the dent did not touch.)
  const TriangleBvh::Hit hit = d.mesh->near->closest(p);
  if (hit.triangle < 0 || !d.overChange[static_cast<size_t>(hit.triangle)]) return 0;
  const glm::uvec3 t = mesh.triangles[static_cast<size_t>(hit.triangle)];
  const glm::dvec2 uv0(mesh.uvs[t.x]), uv1(mesh.uvs[t.y]), uv2(mesh.uvs[t.z]);
  const glm::dvec2 uv = hit.barycentric.x * uv0 + hit.barycentric.y * uv1 + hit.barycentric.z * uv2;
  const int r = d.resolution;
  // The height and its derivatives in uv, bilinear between texel centres.
  const glm::dvec2 f = uv * double(r) - 0.5;
  const glm::ivec2 base(static_cast<int>(std::floor(f.x)), static_cast<int>(std::floor(f.y)));
  if (base.x + 1 < d.lo.x - 1 || base.y + 1 < d.lo.y - 1 || base.x > d.hi.x + 1 || base.y > d.hi.y + 1) return 0;
  auto at = [&](int x, int y) { return double(d.height(std::clamp(x, 0, r - 1), std::clamp(y, 0, r - 1))); };
  const double fx = f.x - base.x, fy = f.y - base.y;
  const double h00 = at(base.x, base.y), h10 = at(base.x + 1, base.y), h01 = at(base.x, base.y + 1),
               h11 = at(base.x + 1, base.y + 1);
  const double h = (h00 * (1 - fx) + h10 * fx) * (1 - fy) + (h01 * (1 - fx) + h11 * fx) * fy;
  const double hu = ((h10 - h00) * (1 - fy) + (h11 - h01) * fy) * r;  // dh/du
  const double hv = ((h01 - h00) * (1 - fx) + (h11 - h10) * fx) * r;  // dh/dv
  // The dented surface P + n k (h - 0.5): its tangents dP/du + n k dh/du, dP/dv + n k dh/dv.
  const UvFrame& frame = d.mesh->frames[static_cast<size_t>(hit.triangle)];
  if (frame.det != 0) {
    glm::dvec3 m = glm::cross(frame.dPdu + n * (d.k * hu), frame.dPdv + n * (d.k * hv));
    if (glm::dot(m, n) < 0) m = -m;
    const double len = glm::length(m);
    if (len > 1e-12) bent = m / len;
  }
  return d.k * (0.5 - h);
}

}  // namespace crumple
