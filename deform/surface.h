// A deformable surface: a body's render mesh on the GPU with its height map
// (R32F, 0 = deepest dent, 0.5 = flat, 1 = highest bump) and the normal map
// derived from it. Bodies of one mesh share the undeformed maps until their
// first dent (lazy maps, Wrotek et al. section 6).
#pragma once
#include <glm/glm.hpp>

#include <map>
#include <memory>

#include <crumple/physics/mesh.h>
#include <crumple/gl/objects.h>
#include <crumple/gl/image.h>

namespace crumple::deform {

struct TexelCover;  // deform/passes.h: which triangles reach each tile of the texels, at one map resolution
struct ChartCover;  // deform/passes.h: which texels the uv charts cover, per mip level, at one map resolution

struct GpuMesh {
  gl::VertexArray vao;
  gl::Buffer vertices;  // position (3), normal (3), uv (2), colour (3, sRGB; white without), material uv (2),
                            // material (1, -1 none), normal averaged over the vertices at its position (3) floats
  gl::Buffer indices;
  GLsizei indexCount = 0;
  // Where its uv charts meet, for the displaced renderer (render/shaders/pom_displace.tese): per triangle edge
  // (opposite corner e: entry 3 t + e) the uvs of the other chart at the edge's ends, -1 where none; per vertex
  // (two entries) the uvs of up to three other vertices at its position, and their count.
  gl::Buffer seamEdges, seamVertices;
  // For interactive views (render::RendererSettings::simplified), meshes over kSimplifyAbove triangles get
  // - the same vertices under fewer triangles: simplified (meshoptimizer's edge collapses, which keep uv seams
  //   and open borders) while the surface moves at most kSimplifyError metres, ordered for the vertex cache;
  // - a shadow caster: positions alone, welded, simplified within kShadowError metres (a shadow map texel of
  //   the shipped scenes is several centimetres).
  // The counts are 0 for smaller meshes.
  static constexpr size_t kSimplifyAbove = 1000;
  static constexpr float kSimplifyError = 0.003f, kShadowError = 0.01f;
  gl::VertexArray simplifiedVao;
  gl::Buffer simplifiedIndices;
  GLsizei simplifiedIndexCount = 0;
  gl::VertexArray shadowVao;
  gl::Buffer shadowVertices, shadowIndices;
  GLsizei shadowIndexCount = 0;
  // The crease bevel's graph (Deformer::creaseBevel): the mesh's positions as nodes (the vertices at one position,
  // across uv seams and hard edges, are one node); per vertex its node (uint); per node the uvs of its vertices
  // and its neighbours along triangle edges with the edges' lengths (CSR: nodeCount + 1 offsets, then uv pairs /
  // (node, length) pairs, floats as their bits), and its position and averaged normal (two vec4). nodeCount 0: no
  // uvs or normals, no graph.
  gl::Buffer vertexNodes, nodeUvs, nodeLinks, nodeFrames;
  GLuint nodeCount = 0;
  float shortEdge = 0;  // m: a short edge of the mesh (5th percentile), the step of the bevel's reach
  glm::vec3 boundsMin{0}, boundsMax{0};  // shape frame
  double metresPerUv = 1;                // sqrt(surface area / uv area)
  // The compute gather's (deform/texel_cover.cpp), per map resolution: made on first use, kept with the mesh.
  mutable std::map<int, std::shared_ptr<const TexelCover>> texelCovers;
  // The chart levels' (Deformer::chartLevels), per map resolution: made on first use, kept with the mesh.
  mutable std::map<int, std::shared_ptr<const ChartCover>> chartCovers;
  explicit GpuMesh(const TriangleMesh& mesh);
  void draw() const;
};

struct SurfaceMaps {
  // R32F, with mip levels (the deformer makes them after each change; the displaced renderer reads them through a
  // sampler of its own): sampled at level 0 everywhere else.
  gl::Texture2D height;
  gl::Texture2D normal;  // RGBA8, tangent space
  // The height's bound pyramid (height_bound.comp, R32F, kept with the normals): level 0 holds per tile of
  // kBoundTile x kBoundTile texels the largest |h - 0.5| there, each level above the largest of 2 x 2 below
  // (sizes powers of two; texels past the map 0). The renderer's parallax march skips rays it bounds at 0.
  // The levels lie side by side in one level of one texture (boundOrigin), so that a shader writes all of a
  // map's levels through one image binding (a dispatch then updates 8 maps' pyramids).
  static constexpr int kBoundTile = 16;
  gl::Texture2D bound;
  // No height of the map lies above this: the initial map's highest (Deformer::createMaps), kept while dents only
  // lower heights, back to 1 once a crater rim raises some. The deformer's culls bound how far bumps reach by it
  // (a flat map's bumps reach nowhere) instead of by the highest a map could hold.
  float highest = 1.0f;
  // The initial map's highest (0.5 where flat), kept whatever dents do: the relief that no dent made.
  float imageHighest = 1.0f;
  long version = 0;  // commits into these maps so far
  // For the displaced renderer: per node of the mesh (GpuMesh::vertexNodes), a vec4 whose xyz is how far it is
  // drawn from where its height puts it (shape frame, m), so that no node lies further than an edge's length
  // from where a deeper neighbour went (Deformer::creaseBevel); current while creaseVersion == version.
  gl::Buffer crease;
  long creaseVersion = -1;
  explicit SurfaceMaps(int resolution);
  static int boundSize(int resolution);  // level 0's width and height (S, a power of two)
  int boundLevels() const;               // log2 S + 1
  // Where level k lies in `bound` (S + S / 2 wide, S high; S alone when S is 1): level 0 at (0, 0), level
  // k >= 1 at (S, S - 2 (S >> k)); level k is S >> k a side. pom.frag and the deform shaders place them so.
  static glm::ivec2 boundOrigin(int size, int level) {
    return level == 0 ? glm::ivec2(0) : glm::ivec2(size, size - 2 * (size >> level));
  }
};

class Surface {
 public:
  // `initial` is the starting height map (resolution x resolution, 1 channel) or
  // null for a flat map. `shared` maps may be passed to start lazily.
  Surface(std::shared_ptr<const GpuMesh> mesh, int resolution, float bumpDepth, float bumpDepthCollide,
          std::shared_ptr<SurfaceMaps> shared);
  const GpuMesh& mesh() const { return *mesh_; }
  int resolution() const { return resolution_; }
  float bumpDepth() const { return k_; }
  float bumpDepthCollide() const { return kCollide_; }
  void setBumpDepths(float k, float kCollide) {
    k_ = k;
    kCollide_ = kCollide;
  }
  const gl::Texture2D& height() const { return maps_->height; }
  const gl::Texture2D& normal() const { return maps_->normal; }
  const SurfaceMaps& maps() const { return *maps_; }
  // Gives this surface its own maps (copies of the shared ones) before it is changed.
  void makeUnique();
  // Its heights may now be anywhere up to 1 (a crater rim raised some): SurfaceMaps::highest.
  void heightsMayRise() { maps_->highest = 1.0f; }
  // Whether contacts with its body are measured on its dented surface (the world feels its dents): a deformation
  // then bounds its cut by the relief of its image only (SurfaceMaps::imageHighest), not of its dents and rims,
  // which the contact measured (DeformRequest::boundByDepth).
  void setDentsFelt(bool felt) { dentsFelt_ = felt; }
  // The highest of its heights that contacts do not feel: its image's where its dents are felt, else its map's.
  float unfeltHighest() const { return dentsFelt_ ? maps_->imageHighest : maps_->highest; }
  // A commit changed its map.
  void changed() { ++maps_->version; }
  SurfaceMaps& mutableMaps() { return *maps_; }
  // The crease bevel of its map as it is now (Deformer::creaseBevel made it since the last change), else null.
  const gl::Buffer* crease() const {
    return maps_->version > 0 && maps_->creaseVersion == maps_->version ? &maps_->crease : nullptr;
  }
  bool isShared() const { return maps_.use_count() > 1; }
  float texelSize() const { return static_cast<float>(mesh_->metresPerUv / resolution_); }
  gl::Image downloadHeight() const;
  // Its id in the deformer's change log (Deformer::logChanges): the commits append the texels they change in its
  // map under this id; -1 (the default): not logged.
  int changeLog() const { return changeLog_; }
  void setChangeLog(int id) { changeLog_ = id; }

 private:
  std::shared_ptr<const GpuMesh> mesh_;
  std::shared_ptr<SurfaceMaps> maps_;
  int resolution_;
  float k_, kCollide_;
  int changeLog_ = -1;
  bool dentsFelt_ = false;
};

}  // namespace crumple::deform
