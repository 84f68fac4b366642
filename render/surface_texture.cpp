#include <crumple/render/surface_texture.h>

#include <algorithm>
#include <cmath>

namespace crumple::render {

namespace {
// pom.frag's functions, in the same float arithmetic (GLSL's fract is x - floor(x)).
float fract(float x) { return x - std::floor(x); }
glm::vec3 fract(const glm::vec3& v) { return v - glm::floor(v); }
float hash3(glm::vec3 p) {
  p = fract(p * glm::vec3(0.1031f, 0.1030f, 0.0973f));
  p += glm::dot(p, glm::vec3(p.y, p.x, p.z) + 33.33f);
  return fract((p.x + p.y) * p.z);
}
float valueNoise(const glm::vec3& x) {
  const glm::vec3 i = glm::floor(x);
  glm::vec3 f = fract(x);
  f = f * f * (3.0f - 2.0f * f);
  auto h = [&](float a, float b, float c) { return hash3(i + glm::vec3(a, b, c)); };
  return glm::mix(glm::mix(glm::mix(h(0, 0, 0), h(1, 0, 0), f.x), glm::mix(h(0, 1, 0), h(1, 1, 0), f.x), f.y),
                  glm::mix(glm::mix(h(0, 0, 1), h(1, 0, 1), f.x), glm::mix(h(0, 1, 1), h(1, 1, 1), f.x), f.y), f.z);
}
float fadeFor(float frequency, float footprint) { return std::clamp(2.0f - 4.0f * frequency * footprint, 0.0f, 1.0f); }
float fbm(const glm::vec3& p, float frequency, int octaves, float footprint) {
  float sum = 0, amplitude = 0.5f, total = 0;
  for (int i = 0; i < octaves; ++i) {
    sum += amplitude * glm::mix(0.5f, valueNoise(p * frequency + static_cast<float>(i) * 17.31f),
                                fadeFor(frequency, footprint));
    total += amplitude;
    amplitude *= 0.5f;
    frequency *= 2.03f;
  }
  return sum / total;
}
float smoothstep(float a, float b, float x) {
  const float t = std::clamp((x - a) / (b - a), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}
}  // namespace

glm::vec2 surfaceTexture(SurfaceTexture texture, const glm::vec3& q, float footprint) {
  switch (texture) {
    case SurfaceTexture::Asphalt: {
      // Worn and tar-darkened patches of a metre or two, 2 cm grain, pale stone chips.
      const float patches = fbm(q, 0.6f, 3, footprint);
      const float grain = fbm(q, 45.0f, 2, footprint);
      const float chips = smoothstep(0.74f, 0.8f, valueNoise(q * 110.0f + 5.0f)) * fadeFor(110.0f, footprint);
      const float tar = smoothstep(0.45f, 0.8f, patches);
      const float albedo = glm::mix(1.1f, 0.84f, tar) * glm::mix(0.82f, 1.18f, grain) + 0.7f * chips;
      return {albedo, 0.12f * (grain - 0.5f) - 0.15f * tar};
    }
    case SurfaceTexture::Concrete: {
      // Cloudy mottling, faint larger stains, pores of a centimetre or so.
      const float mottle = fbm(q, 0.9f, 4, footprint);
      const float stains = fbm(q + 31.0f, 0.18f, 2, footprint);
      const float pores = smoothstep(0.8f, 0.88f, valueNoise(q * 70.0f + 11.0f)) * fadeFor(70.0f, footprint);
      const float albedo = glm::mix(0.82f, 1.14f, mottle) * glm::mix(0.88f, 1.06f, stains) * (1.0f - 0.45f * pores);
      return {albedo, 0.14f * (mottle - 0.5f) + 0.1f * pores};
    }
    case SurfaceTexture::Clay: {
      // Broad damp and dry areas, clods of a few centimetres.
      const float damp = fbm(q, 0.7f, 4, footprint);
      const float clods = fbm(q + 7.0f, 9.0f, 3, footprint);
      const float albedo = glm::mix(0.72f, 1.2f, damp) * glm::mix(0.82f, 1.12f, clods);
      return {albedo, 0.08f * (clods - 0.5f) - 0.15f * smoothstep(0.55f, 0.75f, 1.0f - damp)};
    }
    case SurfaceTexture::None:
      break;
  }
  return {1.0f, 0.0f};
}

}  // namespace crumple::render
