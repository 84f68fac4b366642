// A procedural surface (render/surface_texture.h) baked into a mesh's atlas: what an export carries so that a
// glTF viewer shows the surface crumple draws.
#pragma once
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include <crumple/physics/mesh.h>
#include <crumple/render/renderer.h>

namespace crumple {

// A material's "texture" (docs/scene-format.md) as the renderer's procedural surface (unknown names: none).
render::SurfaceTexture surfaceTextureNamed(const std::string& name);

// A surface baked into the atlas of `mesh` (its uvs, one-to-one) at size x size texels: per texel the linear
// base colour `color` (linear RGB) times the albedo and the roughness `roughness` plus its offset, at the mesh
// point the texel's centre maps to. Texels no triangle covers take their nearest covered neighbour's values
// (a gutter, so that filtering at chart edges does not bleed the background in).
struct BakedSurface {
  int size = 0;
  std::vector<glm::vec3> color;   // linear RGB, row-major from uv (0, 0)
  std::vector<float> roughness;
  int covered = 0;                // texels a triangle covers
};
BakedSurface bakeSurface(const TriangleMesh& mesh, int size, render::SurfaceTexture texture, float textureScale,
                         const glm::vec3& color, float roughness);

}  // namespace crumple
