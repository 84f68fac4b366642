#include <crumple/deform/surface.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <meshoptimizer.h>
#include <tuple>
#include <unordered_map>
#include <vector>

namespace crumple::deform {

namespace {
// The vertex layout of GpuMesh::vertices (17 floats) on vertex array `a`, with its index buffer.
void describeVertices(GLuint a, GLuint vertexBuffer, GLuint indexBuffer) {
  glVertexArrayVertexBuffer(a, 0, vertexBuffer, 0, 17 * sizeof(float));
  glVertexArrayElementBuffer(a, indexBuffer);
  for (GLuint k = 0; k < 7; ++k) {
    glEnableVertexArrayAttrib(a, k);
    glVertexArrayAttribBinding(a, k, 0);
  }
  glVertexArrayAttribFormat(a, 0, 3, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribFormat(a, 1, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float));
  glVertexArrayAttribFormat(a, 2, 2, GL_FLOAT, GL_FALSE, 6 * sizeof(float));
  glVertexArrayAttribFormat(a, 3, 3, GL_FLOAT, GL_FALSE, 8 * sizeof(float));
  glVertexArrayAttribFormat(a, 4, 2, GL_FLOAT, GL_FALSE, 11 * sizeof(float));  // the file's material uv
  glVertexArrayAttribFormat(a, 5, 1, GL_FLOAT, GL_FALSE, 13 * sizeof(float));  // its material, -1 none
  glVertexArrayAttribFormat(a, 6, 3, GL_FLOAT, GL_FALSE, 14 * sizeof(float));  // the smooth normal
}

// GpuMesh's simplified triangles (indices into the same vertices). Vertices split at one position (uv seams,
// hard edges, colour or material borders) stay split: meshoptimizer's simplifier moves such seams only along
// themselves, so every kept triangle keeps its own uvs and the atlas still maps it one-to-one; open borders are
// locked. Where seams leave little to collapse the triangles stay as they are. Either way they are ordered for
// the vertex cache.
std::vector<uint32_t> simplifiedTriangles(const std::vector<float>& v, size_t floats, const std::vector<uint32_t>& idx) {
  const size_t vertexCount = v.size() / floats;
  const float scale = meshopt_simplifyScale(v.data(), vertexCount, floats * sizeof(float));
  std::vector<uint32_t> out(idx.size());
  size_t n = 0;
  if (scale > 0)
    n = meshopt_simplify(out.data(), idx.data(), idx.size(), v.data(), vertexCount, floats * sizeof(float),
                         idx.size() / 8 / 3 * 3, GpuMesh::kSimplifyError / scale, meshopt_SimplifyLockBorder);
  if (n == 0) {
    out = idx;
    n = idx.size();
  }
  out.resize(n);
  meshopt_optimizeVertexCache(out.data(), out.data(), n, vertexCount);
  return out;
}

// The shadow caster: positions alone, welded where they coincide (no seams), simplified while the surface
// moves at most GpuMesh::kShadowError metres, ordered for the vertex cache, unused vertices dropped.
void shadowMesh(const std::vector<float>& v, size_t floats, const std::vector<uint32_t>& idx,
                std::vector<float>& positions, std::vector<uint32_t>& triangles) {
  const size_t count = v.size() / floats;
  std::vector<float> p(count * 3);
  for (size_t i = 0; i < count; ++i)
    for (int k = 0; k < 3; ++k) p[i * 3 + k] = v[i * floats + k];
  std::vector<uint32_t> remap(count);
  const size_t unique = meshopt_generateVertexRemap(remap.data(), idx.data(), idx.size(), p.data(), count, 12);
  std::vector<uint32_t> welded(idx.size());
  meshopt_remapIndexBuffer(welded.data(), idx.data(), idx.size(), remap.data());
  std::vector<float> q(unique * 3);
  meshopt_remapVertexBuffer(q.data(), p.data(), count, 12, remap.data());
  const float scale = meshopt_simplifyScale(q.data(), unique, 12);
  triangles.assign(welded.size(), 0);
  size_t n = 0;
  if (scale > 0)
    n = meshopt_simplify(triangles.data(), welded.data(), welded.size(), q.data(), unique, 12, welded.size() / 20 / 3 * 3,
                         GpuMesh::kShadowError / scale, meshopt_SimplifyLockBorder);
  if (n == 0) {
    triangles = welded;
    n = welded.size();
  }
  triangles.resize(n);
  meshopt_optimizeVertexCache(triangles.data(), triangles.data(), n, unique);
  positions.assign(unique * 3, 0.0f);
  const size_t used = meshopt_optimizeVertexFetch(positions.data(), triangles.data(), n, q.data(), unique, 12);
  positions.resize(used * 3);
}

// Where a mesh's uv charts meet (the displaced renderer reads both sides' heights there, so a seam does not split
// open where the two charts hold different dents): per triangle edge (the edge opposite corner e is entry
// 3 t + e), the other chart's uv at the edge's two ends, corner (e + 1) % 3's first (the triangle across the
// edge whose uvs differ), or -1 where there is none; per vertex two entries, the uvs of up to three other
// vertices at its position with other uvs and their count. `at`: each vertex's position number (positionNumbers).
void seamTables(const TriangleMesh& mesh, const std::vector<uint32_t>& at, std::vector<glm::vec4>& edges,
                std::vector<glm::vec4>& vertices) {
  const size_t count = mesh.positions.size();
  edges.assign(mesh.triangles.size() * 3, glm::vec4(-1));
  vertices.assign(count * 2, glm::vec4(0));
  if (mesh.uvs.size() != count || count == 0) return;
  std::vector<std::vector<uint32_t>> sharing(count);
  for (uint32_t i = 0; i < count; ++i) sharing[at[i]].push_back(i);
  for (uint32_t i = 0; i < count; ++i) {
    glm::vec2 others[3];
    int n = 0;
    for (uint32_t j : sharing[at[i]]) {
      const glm::vec2 uv = mesh.uvs[j];
      if (n == 3 || uv == mesh.uvs[i] || std::find(others, others + n, uv) != others + n) continue;
      others[n++] = uv;
    }
    vertices[2 * i] = glm::vec4(others[0], others[1]);
    vertices[2 * i + 1] = glm::vec4(others[2], static_cast<float>(n), 0.0f);
  }
  // The triangle edges by the positions at their ends.
  std::unordered_map<uint64_t, std::vector<uint32_t>> byEnds;  // -> 3 t + e
  auto ends = [&](uint32_t t, int e) {
    const glm::uvec3& tri = mesh.triangles[t];
    return std::make_pair(tri[(e + 1) % 3], tri[(e + 2) % 3]);
  };
  for (uint32_t t = 0; t < mesh.triangles.size(); ++t)
    for (int e = 0; e < 3; ++e) {
      const auto [a, b] = ends(t, e);
      if (at[a] == at[b]) continue;
      const uint64_t lo = std::min(at[a], at[b]), hi = std::max(at[a], at[b]);
      byEnds[lo << 32 | hi].push_back(3 * t + static_cast<uint32_t>(e));
    }
  for (const auto& [k, list] : byEnds)
    for (uint32_t mine : list) {
      const auto [a, b] = ends(mine / 3, static_cast<int>(mine % 3));
      for (uint32_t other : list) {
        if (other == mine) continue;
        auto [c, d] = ends(other / 3, static_cast<int>(other % 3));
        if (at[c] != at[a]) std::swap(c, d);  // c at a's position, d at b's
        if (mesh.uvs[c] == mesh.uvs[a] && mesh.uvs[d] == mesh.uvs[b]) continue;  // the same chart
        edges[mine] = glm::vec4(mesh.uvs[c], mesh.uvs[d]);
        break;
      }
    }
}


// Each vertex's position number, the same for every vertex at one position (numbered 0.. in order of first use);
// returns how many positions there are.
size_t positionNumbers(const TriangleMesh& mesh, std::vector<uint32_t>& at) {
  const size_t count = mesh.positions.size();
  at.resize(count);
  if (count == 0) return 0;
  return meshopt_generateVertexRemap(at.data(), nullptr, count, mesh.positions.data(), count, sizeof(glm::vec3));
}

// The crease bevel's graph (GpuMesh::nodeUvs, nodeLinks, nodeFrames): the mesh's positions as nodes (`at`, a
// vertex's node, and `nodes`: positionNumbers); per node the distinct uvs of its vertices and the other nodes it
// shares a triangle edge with, with the edge's length (each list as CSR: nodes + 1 offsets, then the entries,
// offsets counted from the first entry); per node its position and the normal averaged over its vertices (two
// vec4). Returns the number of nodes, 0 where the mesh has no uvs; `shortEdge` is a short edge of the mesh (its
// 5th percentile).
GLuint creaseGraph(const TriangleMesh& mesh, const std::vector<uint32_t>& at, size_t nodes, std::vector<GLuint>& uvs,
                   std::vector<GLuint>& links, std::vector<glm::vec4>& frames, float& shortEdge) {
  const size_t count = mesh.positions.size();
  if (mesh.uvs.size() != count || mesh.normals.size() != count || count == 0 || mesh.triangles.empty()) return 0;
  const std::vector<uint32_t>& vertexNode = at;  // (the nodes are the positions)
  std::vector<std::vector<glm::vec2>> nodeUvs(nodes);
  frames.assign(nodes * 2, glm::vec4(0));
  for (size_t i = 0; i < count; ++i) {
    const GLuint n = vertexNode[i];
    std::vector<glm::vec2>& list = nodeUvs[n];
    if (std::find(list.begin(), list.end(), mesh.uvs[i]) == list.end()) list.push_back(mesh.uvs[i]);
    frames[2 * n] = glm::vec4(mesh.positions[i], 1.0f);
    frames[2 * n + 1] += glm::vec4(mesh.normals[i], 0.0f);
  }
  for (size_t n = 0; n < nodes; ++n) {
    const glm::vec3 s(frames[2 * n + 1]);
    frames[2 * n + 1] = glm::vec4(glm::length(s) > 1e-6f ? glm::normalize(s) : glm::vec3(0), 0.0f);
  }
  std::vector<std::vector<std::pair<GLuint, float>>> near(nodes);
  std::vector<float> lengths;
  for (const glm::uvec3& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      const GLuint a = vertexNode[t[e]], b = vertexNode[t[(e + 1) % 3]];
      if (a == b) continue;
      const float length = glm::distance(mesh.positions[t[e]], mesh.positions[t[(e + 1) % 3]]);
      for (const std::pair<GLuint, GLuint>& link : {std::make_pair(a, b), std::make_pair(b, a)}) {
        auto& list = near[link.first];
        const GLuint to = link.second;  // (a structured binding cannot be captured before C++20)
        if (std::none_of(list.begin(), list.end(), [&](const auto& l) { return l.first == to; }))
          list.emplace_back(to, length);
      }
      lengths.push_back(length);
    }
  auto bits = [](float f) {
    GLuint u;
    std::memcpy(&u, &f, sizeof u);
    return u;
  };
  auto csr = [&](std::vector<GLuint>& out, auto size, auto put) {
    out.assign(nodes + 1, 0);
    for (size_t n = 0; n < nodes; ++n) out[n + 1] = out[n] + static_cast<GLuint>(size(n));
    for (size_t n = 0; n < nodes; ++n) put(n, out);
  };
  csr(uvs, [&](size_t n) { return nodeUvs[n].size(); }, [&](size_t n, std::vector<GLuint>& out) {
    for (const glm::vec2& uv : nodeUvs[n]) out.insert(out.end(), {bits(uv.x), bits(uv.y)});
  });
  csr(links, [&](size_t n) { return near[n].size(); }, [&](size_t n, std::vector<GLuint>& out) {
    for (const auto& [to, length] : near[n]) out.insert(out.end(), {to, bits(length)});
  });
  std::nth_element(lengths.begin(), lengths.begin() + static_cast<long>(lengths.size() / 20), lengths.end());
  shortEdge = std::max(lengths[lengths.size() / 20], 1e-6f);
  return static_cast<GLuint>(nodes);
}
}  // namespace

GpuMesh::GpuMesh(const TriangleMesh& mesh) {
  std::vector<float> v;
  constexpr int kFloats = 17;
  // The normal averaged over the vertices at one position (the displaced renderer moves vertices along it, so hard
  // edges and chart seams stay closed).
  std::map<std::tuple<float, float, float>, glm::vec3> smooth;
  for (size_t i = 0; i < mesh.positions.size() && i < mesh.normals.size(); ++i) {
    const glm::vec3 p = mesh.positions[i];
    smooth[{p.x, p.y, p.z}] += mesh.normals[i];
  }
  v.reserve(mesh.positions.size() * kFloats);
  const bool looks = mesh.materialUvs.size() == mesh.positions.size() && mesh.materialIds.size() == mesh.positions.size();
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const glm::vec3 p = mesh.positions[i];
    const glm::vec3 n = i < mesh.normals.size() ? mesh.normals[i] : glm::vec3(0, 1, 0);
    const glm::vec2 t = i < mesh.uvs.size() ? mesh.uvs[i] : glm::vec2(0);
    const glm::vec3 c = i < mesh.colors.size() ? mesh.colors[i] : glm::vec3(1);
    const glm::vec2 mt = looks ? mesh.materialUvs[i] : glm::vec2(0);
    const float mid = looks ? static_cast<float>(mesh.materialIds[i]) : -1.0f;
    glm::vec3 sn = smooth.count({p.x, p.y, p.z}) ? smooth[{p.x, p.y, p.z}] : n;
    sn = glm::length(sn) > 1e-6f ? glm::normalize(sn) : n;
    v.insert(v.end(), {p.x, p.y, p.z, n.x, n.y, n.z, t.x, t.y, c.x, c.y, c.z, mt.x, mt.y, mid, sn.x, sn.y, sn.z});
  }
  std::vector<uint32_t> idx;
  idx.reserve(mesh.triangles.size() * 3);
  double area3 = 0, areaUv = 0;
  for (const auto& t : mesh.triangles) {
    idx.insert(idx.end(), {t.x, t.y, t.z});
    area3 += 0.5 * glm::length(glm::cross(glm::dvec3(mesh.positions[t.y] - mesh.positions[t.x]),
                                          glm::dvec3(mesh.positions[t.z] - mesh.positions[t.x])));
    if (!mesh.uvs.empty()) {
      const glm::dvec2 a = mesh.uvs[t.x], b = mesh.uvs[t.y], c = mesh.uvs[t.z];
      areaUv += 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    }
  }
  metresPerUv = areaUv > 0 ? std::sqrt(area3 / areaUv) : 1.0;
  vertices = gl::Buffer::fromVector(v);
  indices = gl::Buffer::fromVector(idx);
  indexCount = static_cast<GLsizei>(idx.size());
  boundsMin = mesh.boundsMin();
  boundsMax = mesh.boundsMax();
  describeVertices(vao.id(), vertices.id(), indices.id());
  std::vector<uint32_t> at;
  const size_t positions = positionNumbers(mesh, at);
  std::vector<glm::vec4> edges, shared;
  seamTables(mesh, at, edges, shared);
  if (!edges.empty() && !shared.empty()) {
    seamEdges = gl::Buffer::fromVector(edges);
    seamVertices = gl::Buffer::fromVector(shared);
  }
  {
    std::vector<GLuint> uvs, links;
    std::vector<glm::vec4> frames;
    nodeCount = creaseGraph(mesh, at, positions, uvs, links, frames, shortEdge);
    if (nodeCount > 0) {
      vertexNodes = gl::Buffer::fromVector(at);  // a vertex's node: its position's number
      nodeUvs = gl::Buffer::fromVector(uvs);
      nodeLinks = gl::Buffer::fromVector(links);
      nodeFrames = gl::Buffer::fromVector(frames);
    }
  }
  if (mesh.triangles.size() > kSimplifyAbove) {
    const std::vector<uint32_t> fewer = simplifiedTriangles(v, kFloats, idx);
    simplifiedIndices = gl::Buffer::fromVector(fewer);
    simplifiedIndexCount = static_cast<GLsizei>(fewer.size());
    describeVertices(simplifiedVao.id(), vertices.id(), simplifiedIndices.id());
    std::vector<float> positions;
    std::vector<uint32_t> triangles;
    shadowMesh(v, kFloats, idx, positions, triangles);
    shadowVertices = gl::Buffer::fromVector(positions);
    shadowIndices = gl::Buffer::fromVector(triangles);
    shadowIndexCount = static_cast<GLsizei>(triangles.size());
    const GLuint a = shadowVao.id();
    glVertexArrayVertexBuffer(a, 0, shadowVertices.id(), 0, 3 * sizeof(float));
    glVertexArrayElementBuffer(a, shadowIndices.id());
    glEnableVertexArrayAttrib(a, 0);
    glVertexArrayAttribBinding(a, 0, 0);
    glVertexArrayAttribFormat(a, 0, 3, GL_FLOAT, GL_FALSE, 0);
  }
}

