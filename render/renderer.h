// The parallax-occlusion renderer: every body drawn with its current height and
// normal maps, so dents show although the mesh never changes.
//   - parallax occlusion mapping (Tatarchuk 2006; steep parallax, McGuire & McGuire
//     2005): a linear march whose step count follows the view angle, refined by a
//     secant search; soft self-shadowing of the height field towards the sun;
//     a fade to plain normal mapping with the texture's level of detail;
//     the paper's offset-limited parallax (Welsh 2004) as a cheaper mode
//   - glTF's metallic-roughness materials under a Cook-Torrance GGX BRDF: a
//     directional sun with a shadow map, and image-based light from an analytic
//     sky (rendered into a small cube map, prefiltered per roughness, with an
//     irradiance cube and a split-sum BRDF table, all made once and again only
//     when the sun or sky settings change); the sky drawn as the background;
//     exposure and an ACES fit tone map, sRGB output
//   - antialiasing: an FXAA pass over the shaded frame (luma edges, blended
//     across; render/shaders/fxaa.frag), on by default
//   - optional displacement (settings().displace): tessellation shaders move the
//     vertices by the height map, so a dented edge is no longer straight
//   - debug views: height map, normal map, address map, wireframe
// The tangent frame comes from screen-space derivatives of position and uv, so
// meshes need no tangents and mirrored charts need no care.
#pragma once
#include <glm/glm.hpp>

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <crumple/gl/objects.h>
#include <crumple/gl/image.h>

