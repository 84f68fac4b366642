#include "deform/surface.h"

#include <cmath>
#include <map>
#include <tuple>
#include <vector>

namespace crumple::deform {

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
  vertices = render::Buffer::fromVector(v);
  indices = render::Buffer::fromVector(idx);
  indexCount = static_cast<GLsizei>(idx.size());
  boundsMin = mesh.boundsMin();
  boundsMax = mesh.boundsMax();
  const GLuint a = vao.id();
  glVertexArrayVertexBuffer(a, 0, vertices.id(), 0, kFloats * sizeof(float));
  glVertexArrayElementBuffer(a, indices.id());
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

void GpuMesh::draw() const {
  glBindVertexArray(vao.id());
  glDrawElements(GL_TRIANGLES, indexCount, GL_UNSIGNED_INT, nullptr);
}

SurfaceMaps::SurfaceMaps(int resolution)
    : height(resolution, resolution, GL_R32F), normal(resolution, resolution, GL_RGBA8) {}

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
  maps_ = std::move(own);
}

render::Image Surface::downloadHeight() const {
  render::Image img(resolution_, resolution_, 1);
  maps_->height.download(GL_RED, GL_FLOAT, img.pixels.data(), img.pixels.size() * sizeof(float));
  return img;
}

}  // namespace crumple::deform
