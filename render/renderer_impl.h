// Internal to render/ (not installed): the renderer's state (Renderer::Impl) and what its passes share, for
// renderer.cpp (the state: programs, targets, the sky's light) and frame.cpp (one frame's passes).
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include <crumple/gl/bindings.h>
#include <crumple/gl/context.h>
#include <crumple/gl/objects.h>
#include <crumple/gl/program.h>
#include <crumple/render/look.h>
#include <crumple/render/renderer.h>

namespace crumple::render {

using gl::Framebuffer;
using gl::GlName;
using gl::Program;
using gl::Renderbuffer;
using gl::Texture2D;
using gl::Uniform;
using gl::VertexArray;
namespace detail = gl::detail;

// A program of the vertex and fragment shaders of these names (render/shaders/).
Program program(const char* vs, const char* fs);
// `source` with `defines` after its #version line (line numbers in messages stay the file's).
std::string withDefines(std::string_view source, const std::string& defines);
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
constexpr gl::StorageBinding kVertices{0}, kIndices{1}, kSeamEdges{2}, kSeamVertices{3}, kVertexNodes{4}, kCrease{5};
}  // namespace pom
// The one input of the full-screen passes: address_view.frag's uAddress, fxaa.frag's uScene, prefilter.frag's uEnv.
constexpr gl::TextureUnit kSource{0};

// A cube map with immutable storage.
GLuint makeCube(int size, int levels, GLenum format);
// A 1x1 white texture array.
GLuint makeFlatArray();
// Maps (ndc.x, ndc.y, 1) of a cube face's viewport to the direction of its texel (GL's face layout).
glm::mat3 faceBasis(int face);
// The pixels (x, y, width, height) the box lo..hi (model frame) may cover in a w x h frame through `mvp`, a
// pixel of margin; the whole frame where the box reaches behind the eye.
glm::ivec4 screenRect(const glm::mat4& mvp, const glm::vec3& lo, const glm::vec3& hi, int w, int h);
// True when the box lo..hi (model frame) lies wholly outside one plane of the clip volume of `mvp`:
// the item can draw no pixel (a conservative test: boxes across a corner of the frustum are kept).
bool outsideClip(const glm::mat4& mvp, const glm::vec3& lo, const glm::vec3& hi);

// What one item draws: its simplified mesh where the settings ask for it and it has one.
inline GLuint itemVao(const RenderItem& it, const RendererSettings& s) {
  return s.simplified && it.simplifiedVao ? it.simplifiedVao : it.vao;
}
inline GLsizei itemIndexCount(const RenderItem& it, const RendererSettings& s) {
  return s.simplified && it.simplifiedVao ? it.simplifiedIndexCount : it.indexCount;
}
// What it casts into the shadow map.
inline GLuint casterVao(const RenderItem& it, const RendererSettings& s) {
  return s.simplified && it.shadowVao ? it.shadowVao : it.vao;
}
inline GLsizei casterIndexCount(const RenderItem& it, const RendererSettings& s) {
  return s.simplified && it.shadowVao ? it.shadowIndexCount : it.indexCount;
}

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
  Uniform<int> seams{program, "uSeams"};
  Uniform<int> creased{program, "uCrease"};
  Uniform<float> pixelAngle{program, "uPixelAngle"}, metresPerUv{program, "uMetresPerUv"};
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
  // The visibility pass of a bump-mapped item (pom.vert + pom.frag with VISIBILITY_PASS): the march's depth.
  const PomProgram& pomVisibility(const PomFeatures& f);
  std::map<uint32_t, PomProgram> pomVisibilityVariants;
  Texture2D visibilityIds{1, 1, GL_RG32UI};
  Framebuffer visibilityFbo;
  GlName<detail::deleteTexture> sceneColorView;  // sceneColor's storage as RGBA8 (images cannot store sRGB)
  const PomProgram& pomCompute(const PomFeatures& f);
  // The vertex and index buffers of a GpuMesh's vertex array (17 floats a vertex, 32-bit indices); vertices 0
  // where it has another layout (the frame is then drawn in the fragment stage).
  struct MeshBuffers {
    GLuint vertices = 0, indices = 0;
  };
  static MeshBuffers meshBuffers(GLuint vao);
  std::vector<MeshBuffers> itemBuffers;  // this frame's, by item (compute shading)
  // The main pass's programs, one per combination of features, made on first use (a handful per scene).
  std::map<uint32_t, PomProgram> pomVariants;
  // The displaced path reads the height maps' mip levels (pom_displace.tese filters a vertex's height over the
  // surface around it); the maps themselves are sampled at level 0 everywhere else.
  gl::Sampler displacedHeight{GL_LINEAR_MIPMAP_LINEAR, GL_LINEAR, GL_CLAMP_TO_EDGE};
  const PomProgram& pom(const PomFeatures& f);
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
  GLuint multisampled(int w, int h);
  // The MSAA resolve: each pixel the mean of its samples, into `target`.
  void resolve(GLuint target, int w, int h);
  Texture2D shadowMap{kShadowSize, kShadowSize, GL_DEPTH_COMPONENT32F};
  Framebuffer shadowFbo;
  ShadowCache shadowCache;
  glm::vec3 sunFitLo{1e30f}, sunFitHi{-1e30f};  // the box the sun's frustum is fitted to (drawTo)
  Texture2D flatHeight{1, 1, GL_R32F}, flatNormal{1, 1, GL_RGBA8};
  Texture2D noBound{1, 1, GL_R32F};  // the bound of a map that has none: 1 everywhere (march every ray)
  GlName<detail::deleteTexture> flatArray{makeFlatArray()};  // bound where a look has no images of a kind
  Impl();
  // The item's look (render/look.h): its materials' uniforms and its two texture arrays (units 8, 9).
  void bindLook(const PomProgram& p, const RenderItem& it);
  // Renders into each face of `cube` at `level` with the bound program (its uniform uBasis, `basis`, per face).
  void bakeFaces(const Uniform<glm::mat3>& basisUniform, GLuint cube, int size, int level);
  void setSkyUniforms(const RendererSettings& s);
  // The split-sum table once; the sky's cube maps again when the sun or sky changes.
  void prepareLight(const RendererSettings& s);
  void resize(int w, int h);
  // The FXAA pass: sceneColor into `target`.
  void antialias(GLuint target, int w, int h);
  struct Frame;  // one frame's passes (frame.cpp)
};

}  // namespace crumple::render
