#include <crumple/render/look.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace crumple::render {

namespace {

// Bilinear resampling of an RGBA8 image to w x h (texel centres aligned).
std::vector<uint8_t> resample(const LookImage& im, int w, int h) {
  if (im.width == w && im.height == h) return im.rgba;
  std::vector<uint8_t> out(static_cast<size_t>(w) * h * 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float fx = std::clamp((x + 0.5f) * im.width / w - 0.5f, 0.0f, im.width - 1.0f);
      const float fy = std::clamp((y + 0.5f) * im.height / h - 0.5f, 0.0f, im.height - 1.0f);
      const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
      const int x1 = std::min(x0 + 1, im.width - 1), y1 = std::min(y0 + 1, im.height - 1);
      const float tx = fx - x0, ty = fy - y0;
      for (int c = 0; c < 4; ++c) {
        auto at = [&](int xx, int yy) { return float(im.rgba[(static_cast<size_t>(yy) * im.width + xx) * 4 + c]); };
        const float v = (at(x0, y0) * (1 - tx) + at(x1, y0) * tx) * (1 - ty) + (at(x0, y1) * (1 - tx) + at(x1, y1) * tx) * ty;
        out[(static_cast<size_t>(y) * w + x) * 4 + c] = static_cast<uint8_t>(std::lround(std::clamp(v, 0.0f, 255.0f)));
      }
    }
  return out;
}

// A mipmapped, repeating texture array of the given images (indices into look.images), all at w x h.
GLuint makeArray(const Look& look, const std::vector<int>& images, GLenum format, int w, int h) {
  if (images.empty()) return 0;
  GLuint id = 0;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &id);
  const int levels = 1 + static_cast<int>(std::floor(std::log2(std::max(w, h))));
  glTextureStorage3D(id, levels, format, w, h, static_cast<GLsizei>(images.size()));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  for (size_t layer = 0; layer < images.size(); ++layer) {
    const std::vector<uint8_t> px = resample(look.images[static_cast<size_t>(images[layer])], w, h);
    glTextureSubImage3D(id, 0, 0, 0, static_cast<GLint>(layer), w, h, 1, GL_RGBA, GL_UNSIGNED_BYTE, px.data());
  }
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glGenerateTextureMipmap(id);
  glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_REPEAT);
  return id;
}

}  // namespace

GpuLook::GpuLook(const Look& look) {
  // Which images are colour (sRGB) and which data (linear); an image may be both.
  std::map<int, int> srgbLayer, linearLayer;
  std::vector<int> srgbImages, linearImages;
  auto valid = [&](int i) { return i >= 0 && i < static_cast<int>(look.images.size()) && look.images[size_t(i)].width > 0; };
  auto layerOf = [&](int image, std::map<int, int>& layers, std::vector<int>& list) {
    if (!valid(image)) return -1;
    auto [it, inserted] = layers.try_emplace(image, static_cast<int>(list.size()));
    if (inserted) list.push_back(image);
    return it->second;
  };
  const size_t n = std::min(look.materials.size(), static_cast<size_t>(kMaxLookMaterials));
  for (size_t i = 0; i < n; ++i) {
    const LookMaterial& m = look.materials[i];
    baseColor.push_back(m.baseColor);
    params.push_back({m.metallic, m.roughness, m.normalScale, m.occlusionStrength});
    emissive.push_back({m.emissive, static_cast<float>(layerOf(m.emissiveImage, srgbLayer, srgbImages))});
    layers.push_back({layerOf(m.baseColorImage, srgbLayer, srgbImages),
                      layerOf(m.metallicRoughnessImage, linearLayer, linearImages),
                      layerOf(m.normalImage, linearLayer, linearImages),
                      layerOf(m.occlusionImage, linearLayer, linearImages)});
  }
  int w = 1, h = 1;
  for (int i : srgbImages) w = std::max(w, look.images[size_t(i)].width), h = std::max(h, look.images[size_t(i)].height);
  for (int i : linearImages) w = std::max(w, look.images[size_t(i)].width), h = std::max(h, look.images[size_t(i)].height);
  w = std::min(w, 2048);
  h = std::min(h, 2048);
  srgb_ = gl::GlName<gl::detail::deleteTexture>(makeArray(look, srgbImages, GL_SRGB8_ALPHA8, w, h));
  linear_ = gl::GlName<gl::detail::deleteTexture>(makeArray(look, linearImages, GL_RGBA8, w, h));
}

}  // namespace crumple::render