void GpuMesh::draw() const {
  glBindVertexArray(vao.id());
  glDrawElements(GL_TRIANGLES, indexCount, GL_UNSIGNED_INT, nullptr);
}

namespace {
int log2Floor(int n) {
  int l = 0;
  while ((2 << l) <= n) ++l;
  return l;
}
}  // namespace

int SurfaceMaps::boundSize(int resolution) {
  const int tiles = (resolution + kBoundTile - 1) / kBoundTile;
  int size = 1;
  while (size < tiles) size *= 2;
  return size;
}
int SurfaceMaps::boundLevels() const { return log2Floor(bound.height()) + 1; }

SurfaceMaps::SurfaceMaps(int resolution)
    : height(resolution, resolution, GL_R32F, log2Floor(resolution) + 1),
      normal(resolution, resolution, GL_RGBA8),
      bound(boundSize(resolution) + boundSize(resolution) / 2, boundSize(resolution), GL_R32F) {
  const float zero = 0.0f;  // the padding past the map's tiles stays 0; the rest is written with the normals
  glClearTexImage(bound.id(), 0, GL_RED, GL_FLOAT, &zero);
  bound.setFilter(GL_NEAREST, GL_NEAREST);
  height.setFilter(GL_LINEAR, GL_LINEAR);  // its level 0 alone, but for the displaced renderer's own sampler
}

