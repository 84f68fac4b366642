// The renderer's state: its programs, targets and the sky's light (renderer_impl.h); one frame's passes are in
// frame.cpp.
#include <crumple/render/renderer.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <glm/gtc/matrix_transform.hpp>

#include <crumple/gl/bindings.h>
#include <crumple/gl/capture.h>
#include <crumple/gl/context.h>
#include <crumple/gl/program.h>
#include <crumple/render/look.h>
#include <crumple/render/renderer_impl.h>

namespace crumple::render {

using gl::Image;

namespace shaders {
std::string_view shaderSource(std::string_view name);
}
std::string_view renderShader(std::string_view fileName) { return shaders::shaderSource(fileName); }

Program program(const char* vs, const char* fs) {
  return Program(
      {{GL_VERTEX_SHADER, vs, std::string(renderShader(vs))}, {GL_FRAGMENT_SHADER, fs, std::string(renderShader(fs))}});
}

std::string withDefines(std::string_view source, const std::string& defines) {
  const size_t eol = source.find('\n') + 1;
  return std::string(source.substr(0, eol)) + defines + "#line 2\n" + std::string(source.substr(eol));
}

GLuint makeCube(int size, int levels, GLenum format) {
  GLuint id = 0;
  glCreateTextures(GL_TEXTURE_CUBE_MAP, 1, &id);
  glTextureStorage2D(id, levels, format, size, size);
  glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, levels > 1 ? GL_LINEAR_MIPMAP_LINEAR : GL_LINEAR);
  glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(id, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(id, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTextureParameteri(id, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
  return id;
}

GLuint makeFlatArray() {
  GLuint id = 0;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &id);
  glTextureStorage3D(id, 1, GL_RGBA8, 1, 1, 1);
  const unsigned char white[4] = {255, 255, 255, 255};
  glTextureSubImage3D(id, 0, 0, 0, 0, 1, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, white);
  return id;
}

glm::mat3 faceBasis(int face) {
  static const glm::vec3 fwd[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  static const glm::vec3 right[6] = {{0, 0, -1}, {0, 0, 1}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}, {-1, 0, 0}};
  static const glm::vec3 up[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
  return glm::mat3(right[face], up[face], fwd[face]);
}

glm::ivec4 screenRect(const glm::mat4& mvp, const glm::vec3& lo, const glm::vec3& hi, int w, int h) {
  glm::vec2 a(1e30f), b(-1e30f);
  for (int k = 0; k < 8; ++k) {
    const glm::vec4 c = mvp * glm::vec4(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z, 1.0f);
    if (c.w <= 1e-6f) return {0, 0, w, h};
    const glm::vec2 p = (glm::vec2(c) / c.w * 0.5f + 0.5f) * glm::vec2(w, h);
    a = glm::min(a, p);
    b = glm::max(b, p);
  }
  const int x0 = std::clamp(static_cast<int>(std::floor(a.x)) - 1, 0, w),
            y0 = std::clamp(static_cast<int>(std::floor(a.y)) - 1, 0, h);
  const int x1 = std::clamp(static_cast<int>(std::ceil(b.x)) + 1, 0, w),
            y1 = std::clamp(static_cast<int>(std::ceil(b.y)) + 1, 0, h);
  return {x0, y0, x1 - x0, y1 - y0};
}

bool outsideClip(const glm::mat4& mvp, const glm::vec3& lo, const glm::vec3& hi) {
  glm::vec4 c[8];
  for (int k = 0; k < 8; ++k)
    c[k] = mvp * glm::vec4(k & 1 ? hi.x : lo.x, k & 2 ? hi.y : lo.y, k & 4 ? hi.z : lo.z, 1.0f);
  for (int axis = 0; axis < 3; ++axis)
    for (const float side : {-1.0f, 1.0f}) {
      bool allOut = true;
      for (int k = 0; k < 8 && allOut; ++k) allOut = side * c[k][axis] > c[k].w;
      if (allOut) return true;
    }
  return false;
}

const PomProgram& Renderer::Impl::pomCompute(const PomFeatures& f) {
  auto found = pomComputeVariants.find(f.key());
  if (found != pomComputeVariants.end()) return found->second;
  const std::string source = withDefines(renderShader("pom.frag"), f.defines() + "#define COMPUTE_SHADING 1\n") +
                             "#line 1 1\n" + std::string(renderShader("pom_shade.comp"));
  return pomComputeVariants
      .try_emplace(f.key(), std::vector<Program::Stage>{{GL_COMPUTE_SHADER, "pom.frag + pom_shade.comp", source}})
      .first->second;
}

const PomProgram& Renderer::Impl::pomVisibility(const PomFeatures& f) {
  auto found = pomVisibilityVariants.find(f.key());
  if (found != pomVisibilityVariants.end()) return found->second;
  const std::string fragment = withDefines(renderShader("pom.frag"), f.defines() + "#define VISIBILITY_PASS 1\n");
  return pomVisibilityVariants
      .try_emplace(f.key(), std::vector<Program::Stage>{{GL_VERTEX_SHADER, "pom.vert", std::string(renderShader("pom.vert"))},
                                                        {GL_FRAGMENT_SHADER, "pom.frag (visibility)", fragment}})
      .first->second;
}

Renderer::Impl::MeshBuffers Renderer::Impl::meshBuffers(GLuint vao) {
  GLint buffer = 0, stride = 0, offset = -1, elements = 0;
  glGetVertexArrayIndexediv(vao, 0, GL_VERTEX_BINDING_BUFFER, &buffer);
  glGetVertexArrayIndexediv(vao, 0, GL_VERTEX_BINDING_STRIDE, &stride);
  glGetVertexArrayIndexediv(vao, 0, GL_VERTEX_ATTRIB_RELATIVE_OFFSET, &offset);
  glGetVertexArrayiv(vao, GL_ELEMENT_ARRAY_BUFFER_BINDING, &elements);
  if (buffer == 0 || elements == 0 || stride != 17 * static_cast<GLint>(sizeof(float)) || offset != 0) return {};
  return {static_cast<GLuint>(buffer), static_cast<GLuint>(elements)};
}

const PomProgram& Renderer::Impl::pom(const PomFeatures& f) {
  auto found = pomVariants.find(f.key());
  if (found != pomVariants.end()) return found->second;
  const std::string fragment = withDefines(renderShader("pom.frag"), f.defines());
  std::vector<Program::Stage> stages;
  if (f.displaced)
    stages = {{GL_VERTEX_SHADER, "pom_displace.vert", std::string(renderShader("pom_displace.vert"))},
              {GL_TESS_CONTROL_SHADER, "pom_displace.tesc",
               withDefines(renderShader("pom_displace.tesc"), std::string(renderShader("displace_common.glsl")))},
              {GL_TESS_EVALUATION_SHADER, "pom_displace.tese",
               withDefines(renderShader("pom_displace.tese"), std::string(renderShader("displace_common.glsl")))},
              {GL_FRAGMENT_SHADER, "pom.frag", fragment}};
  else
    stages = {{GL_VERTEX_SHADER, "pom.vert", std::string(renderShader("pom.vert"))},
              {GL_FRAGMENT_SHADER, "pom.frag", fragment}};
  return pomVariants.try_emplace(f.key(), stages).first->second;
}

GLuint Renderer::Impl::multisampled(int w, int h) {
  if (msaaWidth != w || msaaHeight != h || !msaaFbo) {
    msaaColor = Renderbuffer(w, h, GL_SRGB8_ALPHA8, kMsaaSamples);
    msaaDepth = Renderbuffer(w, h, GL_DEPTH_COMPONENT32F, kMsaaSamples);
    msaaFbo = Framebuffer();
    msaaFbo.attachColor(msaaColor);
    msaaFbo.attachDepth(msaaDepth);
    msaaFbo.checkComplete();
    msaaWidth = w;
    msaaHeight = h;
  }
  return msaaFbo.id();
}

void Renderer::Impl::resolve(GLuint target, int w, int h) {
  glEnable(GL_FRAMEBUFFER_SRGB);
  glBlitNamedFramebuffer(msaaFbo.id(), target, 0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  if (target == fbo.id())  // our own target keeps a depth (one sample's) for whoever reads it
    glBlitNamedFramebuffer(msaaFbo.id(), target, 0, 0, w, h, 0, 0, w, h, GL_DEPTH_BUFFER_BIT, GL_NEAREST);
}

Renderer::Impl::Impl() {
  glTextureParameteri(shadowMap.id(), GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTextureParameteri(shadowMap.id(), GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  shadowFbo.attachDepth(shadowMap);
  glNamedFramebufferDrawBuffer(shadowFbo.id(), GL_NONE);
  shadowFbo.checkComplete();
  const float half = 0.5f;
  flatHeight.upload(GL_RED, GL_FLOAT, &half);
  const float one = 1.0f;
  noBound.upload(GL_RED, GL_FLOAT, &one);
  const unsigned char up[4] = {128, 128, 255, 255};
  flatNormal.upload(GL_RGBA, GL_UNSIGNED_BYTE, up);
  glEnable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
}

void Renderer::Impl::bindLook(const PomProgram& p, const RenderItem& it) {
  const GpuLook* look = it.look;
  if (!look || look->materialCount() == 0) return;
  const int n = look->materialCount();
  p.lookOwn.set(glm::ivec3(it.ownColor, it.ownMetallic, it.ownRoughness));
  p.lookBase.set(look->baseColor.data(), n);
  p.lookParams.set(look->params.data(), n);
  p.lookEmissive.set(look->emissive.data(), n);
  p.lookLayers.set(look->layers.data(), n);
  gl::bindTexture(pom::kLookSrgb, look->srgbArray() ? look->srgbArray() : flatArray.id());
  gl::bindTexture(pom::kLookLinear, look->linearArray() ? look->linearArray() : flatArray.id());
}

void Renderer::Impl::bakeFaces(const Uniform<glm::mat3>& basisUniform, GLuint cube, int size, int level) {
  glBindFramebuffer(GL_FRAMEBUFFER, bakeFbo.id());
  glViewport(0, 0, size >> level, size >> level);
  for (int face = 0; face < 6; ++face) {
    glNamedFramebufferTextureLayer(bakeFbo.id(), GL_COLOR_ATTACHMENT0, cube, level, face);
    basisUniform.set(faceBasis(face));
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }
}

void Renderer::Impl::setSkyUniforms(const RendererSettings& s) {
  skyUniforms.toSun.set(-glm::normalize(s.sunDirection));
  skyUniforms.sunColor.set(s.sunColor);
  skyUniforms.skyColor.set(s.skyColor);
  skyUniforms.groundColor.set(s.groundColor);
}

void Renderer::Impl::prepareLight(const RendererSettings& s) {
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_FRAMEBUFFER_SRGB);
  glBindVertexArray(emptyVao.id());
  if (!lutDone) {
    glBindFramebuffer(GL_FRAMEBUFFER, bakeFbo.id());
    glNamedFramebufferTexture(bakeFbo.id(), GL_COLOR_ATTACHMENT0, lut.id(), 0);
    glViewport(0, 0, kLutSize, kLutSize);
    brdfLut.use();
    glDrawArrays(GL_TRIANGLES, 0, 3);
    lutDone = true;
  }
  const glm::vec3 key[4] = {s.sunDirection, s.sunColor, s.skyColor, s.groundColor};
  if (!skyDone || !std::equal(key, key + 4, skyKey)) {
    std::copy(key, key + 4, skyKey);
    sky.use();
    setSkyUniforms(s);
    skyUniforms.background.set(0);
    bakeFaces(skyUniforms.basis, env.id(), kEnvSize, 0);
    glGenerateTextureMipmap(env.id());
    prefilter.use();
    gl::bindTexture(kSource, env.id());
    prefilterMode.set(0);
    for (int level = 0; level < kPrefilterLevels; ++level) {
      const float roughness = static_cast<float>(level) / (kPrefilterLevels - 1);
      prefilterRoughness.set(roughness);
      prefilterSamples.set(level == 0 ? 1 : 48);
      bakeFaces(prefilterBasis, prefiltered.id(), kPrefilterSize, level);
    }
    prefilterMode.set(1);
    prefilterSamples.set(128);
    bakeFaces(prefilterBasis, irradiance.id(), kIrradianceSize, 0);
    skyDone = true;
  }
  glEnable(GL_DEPTH_TEST);
}

void Renderer::Impl::resize(int w, int h) {
  color = Texture2D(w, h, GL_SRGB8_ALPHA8);
  depth = Texture2D(w, h, GL_DEPTH_COMPONENT32F);
  fbo = Framebuffer();
  fbo.attachColor(color);
  fbo.attachDepth(depth);
  fbo.checkComplete();
  sceneColor = Texture2D(w, h, GL_SRGB8_ALPHA8);
  sceneColor.setFilter(GL_LINEAR, GL_LINEAR);
  sceneColor.setWrap(GL_CLAMP_TO_EDGE);
  sceneFbo = Framebuffer();
  sceneFbo.attachColor(sceneColor);
  sceneFbo.attachDepth(depth);
  sceneFbo.checkComplete();
  GLuint view = 0;
  glGenTextures(1, &view);
  glTextureView(view, GL_TEXTURE_2D, sceneColor.id(), GL_RGBA8, 0, 1, 0, 1);
  sceneColorView = GlName<detail::deleteTexture>(view);
  visibilityIds = Texture2D(w, h, GL_RG32UI);
  visibilityIds.setFilter(GL_NEAREST, GL_NEAREST);
  visibilityFbo = Framebuffer();
  visibilityFbo.attachColor(visibilityIds);
  visibilityFbo.attachDepth(depth);
  visibilityFbo.checkComplete();
}

void Renderer::Impl::antialias(GLuint target, int w, int h) {
  glBindFramebuffer(GL_FRAMEBUFFER, target);
  glViewport(0, 0, w, h);
  glDisable(GL_DEPTH_TEST);
  glEnable(GL_FRAMEBUFFER_SRGB);
  fxaa.use();
  fxaaTexel.set(glm::vec2(1.0f / static_cast<float>(w), 1.0f / static_cast<float>(h)));
  gl::bindTexture(kSource, sceneColor.id());
  glBindVertexArray(emptyVao.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glEnable(GL_DEPTH_TEST);
}

Renderer::Renderer(int width, int height) : impl_(std::make_unique<Impl>()), width_(width), height_(height) {
  impl_->resize(width, height);
}
Renderer::~Renderer() = default;

void Renderer::resize(int width, int height) {
  if (width == width_ && height == height_) return;
  width_ = width;
  height_ = height;
  impl_->resize(width, height);
}

GLuint Renderer::framebuffer() const { return impl_->fbo.id(); }

void Renderer::draw(const std::vector<RenderItem>& items, const View& view) { drawTo(impl_->fbo.id(), items, view); }

Image Renderer::readPixels() const { return gl::readFramebuffer(impl_->fbo.id(), width_, height_, 3); }

void Renderer::savePng(const std::string& path) const { gl::writePng(path, readPixels(), 8); }

}  // namespace crumple::render
