#include <crumple/engine/surface_bake.h>

#include <algorithm>
#include <cmath>

#include <crumple/render/surface_texture.h>

namespace crumple {

render::SurfaceTexture surfaceTextureNamed(const std::string& name) {
  return name == "asphalt"    ? render::SurfaceTexture::Asphalt
         : name == "concrete" ? render::SurfaceTexture::Concrete
         : name == "clay"     ? render::SurfaceTexture::Clay
                              : render::SurfaceTexture::None;
}

BakedSurface bakeSurface(const TriangleMesh& mesh, int size, render::SurfaceTexture texture, float textureScale,
                         const glm::vec3& color, float roughness) {
  BakedSurface out;
  out.size = size;
  const size_t texels = static_cast<size_t>(size) * static_cast<size_t>(size);
  out.color.assign(texels, glm::vec3(0));
  out.roughness.assign(texels, 0.0f);
  std::vector<char> done(texels, 0);
  const float scale = std::max(textureScale, 1e-3f);
  for (const glm::uvec3& t : mesh.triangles) {
    const glm::vec2 uv[3] = {mesh.uvs[t.x] * float(size), mesh.uvs[t.y] * float(size), mesh.uvs[t.z] * float(size)};
    const glm::vec3 p[3] = {mesh.positions[t.x], mesh.positions[t.y], mesh.positions[t.z]};
    const float areaUv = 0.5f * ((uv[1].x - uv[0].x) * (uv[2].y - uv[0].y) - (uv[2].x - uv[0].x) * (uv[1].y - uv[0].y));
    if (std::abs(areaUv) < 1e-12f) continue;
    // A texel's footprint in the texture's units: the metres a texel spans here, over the scale.
    const float area3 = 0.5f * glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
    const float footprint = std::sqrt(area3 / std::abs(areaUv)) / scale;
    const glm::vec2 lo = glm::min(uv[0], glm::min(uv[1], uv[2])), hi = glm::max(uv[0], glm::max(uv[1], uv[2]));
    const int x0 = std::max(0, static_cast<int>(std::floor(lo.x))), x1 = std::min(size - 1, static_cast<int>(hi.x));
    const int y0 = std::max(0, static_cast<int>(std::floor(lo.y))), y1 = std::min(size - 1, static_cast<int>(hi.y));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        // The texel's centre in barycentric coordinates (edges shared by two triangles: either may fill it).
        const glm::vec2 c(x + 0.5f, y + 0.5f);
        const float b1 = ((c.x - uv[0].x) * (uv[2].y - uv[0].y) - (uv[2].x - uv[0].x) * (c.y - uv[0].y)) / (2 * areaUv);
        const float b2 = ((uv[1].x - uv[0].x) * (c.y - uv[0].y) - (c.x - uv[0].x) * (uv[1].y - uv[0].y)) / (2 * areaUv);
        const float b0 = 1.0f - b1 - b2;
        if (b0 < -1e-4f || b1 < -1e-4f || b2 < -1e-4f) continue;
        const size_t i = static_cast<size_t>(y) * static_cast<size_t>(size) + static_cast<size_t>(x);
        if (done[i]) continue;
        const glm::vec2 s = render::surfaceTexture(texture, (b0 * p[0] + b1 * p[1] + b2 * p[2]) / scale, footprint);
        out.color[i] = color * s.x;
        out.roughness[i] = std::clamp(roughness + s.y, 0.0f, 1.0f);
        done[i] = 1;
        ++out.covered;
      }
  }
  // The gutter: uncovered texels take a covered neighbour's values, ring by ring (eight rings).
  for (int ring = 0; ring < 8; ++ring) {
    std::vector<char> next = done;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const size_t i = static_cast<size_t>(y) * static_cast<size_t>(size) + static_cast<size_t>(x);
        if (done[i]) continue;
        for (int k = 0; k < 4 && !next[i]; ++k) {
          const int nx = x + (k == 0) - (k == 1), ny = y + (k == 2) - (k == 3);
          if (nx < 0 || ny < 0 || nx >= size || ny >= size) continue;
          const size_t j = static_cast<size_t>(ny) * static_cast<size_t>(size) + static_cast<size_t>(nx);
          if (!done[j]) continue;
          out.color[i] = out.color[j];
          out.roughness[i] = out.roughness[j];
          next[i] = 1;
        }
      }
    done.swap(next);
  }
  return out;
}

}  // namespace crumple