Surface::Surface(std::shared_ptr<const GpuMesh> mesh, int resolution, float bumpDepth, float bumpDepthCollide,
                 std::shared_ptr<SurfaceMaps> shared)
    : mesh_(std::move(mesh)),
      maps_(std::move(shared)),
      resolution_(resolution),
      k_(bumpDepth),
      kCollide_(bumpDepthCollide) {}

void Surface::makeUnique() {
  if (maps_.use_count() <= 1) return;
  auto own = std::make_shared<SurfaceMaps>(resolution_);
  glCopyImageSubData(maps_->height.id(), GL_TEXTURE_2D, 0, 0, 0, 0, own->height.id(), GL_TEXTURE_2D, 0, 0, 0, 0,
                     resolution_, resolution_, 1);
  glCopyImageSubData(maps_->normal.id(), GL_TEXTURE_2D, 0, 0, 0, 0, own->normal.id(), GL_TEXTURE_2D, 0, 0, 0, 0,
                     resolution_, resolution_, 1);
  glCopyImageSubData(maps_->bound.id(), GL_TEXTURE_2D, 0, 0, 0, 0, own->bound.id(), GL_TEXTURE_2D, 0, 0, 0, 0,
                     own->bound.width(), own->bound.height(), 1);
  glGenerateTextureMipmap(own->height.id());
  own->highest = maps_->highest;
  own->imageHighest = maps_->imageHighest;
  own->version = maps_->version;
  maps_ = std::move(own);
}

gl::Image Surface::downloadHeight() const {
  gl::Image img(resolution_, resolution_, 1);
  maps_->height.download(GL_RED, GL_FLOAT, img.pixels.data(), img.pixels.size() * sizeof(float));
  return img;
}

}  // namespace crumple::deform