namespace crumple::render {

class GpuLook;  // render/look.h

// Procedural surfaces (pom.frag, value-noise fbm): albedo and roughness varied, no image needed.
enum class SurfaceTexture { None = 0, Asphalt = 1, Concrete = 2, Clay = 3 };

struct RenderItem {
  GLuint vao = 0;
  GLsizei indexCount = 0;
  glm::mat4 model{1};
  GLuint height = 0;  // R32F, 0 = flat
  GLuint normal = 0;  // RGBA8 tangent space, 0 = flat
  // The height's bound pyramid (deform::SurfaceMaps::bound: per tile of boundTile texels the largest
  // |h - 0.5|, each level above the largest of 2 x 2 below, the levels side by side in level 0 as
  // deform::SurfaceMaps::boundOrigin places them): parallax rays over undented texels skip their march; 0: march
  // everywhere.
  GLuint heightBound = 0;
  int boundTile = 16;
  glm::vec3 color{0.7f};   // sRGB base colour
  float metallic = 0.0f;   // glTF metallic-roughness
  float roughness = 0.6f;  // perceptual roughness
  // The mesh file's own materials (render/look.h), picked per vertex; null: color/metallic/roughness above.
  // A look's base colour, metallic or roughness gives way to the item's when the scene set that key.
  const GpuLook* look = nullptr;
  bool ownColor = true, ownMetallic = true, ownRoughness = true;
  // A procedural surface over the colour and roughness, laid in the mesh's frame (metres / textureScale).
  SurfaceTexture texture = SurfaceTexture::None;
  float textureScale = 1.0f;
  float bumpDepth = 0.1f;                 // k: the map's range in metres
  // Where the mesh's uv charts meet (deform::GpuMesh::seamEdges, seamVertices): the displaced path keeps seams
  // closed with them; 0: no seams known (a seam may open where its charts' dents differ).
  GLuint seamEdges = 0, seamVertices = 0;
  // The displaced path's crease bevel (deform::SurfaceMaps::crease: per node, xyz added to where the height moves
  // it) and each vertex's node (deform::GpuMesh::vertexNodes): a panel crushed against an undented one across a
  // hard edge meets it in a bevel, not a wall; 0: none.
  GLuint vertexNodes = 0, crease = 0;
  float metresPerUv = 1.0f;  // the mesh's size of one uv unit (deform::GpuMesh::metresPerUv)
  glm::vec3 boundsMin{-1}, boundsMax{1};  // mesh bounds (model frame): the sun's shadow map, view culling
  // A simplified version of the mesh (the same vertices, fewer triangles), drawn where
  // RendererSettings::simplified asks; 0: none.
  GLuint simplifiedVao = 0;
  GLsizei simplifiedIndexCount = 0;
  // Its shadow caster under the same setting (positions at attribute 0 alone); 0: none.
  GLuint shadowVao = 0;
  GLsizei shadowIndexCount = 0;
};

struct View {
  glm::vec3 eye{4, 3, 4}, target{0}, up{0, 1, 0};
  float fovDegrees = 45;
  float zNear = 0.05f, zFar = 500.0f;
  bool displace = false;  // this view displaces as RendererSettings::displace does (a scene camera's "displace")
};

enum class ParallaxMode { Occlusion = 0, OffsetLimited = 1, None = 2 };
enum class DebugView { Shaded = 0, Height = 1, Normal = 2, Address = 3, Wireframe = 4 };
// Antialiasing of the shaded view (debug views are never filtered): an FXAA pass over the finished frame, or
// MSAA (the frame drawn into 4-sample colour and depth, resolved into the target: every edge, also those
// within a surface the filter cannot see, at about 4 times the fragment work on a CPU rasteriser).
enum class Antialias { None = 0, Fxaa = 1, Msaa = 2 };
enum class Shading { Auto = 0, Forward = 1, Compute = 2 };
constexpr int kMsaaSamples = 4;
// "none", "fxaa" or "msaa" (the command lines' names); anything else is FXAA.
inline Antialias antialiasNamed(const std::string& name) {
  return name == "none" ? Antialias::None : name == "msaa" ? Antialias::Msaa : Antialias::Fxaa;
}

struct RendererSettings {
  ParallaxMode parallax = ParallaxMode::Occlusion;
  DebugView debug = DebugView::Shaded;
  glm::vec3 sunDirection = glm::normalize(glm::vec3(0.55f, -0.75f, -0.5f));  // direction the light travels
  glm::vec3 sunColor{1.7f, 1.62f, 1.5f};
  glm::vec3 skyColor{0.35f, 0.42f, 0.55f}, groundColor{0.18f, 0.16f, 0.14f};  // the sky's tint, the ground's
  float exposure = 0.7f;  // scales the light before the tone map
  bool ibl = true;        // image-based light from the sky (off: the sun alone, a flat sky tint as ambient)
  Antialias antialias = Antialias::Fxaa;
  bool shadows = true;
  bool selfShadow = true;
  int minSteps = 8, maxSteps = 48;
  float lodFadeStart = 1.5f, lodFadeEnd = 3.5f;  // texture lod where POM fades to normal mapping
  GLuint addressMap = 0;                         // RG32F: shown by DebugView::Address
  // Silhouettes that show dents: bodies with maps drawn through tessellation shaders, cut to about
  // displaceSegmentPixels a segment on screen (at most 32 a triangle edge) and moved along the normal by
  // (h - 0.5) k; the fragment stage then shades with the normal map without the parallax march.
  bool displace = false;
  float displaceSegmentPixels = 6.0f;
  // Draw items' simplified meshes where they have one (RenderItem::simplifiedVao): the interactive sandbox's
  // fast path on software GL; batch renders keep the full meshes.
  bool simplified = false;
  // Where the shaded view's pixels are shaded (without MSAA, no displaced item): Forward, in the fragment stage as
  // the items are drawn; Compute, from a visibility buffer (the items drawn with positions alone, the item and
  // triangle nearest at each pixel), by compute shaders running pom.frag's code (pom_shade.comp), once a pixel;
  // Auto: Compute on GPUs whose graphics stages run on a few multiprocessors (NVIDIA's H100, H200, A100, B200
  // and kin), Forward elsewhere.
  Shading shading = Shading::Auto;
};

// What the last drawTo did (for tests and the sandbox's panel).
struct RendererStats {
  int drawn = 0;          // items drawn in the view
  int culled = 0;         // items skipped, wholly outside the view
  int shadowCasters = 0;  // items drawn for the sun's shadow this frame (the others came from its cache)
  bool shadowCacheRedrawn = false;  // the still casters' map was drawn anew
  bool computeShaded = false;       // the items were shaded from a visibility buffer (RendererSettings::shading)
};

class Renderer {
 public:
  Renderer(int width, int height);
  ~Renderer();
  void resize(int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }
  RendererSettings& settings() { return settings_; }
  const RendererStats& stats() const { return stats_; }
  // Draws into the renderer's own offscreen target, or into `framebuffer` when
  // given (the window's, 0), at the renderer's size.
  void draw(const std::vector<RenderItem>& items, const View& view);
  void drawTo(GLuint framebuffer, const std::vector<RenderItem>& items, const View& view);
  // Called at the end of each part of a frame ("light", "shadow map", "visibility clear" and "visibility" where
  // shaded in compute, "items", "sky", "antialias"), once its commands are issued (crumple-bench --render-profile puts GPU timestamps there); none by default.
  void setPassMarker(std::function<void(const char*)> mark) { mark_ = std::move(mark); }
  gl::Image readPixels() const;
  void savePng(const std::string& path) const;
  GLuint framebuffer() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int width_, height_;
  RendererSettings settings_;
  RendererStats stats_;
  std::function<void(const char*)> mark_;
};

// Source of a shader embedded from render/shaders at build time.
std::string_view renderShader(std::string_view fileName);

}  // namespace crumple::render
