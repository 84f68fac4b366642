// A mesh file's own looks in glTF's metallic-roughness model (read by engine/mesh_gltf.cpp), and their GPU copy:
// per material the factors and which images it uses; the images in two texture arrays (colour images sRGB, data
// images linear), made once per asset and shared by every body of that mesh. The renderer picks the material per
// vertex (TriangleMesh::materialIds) and samples with the file's own uvs (TriangleMesh::materialUvs).
#pragma once
#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

#include <crumple/gl/objects.h>

namespace crumple::render {

struct LookImage {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;  // row 0 = v 0 (glTF's top row), 4 bytes a texel
};

struct LookMaterial {
  glm::vec4 baseColor{1};  // linear RGBA factor
  float metallic = 1, roughness = 1;
  float normalScale = 1, occlusionStrength = 1;
  glm::vec3 emissive{0};  // linear
  // Indices into Look::images, -1 for none. Metallic is read from blue, roughness from green (glTF).
  int baseColorImage = -1, metallicRoughnessImage = -1, normalImage = -1, occlusionImage = -1, emissiveImage = -1;
};

struct Look {
  std::vector<LookMaterial> materials;
  std::vector<LookImage> images;
  bool empty() const { return materials.empty(); }
};

// The renderer's copy. At most kMaxLookMaterials materials are used (later ones draw as the last);
// images are resampled to one size (the largest, at most 2048) to share an array.
constexpr int kMaxLookMaterials = 16;
class GpuLook {
 public:
  explicit GpuLook(const Look& look);
  GLuint srgbArray() const { return srgb_.id(); }      // 0 when no material uses a colour image
  GLuint linearArray() const { return linear_.id(); }  // 0 when no material uses a data image
  int materialCount() const { return static_cast<int>(baseColor.size()); }
  // Per material, for the shader's uniform arrays.
  std::vector<glm::vec4> baseColor;  // linear factor
  std::vector<glm::vec4> params;     // metallic, roughness, normal scale, occlusion strength
  std::vector<glm::vec4> emissive;   // rgb, and the emissive image's layer in the sRGB array (-1 none)
  std::vector<glm::ivec4> layers;    // base colour (sRGB array), metallic-roughness, normal, occlusion (linear); -1 none

 private:
  gl::GlName<gl::detail::deleteTexture> srgb_, linear_;
};

}  // namespace crumple::render
