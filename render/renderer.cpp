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

namespace crumple::render {

using gl::Framebuffer;
using gl::GlName;
using gl::Image;
using gl::Program;
using gl::Renderbuffer;
using gl::Texture2D;
using gl::Uniform;
using gl::VertexArray;
namespace detail = gl::detail;

namespace shaders {
std::string_view shaderSource(std::string_view name);
}
std::string_view renderShader(std::string_view fileName) { return shaders::shaderSource(fileName); }

namespace {
Program program(const char* vs, const char* fs) {
  return Program(
      {{GL_VERTEX_SHADER, vs, std::string(renderShader(vs))}, {GL_FRAGMENT_SHADER, fs, std::string(renderShader(fs))}});
}
// `source` with `defines` after its #version line (line numbers in messages stay the file's).
std::string withDefines(std::string_view source, const std::string& defines) {
  const size_t eol = source.find('\n') + 1;
  return std::string(source.substr(0, eol)) + defines + "#line 2\n" + std::string(source.substr(eol));
}
constexpr int kShadowSize = 2048;
constexpr int kEnvSize = 64, kEnvLevels = 7;              // the sky as rendered, mipmapped
constexpr int kPrefilterSize = 64, kPrefilterLevels = 5;  // roughness 0, 0.25, .. 1
constexpr int kIrradianceSize = 16, kLutSize = 64;

// The shaders' binding points, as render/shaders/ declares them with layout(binding = N) (each declaration names
// its constant): pom.frag's samplers (pom_displace.tese's uHeight too) and pom_shade.comp's.
namespace pom {
constexpr gl::TextureUnit kHeight{0}, kNormalMap{1}, kShadowMap{2}, kPrefiltered{3}, kIrradiance{4}, kBrdfLut{5},
    kHeightBound{6}, kLookSrgb{8}, kLookLinear{9}, kVisibilityIds{10};
constexpr gl::ImageUnit kShaded{0};
constexpr gl::StorageBinding kVertices{0}, kIndices{1};
}  // namespace pom
// The one input of the full-screen passes: address_view.frag's uAddress, fxaa.frag's uScene, prefilter.frag's uEnv.
constexpr gl::TextureUnit kSource{0};

// A cube map with immutable storage.
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

// A 1x1 white texture array.
GLuint makeFlatArray() {
  GLuint id = 0;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &id);
  glTextureStorage3D(id, 1, GL_RGBA8, 1, 1, 1);
  const unsigned char white[4] = {255, 255, 255, 255};
  glTextureSubImage3D(id, 0, 0, 0, 0, 1, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, white);
  return id;
}

// Maps (ndc.x, ndc.y, 1) of a cube face's viewport to the direction of its texel (GL's face layout).
glm::mat3 faceBasis(int face) {
  static const glm::vec3 fwd[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  static const glm::vec3 right[6] = {{0, 0, -1}, {0, 0, 1}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}, {-1, 0, 0}};
  static const glm::vec3 up[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
  return glm::mat3(right[face], up[face], fwd[face]);
}
// The pixels (x, y, width, height) the box lo..hi (model frame) may cover in a w x h frame through `mvp`, a
// pixel of margin; the whole frame where the box reaches behind the eye.
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
// True when the box lo..hi (model frame) lies wholly outside one plane of the clip volume of `mvp`:
// the item can draw no pixel (a conservative test: boxes across a corner of the frustum are kept).
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

// What one item draws: its simplified mesh where the settings ask for it and it has one.
GLuint itemVao(const RenderItem& it, const RendererSettings& s) {
  return s.simplified && it.simplifiedVao ? it.simplifiedVao : it.vao;
}
GLsizei itemIndexCount(const RenderItem& it, const RendererSettings& s) {
  return s.simplified && it.simplifiedVao ? it.simplifiedIndexCount : it.indexCount;
}
// What it casts into the shadow map.
GLuint casterVao(const RenderItem& it, const RendererSettings& s) {
  return s.simplified && it.shadowVao ? it.shadowVao : it.vao;
}
GLsizei casterIndexCount(const RenderItem& it, const RendererSettings& s) {
  return s.simplified && it.shadowVao ? it.shadowIndexCount : it.indexCount;
}
}  // namespace

// The sun's shadow map keeps the casters that stood still: they are drawn once into `still`, and each frame
// only the items that moved since the last frame are drawn over a copy of it. The copy is of the rectangle the
// last frame's movers were drawn in (`dirty`): elsewhere the shadow map holds `still` already (a whole 2048^2
// depth copy took 0.37 ms of an H200's 3.3 ms frame).
// An item is matched to last frame's by its place in the list, its mesh and index count; the copy is made
// anew when the light's frustum changes, a still item moves or the list changes. The depth test (less)
// makes the result the same as drawing every item (up to which of two casters at one depth wins).
struct ShadowCache {
  static constexpr int kPromoteFrames = 30;  // a moving caster that then stood this many frames joins `still`
  struct Caster {
    GLuint vao = 0;
    GLsizei indexCount = 0;
    glm::mat4 model{0};
    int unmoved = 0;     // frames since it last moved
    bool still = false;  // drawn into `still` (at `model`)
  };
  std::vector<Caster> casters;
  glm::mat4 lightVP{0};
  bool valid = false;  // `still` holds the still casters, drawn with lightVP
  // Texels [x0, x1) x [y0, y1) where the shadow map may differ from `still` (all of it until a copy).
  glm::ivec4 dirty{0, 0, kShadowSize, kShadowSize};
  // The texels the items not in `still` may cover (their bounds' light-space box, a texel of margin).
  glm::ivec4 moversRect(const std::vector<RenderItem>& items, const glm::mat4& vp) const {
    glm::ivec4 u{kShadowSize, kShadowSize, 0, 0};
    for (size_t i = 0; i < items.size(); ++i) {
      if (casters[i].still) continue;
      const glm::ivec4 r =
          screenRect(vp * items[i].model, items[i].boundsMin, items[i].boundsMax, kShadowSize, kShadowSize);
      if (r.z <= 0 || r.w <= 0) continue;
      u = {std::min(u.x, r.x), std::min(u.y, r.y), std::max(u.z, r.x + r.z), std::max(u.w, r.y + r.w)};
    }
    return u.z > u.x ? u : glm::ivec4(0);
  }
  Texture2D still{kShadowSize, kShadowSize, GL_DEPTH_COMPONENT32F};
  Framebuffer stillFbo;
  ShadowCache() {
    stillFbo.attachDepth(still);
    glNamedFramebufferDrawBuffer(stillFbo.id(), GL_NONE);
    stillFbo.checkComplete();
  }
  // Follows the items' poses; true when `still` must be drawn again (the casters marked still are drawn).
  bool update(const std::vector<RenderItem>& items, const RendererSettings& s, const glm::mat4& vp) {
    bool same = items.size() == casters.size();
    for (size_t i = 0; same && i < items.size(); ++i)
      same = casters[i].vao == casterVao(items[i], s) && casters[i].indexCount == casterIndexCount(items[i], s);
    if (!same) {  // a new list: nothing is known to stand still yet
      casters.assign(items.size(), Caster{});
      for (size_t i = 0; i < items.size(); ++i)
        casters[i] = {casterVao(items[i], s), casterIndexCount(items[i], s), items[i].model, 0, false};
      valid = false;
      return false;
    }
    bool redraw = !valid || vp != lightVP;
    for (size_t i = 0; i < items.size(); ++i) {
      Caster& c = casters[i];
      const bool moved = c.model != items[i].model;
      c.model = items[i].model;
      c.unmoved = moved ? 0 : std::min(c.unmoved + 1, kPromoteFrames);
      redraw = redraw || (c.still && moved) || (!c.still && c.unmoved == kPromoteFrames);
    }
    if (!redraw) return false;
    for (Caster& c : casters) c.still = c.unmoved > 0;
    lightVP = vp;
    valid = true;
    return true;
  }
};

// The features of one draw of the main pass, as pom.frag's defines: the item's (maps, look, procedural
// surface, displaced geometry) and the frame's (parallax mode, debug view, shadows, self-shadowing, sky light).
struct PomFeatures {
  bool maps = false, look = false, displaced = false, shadows = false, selfShadow = false, ibl = false;
  int texture = 0, mode = 0, debug = 0;
  uint32_t key() const {
    return uint32_t(maps) | uint32_t(look) << 1 | uint32_t(displaced) << 2 | uint32_t(shadows) << 3 |
           uint32_t(selfShadow) << 4 | uint32_t(ibl) << 5 | uint32_t(texture) << 6 | uint32_t(mode) << 8 |
           uint32_t(debug) << 10;
  }
  std::string defines() const {
    char text[256];
    std::snprintf(text, sizeof text,
                  "#define HAS_MAPS %d\n#define HAS_LOOK %d\n#define DISPLACED %d\n#define SHADOWS %d\n"
                  "#define SELF_SHADOW %d\n#define IBL %d\n#define TEXTURE %d\n#define MODE %d\n#define DEBUG %d\n",
                  maps, look, displaced, shadows, selfShadow, ibl, texture, mode, debug);
    return text;
  }
};

// A variant of the main pass's program (pom.frag drawn, or shaded in pom_shade.comp) and its uniforms.
struct PomProgram {
  explicit PomProgram(const std::vector<Program::Stage>& stages) : program(stages) {}
  Program program;
  // The frame's (Renderer::render's prepare).
  Uniform<glm::mat4> viewProjection{program, "uViewProjection"}, lightViewProjection{program, "uLightViewProjection"};
  Uniform<glm::vec3> eye{program, "uEye"}, toSun{program, "uToSun"}, sunColor{program, "uSunColor"},
      skyColor{program, "uSkyColor"}, groundColor{program, "uGroundColor"};
  Uniform<float> exposure{program, "uExposure"}, prefilteredMaxLod{program, "uPrefilteredMaxLod"};
  Uniform<int> minSteps{program, "uMinSteps"}, maxSteps{program, "uMaxSteps"};
  Uniform<glm::vec2> lodFade{program, "uLodFade"};
  Uniform<glm::vec2> viewport{program, "uViewport"};  // the displaced path's tessellation
  Uniform<float> segmentPixels{program, "uSegmentPixels"}, maxLevel{program, "uMaxLevel"};
  // The item's (bindItem).
  Uniform<glm::mat4> model{program, "uModel"}, worldToModel{program, "uWorldToModel"};
  Uniform<glm::mat3> normalMatrix{program, "uNormalMatrix"};
  Uniform<glm::vec3> color{program, "uColor"};
  Uniform<float> bumpDepth{program, "uBumpDepth"}, metallic{program, "uMetallic"}, roughness{program, "uRoughness"},
      textureScale{program, "uTextureScale"};
  Uniform<int> boundTile{program, "uBoundTile"};
  // The item's look (bindLook): arrays of its materials.
  Uniform<glm::ivec3> lookOwn{program, "uLookOwn"};
  Uniform<glm::vec4> lookBase{program, "uLookBase"}, lookParams{program, "uLookParams"},
      lookEmissive{program, "uLookEmissive"};
  Uniform<glm::ivec4> lookLayers{program, "uLookLayers"};
  // Shading from the visibility buffer (pom_shade.comp).
  Uniform<glm::mat4> invViewProjection{program, "uInvViewProjection"};
  Uniform<glm::ivec2> frameSize{program, "uFrameSize"};
  Uniform<GLuint> item{program, "uItem"};
  Uniform<glm::ivec4> rect{program, "uRect"};
};

// sky.frag's uniforms (the sky drawn as the background, or into the cube map the light is made from).
struct SkyUniforms {
  explicit SkyUniforms(const Program& p)
      : basis(p, "uBasis"), toSun(p, "uToSun"), sunColor(p, "uSunColor"), skyColor(p, "uSkyColor"),
        groundColor(p, "uGroundColor"), background(p, "uBackground"), exposure(p, "uExposure") {}
  Uniform<glm::mat3> basis;
  Uniform<glm::vec3> toSun, sunColor, skyColor, groundColor;
  Uniform<int> background;
  Uniform<float> exposure;
};

struct Renderer::Impl {
  std::vector<std::pair<float, size_t>> drawOrder;  // the items' drawing order of the last frame (front to back)
  std::vector<size_t> visible;                      // the items drawn this frame, in that order
  // Shading from a visibility buffer (RendererSettings::shading): the pass's programs and targets; Auto picks it
  // on GPUs with few graphics units.
  bool fewGraphicsUnits = gl::fewGraphicsUnits(reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
  Program visibility = program("visibility.vert", "visibility.frag");
  Uniform<glm::mat4> visibilityMvp{visibility, "uModelViewProjection"};
  Uniform<GLuint> visibilityItem{visibility, "uItem"};
  std::map<uint32_t, PomProgram> pomComputeVariants;
  Texture2D visibilityIds{1, 1, GL_RG32UI};
  Framebuffer visibilityFbo;
  GlName<detail::deleteTexture> sceneColorView;  // sceneColor's storage as RGBA8 (images cannot store sRGB)
  const PomProgram& pomCompute(const PomFeatures& f) {
    auto found = pomComputeVariants.find(f.key());
    if (found != pomComputeVariants.end()) return found->second;
    const std::string source = withDefines(renderShader("pom.frag"), f.defines() + "#define COMPUTE_SHADING 1\n") +
                               "#line 1 1\n" + std::string(renderShader("pom_shade.comp"));
    return pomComputeVariants
        .try_emplace(f.key(), std::vector<Program::Stage>{{GL_COMPUTE_SHADER, "pom.frag + pom_shade.comp", source}})
        .first->second;
  }
  // The vertex and index buffers of a GpuMesh's vertex array (17 floats a vertex, 32-bit indices); vertices 0
  // where it has another layout (the frame is then drawn in the fragment stage).
  struct MeshBuffers {
    GLuint vertices = 0, indices = 0;
  };
  static MeshBuffers meshBuffers(GLuint vao) {
    GLint buffer = 0, stride = 0, offset = -1, elements = 0;
    glGetVertexArrayIndexediv(vao, 0, GL_VERTEX_BINDING_BUFFER, &buffer);
    glGetVertexArrayIndexediv(vao, 0, GL_VERTEX_BINDING_STRIDE, &stride);
    glGetVertexArrayIndexediv(vao, 0, GL_VERTEX_ATTRIB_RELATIVE_OFFSET, &offset);
    glGetVertexArrayiv(vao, GL_ELEMENT_ARRAY_BUFFER_BINDING, &elements);
    if (buffer == 0 || elements == 0 || stride != 17 * static_cast<GLint>(sizeof(float)) || offset != 0) return {};
    return {static_cast<GLuint>(buffer), static_cast<GLuint>(elements)};
  }
  std::vector<MeshBuffers> itemBuffers;  // this frame's, by item (compute shading)
  // The main pass's programs, one per combination of features, made on first use (a handful per scene).
  std::map<uint32_t, PomProgram> pomVariants;
  const PomProgram& pom(const PomFeatures& f) {
    auto found = pomVariants.find(f.key());
    if (found != pomVariants.end()) return found->second;
    const std::string fragment = withDefines(renderShader("pom.frag"), f.defines());
    std::vector<Program::Stage> stages;
    if (f.displaced)
      stages = {{GL_VERTEX_SHADER, "pom_displace.vert", std::string(renderShader("pom_displace.vert"))},
                {GL_TESS_CONTROL_SHADER, "pom_displace.tesc", std::string(renderShader("pom_displace.tesc"))},
                {GL_TESS_EVALUATION_SHADER, "pom_displace.tese", std::string(renderShader("pom_displace.tese"))},
                {GL_FRAGMENT_SHADER, "pom.frag", fragment}};
    else
      stages = {{GL_VERTEX_SHADER, "pom.vert", std::string(renderShader("pom.vert"))},
                {GL_FRAGMENT_SHADER, "pom.frag", fragment}};
    return pomVariants.try_emplace(f.key(), stages).first->second;
  }
  Program shadow = program("shadow.vert", "shadow.frag");
  Uniform<glm::mat4> shadowMvp{shadow, "uLightModelViewProjection"};
  Program addressView = program("fullscreen.vert", "address_view.frag");
  Program sky = program("sky.vert", "sky.frag");
  SkyUniforms skyUniforms{sky};
  Program prefilter = program("sky.vert", "prefilter.frag");
  Uniform<glm::mat3> prefilterBasis{prefilter, "uBasis"};
  Uniform<float> prefilterRoughness{prefilter, "uRoughness"};
  Uniform<int> prefilterMode{prefilter, "uMode"}, prefilterSamples{prefilter, "uSamples"};
  Program brdfLut = program("fullscreen.vert", "brdf_lut.frag");
  Program fxaa = program("fullscreen.vert", "fxaa.frag");
  Uniform<glm::vec2> fxaaTexel{fxaa, "uTexel"};
  GlName<detail::deleteTexture> env{makeCube(kEnvSize, kEnvLevels, GL_RGBA16F)};
  GlName<detail::deleteTexture> prefiltered{makeCube(kPrefilterSize, kPrefilterLevels, GL_RGBA16F)};
  GlName<detail::deleteTexture> irradiance{makeCube(kIrradianceSize, 1, GL_RGBA16F)};
  Texture2D lut{kLutSize, kLutSize, GL_RG16F};
  Framebuffer bakeFbo;
  bool lutDone = false, skyDone = false;
  glm::vec3 skyKey[4];  // the settings the cube maps were made for
  VertexArray emptyVao;
  Texture2D color, depth;
  Framebuffer fbo;
  Texture2D sceneColor;  // antialiased views: the frame before the FXAA pass (sharing `depth`)
  Framebuffer sceneFbo;
  // MSAA: the frame's multisampled colour and depth (made on first use, at the renderer's size).
  Renderbuffer msaaColor, msaaDepth;
  Framebuffer msaaFbo;
  int msaaWidth = 0, msaaHeight = 0;
  GLuint multisampled(int w, int h) {
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
  // The MSAA resolve: each pixel the mean of its samples, into `target`.
  void resolve(GLuint target, int w, int h) {
    glEnable(GL_FRAMEBUFFER_SRGB);
    glBlitNamedFramebuffer(msaaFbo.id(), target, 0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    if (target == fbo.id())  // our own target keeps a depth (one sample's) for whoever reads it
      glBlitNamedFramebuffer(msaaFbo.id(), target, 0, 0, w, h, 0, 0, w, h, GL_DEPTH_BUFFER_BIT, GL_NEAREST);
  }
  Texture2D shadowMap{kShadowSize, kShadowSize, GL_DEPTH_COMPONENT32F};
  Framebuffer shadowFbo;
  ShadowCache shadowCache;
  glm::vec3 sunFitLo{1e30f}, sunFitHi{-1e30f};  // the box the sun's frustum is fitted to (drawTo)
  Texture2D flatHeight{1, 1, GL_R32F}, flatNormal{1, 1, GL_RGBA8};
  Texture2D noBound{1, 1, GL_R32F};  // the bound of a map that has none: 1 everywhere (march every ray)
  GlName<detail::deleteTexture> flatArray{makeFlatArray()};  // bound where a look has no images of a kind
  Impl() {
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
  // The item's look (render/look.h): its materials' uniforms and its two texture arrays (units 8, 9).
  void bindLook(const PomProgram& p, const RenderItem& it) {
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
  // Renders into each face of `cube` at `level` with the bound program (its uniform uBasis, `basis`, per face).
  void bakeFaces(const Uniform<glm::mat3>& basisUniform, GLuint cube, int size, int level) {
    glBindFramebuffer(GL_FRAMEBUFFER, bakeFbo.id());
    glViewport(0, 0, size >> level, size >> level);
    for (int face = 0; face < 6; ++face) {
      glNamedFramebufferTextureLayer(bakeFbo.id(), GL_COLOR_ATTACHMENT0, cube, level, face);
      basisUniform.set(faceBasis(face));
      glDrawArrays(GL_TRIANGLES, 0, 3);
    }
  }
  void setSkyUniforms(const RendererSettings& s) {
    skyUniforms.toSun.set(-glm::normalize(s.sunDirection));
    skyUniforms.sunColor.set(s.sunColor);
    skyUniforms.skyColor.set(s.skyColor);
    skyUniforms.groundColor.set(s.groundColor);
  }
  // The split-sum table once; the sky's cube maps again when the sun or sky changes.
  void prepareLight(const RendererSettings& s) {
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
  void resize(int w, int h) {
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
  // The FXAA pass: sceneColor into `target`.
  void antialias(GLuint target, int w, int h) {
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
};

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

void Renderer::drawTo(GLuint finalTarget, const std::vector<RenderItem>& items, const View& view) {
  Impl& m = *impl_;
  const RendererSettings& s = settings_;
  // The shaded view draws into sceneFbo when antialiased, filtered into the target at the end.
  const bool fxaa = s.antialias == Antialias::Fxaa && s.debug == DebugView::Shaded;
  const bool msaa = s.antialias == Antialias::Msaa && s.debug == DebugView::Shaded;
  stats_ = {};
  // Shading in compute from a visibility buffer (RendererSettings::shading): the shaded view without MSAA, no
  // displaced item, every item's vertices in GpuMesh's layout. It writes sceneColor: FXAA filters it into the
  // target, or without antialiasing a blit copies it there.
  bool compute = (s.shading == Shading::Compute || (s.shading == Shading::Auto && m.fewGraphicsUnits)) && !msaa &&
                 s.debug == DebugView::Shaded;
  std::vector<Impl::MeshBuffers>& buffers = m.itemBuffers;  // each item's, asked of GL once a frame
  buffers.clear();
  for (size_t i = 0; compute && i < items.size(); ++i) {
    buffers.push_back(m.meshBuffers(itemVao(items[i], s)));
    compute = !((s.displace || view.displace) && items[i].height) && buffers.back().vertices != 0;
  }
  stats_.computeShaded = compute;
  const GLuint target = fxaa || compute ? m.sceneFbo.id() : msaa ? m.multisampled(width_, height_) : finalTarget;
  // Fit the sun's orthographic frustum around everything.
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const auto& it : items) {
    for (int c = 0; c < 8; ++c) {
      const glm::vec3 p(c & 1 ? it.boundsMax.x : it.boundsMin.x, c & 2 ? it.boundsMax.y : it.boundsMin.y,
                        c & 4 ? it.boundsMax.z : it.boundsMin.z);
      const glm::vec3 w = glm::vec3(it.model * glm::vec4(p, 1));
      lo = glm::min(lo, w);
      hi = glm::max(hi, w);
    }
  }
  if (items.empty()) lo = hi = glm::vec3(0);
  // The box it is fitted to is kept while everything stays inside it and it is not much larger (so the
  // shadow map of the still casters stays valid while bodies move about in it); refitted with a margin.
  const float fitRadius = std::max(0.5f * glm::length(hi - lo), 0.5f);
  const bool inside = glm::all(glm::greaterThanEqual(lo, m.sunFitLo)) && glm::all(glm::lessThanEqual(hi, m.sunFitHi));
  if (!inside || 0.5f * glm::length(m.sunFitHi - m.sunFitLo) > 1.1f * fitRadius) {
    m.sunFitLo = lo - glm::vec3(0.02f * fitRadius);
    m.sunFitHi = hi + glm::vec3(0.02f * fitRadius);
  }
  const glm::vec3 centre = 0.5f * (m.sunFitLo + m.sunFitHi);
  const float radius = std::max(0.5f * glm::length(m.sunFitHi - m.sunFitLo), 0.5f);
  const glm::vec3 sunDir = glm::normalize(s.sunDirection);
  const glm::vec3 sunUp = std::abs(sunDir.y) > 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  const glm::mat4 lightView = glm::lookAt(centre - sunDir * radius * 2.0f, centre, sunUp);
  const glm::mat4 lightProj = glm::ortho(-radius, radius, -radius, radius, 0.01f, radius * 4.0f);
  const glm::mat4 lightVP = lightProj * lightView;

  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  if (s.ibl && s.debug == DebugView::Shaded) m.prepareLight(s);
  auto mark = [&](const char* part) {
    if (mark_) mark_(part);
  };
  mark("light");
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  if (s.shadows && s.debug == DebugView::Shaded) {
    m.shadow.use();
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(2.0f, 4.0f);
    glViewport(0, 0, kShadowSize, kShadowSize);
    // Draws the items whose `still` flag is `which` (all of them without a cache).
    auto drawCasters = [&](bool cached, bool which) {
      for (size_t i = 0; i < items.size(); ++i) {
        if (cached && m.shadowCache.casters[i].still != which) continue;
        const RenderItem& it = items[i];
        ++stats_.shadowCasters;
        const glm::mat4 mvp = lightVP * it.model;
        m.shadowMvp.set(mvp);
        glBindVertexArray(casterVao(it, s));
        glDrawElements(GL_TRIANGLES, casterIndexCount(it, s), GL_UNSIGNED_INT, nullptr);
      }
    };
    ShadowCache& cache = m.shadowCache;
    if (cache.update(items, s, lightVP)) {
      glBindFramebuffer(GL_FRAMEBUFFER, cache.stillFbo.id());
      glClear(GL_DEPTH_BUFFER_BIT);
      drawCasters(true, true);
      stats_.shadowCacheRedrawn = true;
      cache.dirty = {0, 0, kShadowSize, kShadowSize};
    }
    glBindFramebuffer(GL_FRAMEBUFFER, m.shadowFbo.id());
    if (cache.valid) {
      const glm::ivec4 d = cache.dirty;
      if (d.z > d.x && d.w > d.y)
        glCopyImageSubData(cache.still.id(), GL_TEXTURE_2D, 0, d.x, d.y, 0, m.shadowMap.id(), GL_TEXTURE_2D, 0, d.x,
                           d.y, 0, d.z - d.x, d.w - d.y, 1);
      cache.dirty = cache.moversRect(items, lightVP);
      drawCasters(true, false);
    } else {
      glClear(GL_DEPTH_BUFFER_BIT);
      drawCasters(false, false);
      cache.dirty = {0, 0, kShadowSize, kShadowSize};
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
  }
  mark("shadow map");

  glBindFramebuffer(GL_FRAMEBUFFER, target);
  glViewport(0, 0, width_, height_);
  glEnable(GL_FRAMEBUFFER_SRGB);
  const glm::vec3 sky = glm::pow(glm::vec3(0.62f, 0.72f, 0.85f), glm::vec3(2.2f));
  glClearColor(sky.r, sky.g, sky.b, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  if (s.debug == DebugView::Address) {
    m.addressView.use();
    gl::bindTexture(kSource, s.addressMap ? s.addressMap : m.flatHeight.id());
    glDisable(GL_DEPTH_TEST);
    glBindVertexArray(m.emptyVao.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glEnable(GL_DEPTH_TEST);
    glDisable(GL_FRAMEBUFFER_SRGB);
    return;
  }
  const float aspect = static_cast<float>(width_) / static_cast<float>(height_);
  const glm::mat4 viewM = glm::lookAt(view.eye, view.target, view.up);
  const glm::mat4 proj = glm::perspective(glm::radians(view.fovDegrees), aspect, view.zNear, view.zFar);
  const glm::mat4 vp = proj * viewM;
  PomFeatures frame;
  frame.mode = static_cast<int>(s.parallax);
  frame.debug = static_cast<int>(s.debug);
  frame.shadows = s.shadows && s.debug == DebugView::Shaded;
  frame.selfShadow = s.selfShadow;
  frame.ibl = s.ibl;
  // The frame's uniforms, given to each program the first time this frame that it draws.
  std::vector<GLuint> prepared;
  auto prepare = [&](const PomProgram& p) {
    if (std::find(prepared.begin(), prepared.end(), p.program.id()) != prepared.end()) return;
    prepared.push_back(p.program.id());
    p.viewProjection.set(vp);
    p.lightViewProjection.set(lightVP);
    p.eye.set(view.eye);
    p.toSun.set(-sunDir);
    p.sunColor.set(s.sunColor);
    p.skyColor.set(s.skyColor);
    p.groundColor.set(s.groundColor);
    p.exposure.set(s.exposure);
    p.prefilteredMaxLod.set(static_cast<float>(kPrefilterLevels - 1));
    p.minSteps.set(s.minSteps);
    p.maxSteps.set(s.maxSteps);
    p.lodFade.set(glm::vec2(s.lodFadeStart, s.lodFadeEnd));
    // The displaced path's tessellation.
    p.viewport.set(glm::vec2(static_cast<float>(width_), static_cast<float>(height_)));
    p.segmentPixels.set(std::max(s.displaceSegmentPixels, 0.5f));
    p.maxLevel.set(32.0f);  // llvmpipe drew torn, flickering faces at 64
  };
  gl::bindTexture(pom::kShadowMap, m.shadowMap.id());
  gl::bindTexture(pom::kPrefiltered, m.prefiltered.id());
  gl::bindTexture(pom::kIrradiance, m.irradiance.id());
  gl::bindTexture(pom::kBrdfLut, m.lut.id());
  if (s.debug == DebugView::Wireframe) glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
  glVertexAttrib3f(3, 1.0f, 1.0f, 1.0f);  // the colour of vertex arrays without one: white
  GLuint current = 0;
  // Front to back (by the distance of each item's bounds' centre from the eye; equal distances in the given
  // order): the depth test then rejects hidden fragments before the parallax march runs on them (pom.frag
  // writes no depth and discards nothing, so early depth testing holds).
  std::vector<std::pair<float, size_t>>& order = m.drawOrder;  // kept: no allocation a frame
  order.resize(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    const glm::vec3 c = glm::vec3(items[i].model * glm::vec4(0.5f * (items[i].boundsMin + items[i].boundsMax), 1.0f));
    order[i] = {glm::dot(c - view.eye, c - view.eye), i};
  }
  std::stable_sort(
      order.begin(), order.end(),
      [](const std::pair<float, size_t>& a, const std::pair<float, size_t>& b) { return a.first < b.first; });
  // The items to draw, in that order, and how: culled ones dropped.
  std::vector<size_t>& visible = m.visible;
  visible.clear();
  for (const auto& [distance, index] : order) {
    const RenderItem& it = items[index];
    const bool displaced = (s.displace || view.displace) && it.height && s.debug != DebugView::Wireframe;
    // Items wholly outside the view are skipped (displaced ones with their bounds grown by the map's range).
    const glm::vec3 grow(displaced ? it.bumpDepth : 0.0f);
    if (outsideClip(vp * it.model, it.boundsMin - grow, it.boundsMax + grow)) {
      ++stats_.culled;
      continue;
    }
    ++stats_.drawn;
    visible.push_back(index);
  }
  // The item's own uniforms and maps, in either path's program.
  auto bindItem = [&](const PomProgram& p, const RenderItem& it) {
    p.model.set(it.model);
    p.normalMatrix.set(glm::transpose(glm::inverse(glm::mat3(it.model))));
    p.bumpDepth.set(it.bumpDepth);
    p.color.set(it.color);
    p.metallic.set(it.metallic);
    p.roughness.set(it.roughness);
    p.worldToModel.set(glm::inverse(it.model));
    p.textureScale.set(it.textureScale);
    m.bindLook(p, it);
    gl::bindTexture(pom::kHeight, it.height ? it.height : m.flatHeight.id());
    gl::bindTexture(pom::kNormalMap, it.normal ? it.normal : m.flatNormal.id());
    gl::bindTexture(pom::kHeightBound, it.height && it.heightBound ? it.heightBound : m.noBound.id());
    p.boundTile.set(it.height && it.heightBound ? it.boundTile : 1 << 20);
  };
  auto itemFeatures = [&](const RenderItem& it, bool displaced) {
    PomFeatures f = frame;
    f.maps = it.height != 0;
    f.look = it.look != nullptr && it.look->materialCount() > 0;
    f.texture = static_cast<int>(it.texture);
    f.displaced = displaced;
    return f;
  };
  if (compute) {
    // The visibility pass: the item and triangle nearest at each pixel, into the frame's depth.
    m.visibilityFbo.bind();
    const GLuint none[4] = {0xffffffffu, 0, 0, 0};
    const float far = 1.0f;
    glClearNamedFramebufferuiv(m.visibilityFbo.id(), GL_COLOR, 0, none);
    glClearNamedFramebufferfv(m.visibilityFbo.id(), GL_DEPTH, 0, &far);
    mark("visibility clear");
    m.visibility.use();
    for (size_t index : visible) {
      const RenderItem& it = items[index];
      const glm::mat4 mvp = vp * it.model;
      m.visibilityMvp.set(mvp);
      m.visibilityItem.set(static_cast<GLuint>(index));
      glBindVertexArray(itemVao(it, s));  // the simplified mesh where the settings ask for it
      glDrawElements(GL_TRIANGLES, itemIndexCount(it, s), GL_UNSIGNED_INT, nullptr);
    }
    mark("visibility");  // (a profile's "items" is then the shading alone)
    // Each item's pixels shaded over its rectangle on screen.
    const glm::mat4 inverseVp = glm::inverse(vp);
    gl::bindTexture(pom::kVisibilityIds, m.visibilityIds.id());
    gl::bindImage(pom::kShaded, m.sceneColorView.id(), GL_WRITE_ONLY, GL_RGBA8);
    for (size_t index : visible) {
      const RenderItem& it = items[index];
      const PomProgram& p = m.pomCompute(itemFeatures(it, false));
      if (p.program.id() != current) {
        p.program.use();
        current = p.program.id();
        prepare(p);
        p.invViewProjection.set(inverseVp);
        p.frameSize.set(glm::ivec2(width_, height_));
      }
      bindItem(p, it);
      const glm::ivec4 rect = screenRect(vp * it.model, it.boundsMin, it.boundsMax, width_, height_);
      if (rect.z <= 0 || rect.w <= 0) continue;
      p.item.set(static_cast<GLuint>(index));
      p.rect.set(rect);
      const Impl::MeshBuffers& b = buffers[index];
      gl::bindStorage(pom::kVertices, b.vertices);
      gl::bindStorage(pom::kIndices, b.indices);
      glDispatchCompute(static_cast<GLuint>((rect.z + 7) / 8), static_cast<GLuint>((rect.w + 7) / 8), 1);
    }
    glMemoryBarrier(GL_FRAMEBUFFER_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
    glBindFramebuffer(GL_FRAMEBUFFER, target);
  }
  for (size_t i = 0; !compute && i < visible.size(); ++i) {
    const RenderItem& it = items[visible[i]];
    const bool displaced = (s.displace || view.displace) && it.height && s.debug != DebugView::Wireframe;
    const PomProgram& p = m.pom(itemFeatures(it, displaced));
    if (p.program.id() != current) {
      p.program.use();
      current = p.program.id();
      prepare(p);
    }
    bindItem(p, it);
    if (displaced) {
      glBindVertexArray(it.vao);
      glPatchParameteri(GL_PATCH_VERTICES, 3);
      glDrawElements(GL_PATCHES, it.indexCount, GL_UNSIGNED_INT, nullptr);
    } else {
      glBindVertexArray(itemVao(it, s));
      glDrawElements(GL_TRIANGLES, itemIndexCount(it, s), GL_UNSIGNED_INT, nullptr);
    }
  }
  glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
  mark("items");
  if (s.debug == DebugView::Shaded) {
    // The sky behind everything: only the pixels still at the far plane run it.
    m.sky.use();
    m.setSkyUniforms(s);
    const glm::vec3 fwd = glm::normalize(view.target - view.eye);
    const glm::vec3 right = glm::normalize(glm::cross(fwd, view.up));
    const glm::vec3 up = glm::cross(right, fwd);
    const float tanY = std::tan(glm::radians(view.fovDegrees) * 0.5f);
    const glm::mat3 basis(right * tanY * aspect, up * tanY, fwd);
    m.skyUniforms.basis.set(basis);
    m.skyUniforms.background.set(1);
    m.skyUniforms.exposure.set(s.exposure);
    glDepthFunc(GL_LEQUAL);
    glDepthMask(GL_FALSE);
    glBindVertexArray(m.emptyVao.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDepthMask(GL_TRUE);
    glDepthFunc(GL_LESS);
  }
  mark("sky");
  if (fxaa) m.antialias(finalTarget, width_, height_);
  if (msaa) m.resolve(finalTarget, width_, height_);
  if (compute && !fxaa)  // sRGB decoded and encoded again (as the fragment stage's writes into the target are)
    glBlitNamedFramebuffer(m.sceneFbo.id(), finalTarget, 0, 0, width_, height_, 0, 0, width_, height_,
                           GL_COLOR_BUFFER_BIT, GL_NEAREST);
  mark("antialias");
  glDisable(GL_FRAMEBUFFER_SRGB);
  // The shadow map compares depths: a later program's plain sampler on its unit would meet it (NVIDIA flags the
  // state as undefined behaviour even where the sampler reads nothing), so it is not left bound.
  gl::bindTexture(pom::kShadowMap, 0);
}

Image Renderer::readPixels() const { return gl::readFramebuffer(impl_->fbo.id(), width_, height_, 3); }

void Renderer::savePng(const std::string& path) const { gl::writePng(path, readPixels(), 8); }

}  // namespace crumple::render
