// The passes of one deformation (internal to deform/). Each owns its program,
// looks its uniform locations up once and has typed setters; the Deformer
// (deformer.cpp) runs them in the order of figure 11:
//
//   AddressPasses   the paper's two rasterised passes: X's front faces (pass A)
//                   and the other body's back faces (pass B), colour = texture
//                   coordinate, depth offset by the height maps scaled by k'
//   GatherUpdate    the default update: X drawn in its own texture space, each
//                   texel's surface point looked up in pass B's depth
//   ScatterUpdate   the paper's update on the GPU: each address-map pixel
//                   lowers the texel it addresses
//   ReadbackUpdate  the paper's update as written: the address maps read back
//                   and scattered on the CPU
//   CraterRims      the volume a dent pushed down raised in a ring around it
//   CommitPass      new heights written over the touched region, the normal
//                   map regenerated there
//
// Every update writes new heights as float bits into a scratch (a range of one
// buffer, +infinity where untouched; the deepest write wins by an atomic minimum) and
// grows the side's touched region (ivec4 per side in a region buffer).
#pragma once
#include <glm/glm.hpp>

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <crumple/deform/bindings.h>
#include <crumple/deform/deformer.h>
#include <crumple/gl/objects.h>
#include <crumple/gl/program.h>

namespace crumple::deform {

constexpr GLuint kUntouched = 0x7f800000u;  // +infinity as float bits
// Marks the end of a named phase (profile mode: wall and GPU time since the last mark).
using PhaseMark = std::function<void(const char*)>;
inline GLuint dispatchGroups(int n) { return static_cast<GLuint>((n + 15) / 16); }
// A deform shader's source with each line `#include "file"` replaced by that embedded file.
std::string deformSource(const char* name);
inline gl::Program computeProgram(const char* name) {
  return gl::Program({{GL_COMPUTE_SHADER, name, deformSource(name)}});
}

// `buffer` replaced by a new one of at least `boxes` empty texel boxes (x0, y0, x1, y1 = INT_MAX, INT_MAX, -1, -1:
// atomics grow them), as many as it held if more.
void clearBoxes(gl::Buffer& buffer, int boxes);
// `buffer` replaced by a new one holding `bytes` of `data`. Data the CPU hands to a wave's shaders goes into new
// buffers, never into one that earlier commands may still read: on NVIDIA's driver (580, H200) a
// glNamedBufferSubData into a buffer that a queued dispatch reads as shader storage reached that dispatch late
// (a wave's commit ran with the last wave's entries); a buffer made with its data cannot be read before it.
void freshBuffer(gl::Buffer& buffer, size_t bytes, const void* data);

// A side's new heights: resolution^2 uints (float bits, row by row; kUntouched where untouched) from `offset`
// (uints) of the deformer's scratch buffer, which shaders see at bindings::kScratch (uScratch[], their
// uScratchBase = offset).
struct Scratch {
  const gl::Buffer* buffer = nullptr;
  GLuint offset = 0;
  void bind() const { gl::bindStorage(bindings::kScratch, buffer->id()); }
};

// What the updates share about one side of one event.
struct SideUpdate {
  int side = 0;
  int resolution = 0;       // X's map
  float depthToHeight = 0;  // (zfar - znear) / k
  float bumpToDepth = 0;    // X's k' / (zfar - znear)
  float bumpReach = 0;      // how far X's bumps raise a point towards the camera at most: (highest - 0.5) k' / range
  // The deepest a texel is dented along the view (window depth): X's deformation depth d / range and the reach
  // of the two maps' bumps (DeformRequest::boundByDepth; 2: no bound).
  float pushDepth = 0;
  TangentMode tangent = TangentMode::None;
  float tangentFloor = 0.2f;
  glm::vec3 viewNormal{0};  // N_C as owned by X (towards the camera)
};

class AddressPasses {
 public:
  explicit AddressPasses(int size);
  void resize(int size);
  int size() const { return size_; }
  // Slots 0 and 1 serve every path; a wave of events (Deformer::deform of several, compute raster) gives each
  // side of each event a slot of its own for the compute pass B: its targets and bins.
  void reserveSlots(int slots);
  int slots() const { return static_cast<int>(addressO_.size()); }
  // Bytes a slot holds at address map `size` (its targets and tile lists).
  static size_t slotBytes(int size);
  // Pass A: X's front faces, depth LESS; the world-normal attachment only when asked (tangent correction).
  void drawX(int side, const DeformBody& x, const glm::dmat4& viewProjection, const glm::dmat4& model,
             float bumpToDepth, bool normals);
  // Pass B: the other body's back faces, depth GREATER: against X's depth from pass A (scatter), or
  // alone, the farthest back face anywhere (the gather's depth map).
  void drawOther(int side, const DeformBody& other, const glm::dmat4& viewProjection, const glm::dmat4& model,
                 float bumpToDepth, bool alone);
  // The gather's pass B (drawOther alone) rasterised in compute shaders (address_bin.comp, address_raster.comp)
  // for every side of a wave at once: the same targets, filled by every invocation of the GPU rather than by its
  // fragment stage (on compute GPUs such as NVIDIA's H100 only a few of the multiprocessors run fragment
  // shaders), and each stage one dispatch for all the sides (a GPU runs dispatches one after another: a
  // dispatch a side made a wave cost the sum of its sides). A binned rasteriser: the bins append each triangle
  // to the lists of the 8 x 8-pixel tiles it may cover (or, spanning over 1024, to a list of large ones every
  // tile tests), listing the tiles that got something (active), one dispatch a mesh for the sides whose other
  // body it is; the raster, after a barrier, tests the active tiles' pixels against their lists, one indirect
  // dispatch for up to kGroup sides (their height maps bound as an array of samplers). The other tiles must
  // hold "none": first, in compute, it is put back on the tiles each side's last raster wrote (all of them after
  // the fragment pass or at the start; glClearTexImage of a whole map ran at fragment-stage speed on NVIDIA's
  // H200: 0.45 ms at 1024). The targets of all slots are layers of one texture array each.
  // `reach`: triangles whose window depth stays below it everywhere are left out (their pixels unseen): the
  // other body there does not reach X's nearest depth (both bodies' bumps counted), so it cannot dent it.
  struct OtherPass {
    int slot = 0;
    const DeformBody* other = nullptr;
    glm::dmat4 viewProjection{1}, model{1};
    float reach = 0, bumpToDepth = 0;
  };
  // Issues its own barriers; on return the targets are written (the caller's barrier makes them visible to
  // texture fetches). `phase` marks "address bins" after the bins.
  void rasterOthers(const std::vector<OtherPass>& passes, const PhaseMark& phase);
  // Per slot, the pixels (x0, y0, x1, y1, inclusive) the compute raster writes; outside them it leaves "none".
  // clearReach() empties the slots' rectangles; ComputeGather::cull grows them to what its texels can read.
  const gl::Buffer& reach() const { return reach_; }
  void clearReach(int slots);
  const gl::Texture2D& addressX(int side) const { return addressX_[side]; }
  const gl::Texture2D& depthX(int side) const { return depthX_[side]; }
  const gl::Texture2D& normalX(int side) const { return normalX_[side]; }
  // The tiles the last compute raster of a slot ran, and all of the map's (read back: waits for the GPU; tests).
  std::pair<size_t, size_t> tilesRun(int side) const;
  const gl::Texture2D& addressOther(int side) const { return addressO_[side]; }
  // All slots' pass B targets (layer = slot).
  const gl::TextureArray& addressOthers() const { return addressArray_; }
  const gl::TextureArray& depthOthers() const { return depthArray_; }
  const gl::Texture2D& depthOther(int side) const { return depthO_[side]; }

 private:
  void draw(const DeformBody& body, const glm::dmat4& viewProjection, const glm::dmat4& model, float sign,
            float bumpToDepth);
  gl::Program program_, bin_, raster_;
  gl::Uniform<glm::mat4> uMvp_{program_, "uModelViewProjection"};
  gl::Uniform<glm::mat3> uNormalToWorld_{program_, "uNormalToWorld"};
  gl::Uniform<float> uSign_{program_, "uSign"}, uBumpToDepth_{program_, "uBumpToDepth"};
  gl::Uniform<int> bSize_{bin_, "uSize"}, bCapacity_{bin_, "uCapacity"}, bFirst_{bin_, "uFirst"};
  gl::Uniform<int> rSize_{raster_, "uSize"}, rCapacity_{raster_, "uCapacity"}, rMode_{raster_, "uMode"},
      rFirst_{raster_, "uFirst"};
  static constexpr int kTile = 8, kTileCapacity = 64;
  static constexpr int kGroup = 16;  // sides a raster dispatch: its height maps from bindings::address::kHeights
  size_t tiles() const;
  size_t countStride() const { return tiles() + 6; }  // uints of a slot's counts (address_bin.comp)
  // What a slot's targets hold outside the tiles to write: "none" everywhere (None), "none" outside the active
  // tiles its counts list (Tiles: after a raster), or anything (Unknown: at the start, after the fragment pass).
  enum class Held { None, Tiles, Unknown };
  std::vector<Held> held_;  // per slot
  // The compute pass B's buffers: per slot, at fixed strides, the counts (per tile, then the large triangles',
  // the active tiles', 3 unused, whether every tile is active), tile lists and active tiles; per wave, each
  // side's triangle setups and large triangles (at its entry's `setup`), the entries (address_bin.comp's Entry)
  // and each raster group's indirect dispatch (3 uints).
  gl::Buffer count_, list_, active_, setup_, large_, entries_, args_, reach_;
  gl::Texture2D flat_{1, 1, GL_R32F};
  int size_ = 0;
  // Per side: address, depth copy, world normal; one depth buffer shared by the passes of a side.
  gl::Texture2D addressX_[2], depthX_[2], normalX_[2], depthBuffer_[2];
  // Per slot (at least 2): pass B's address and depth, layers of one array each, and a 2D view of each layer.
  gl::TextureArray addressArray_, depthArray_;
  std::vector<gl::Texture2D> addressO_, depthO_;
  void makeSlots(int slots);  // (re)makes the slots' targets and buffers at the current size
  gl::Framebuffer fboX_[2], fboO_[2];
};

class GatherUpdate {
 public:
  GatherUpdate();
  // Draws X (at `model`, seen through `viewProjection`) in its texture space over the texels the camera sees
  // and that reach the other body's farthest window depth. No barriers of its own: before it, the address
  // pass's targets must be made visible to texture fetches; after it, its image and storage writes.
  void run(const SideUpdate& u, const GpuMesh& mesh, const gl::Texture2D& height, const glm::dmat4& viewProjection,
           const glm::dmat4& model, const AddressPasses& passes, float farthestOther, const Scratch& scratch,
           const gl::Buffer& region);

 private:
  void bindTexelSpace(int resolution);
  gl::Program program_;
  gl::Uniform<glm::mat4> uMvp_{program_, "uModelViewProjection"};
  gl::Uniform<glm::mat3> uNormalToWorld_{program_, "uNormalToWorld"};
  gl::Uniform<int> uResolution_{program_, "uResolution"}, uSide_{program_, "uSide"}, uSize_{program_, "uSize"},
      uTangentMode_{program_, "uTangentMode"};
  gl::Uniform<float> uViewMargin_{program_, "uViewMargin"}, uFarthestOther_{program_, "uFarthestOther"},
      uBumpReach_{program_, "uBumpReach"}, uBumpToDepth_{program_, "uBumpToDepth"},
      uDepthToHeight_{program_, "uDepthToHeight"}, uTangentFloor_{program_, "uTangentFloor"},
      uPushDepth_{program_, "uPushDepth"};
  gl::Uniform<glm::vec3> uViewNormal_{program_, "uViewNormal"};
  gl::Uniform<GLuint> uScratchBase_{program_, "uScratchBase"};
  // Framebuffers without attachments, one per map size drawn (a software rasteriser bins all of it); kept, so
  // that sides of different sizes in a row do not reconfigure one.
  std::map<int, gl::Framebuffer> texelSpace_;
};

// Which of a mesh's triangles reach each tile of kTile x kTile texels of its map at one resolution: those whose
// footprint in texture space, grown by half a texel (conservatively, as texel.geom grows it), overlaps the tile's
// texels; and the tile's box in the shape frame (those triangles' parts over the tile's texels, grown by a texel
// and a half on the surface: the texels' points extrapolated past a triangle stay within it; a large triangle
// then bounds each tile by the little of it there). Made on the CPU from the mesh (read back
// once) on first use at a resolution; kept with the mesh (GpuMesh::texelCovers).
struct TexelCover {
  static constexpr int kTile = 16;
  int resolution = 0, tilesX = 0;
  gl::Buffer start;      // tilesX^2 + 1 uints: tile k's triangles are triangles[start[k] .. start[k + 1])
  gl::Buffer triangles;  // triangle indices
  gl::Buffer boxes;      // 2 vec4 a tile: min xyz, max xyz (shape frame; empty tiles min > max)
  size_t listed = 0;         // entries in `triangles`
  size_t tiles() const { return static_cast<size_t>(tilesX) * static_cast<size_t>(tilesX); }
  static std::shared_ptr<const TexelCover> of(const GpuMesh& mesh, int resolution);
};

// Which texels of a mesh's map at one resolution its uv charts cover, as the gather writes them (a texel whose
// square overlaps a triangle), and per mip level the fraction of each texel's level-0 texels covered: the chart
// levels' weights (Deformer::chartLevels). `cover` holds the levels one after the other (level k from offsets[k],
// row-major, level k's size max(1, resolution >> k)). Made on the CPU from the mesh (read back once) on first use at
// a resolution; kept with the mesh (GpuMesh::chartCovers).
struct ChartCover {
  std::vector<GLuint> offsets;  // a level's first entry in `cover`; levels = offsets.size()
  gl::Buffer cover;             // floats
  long covered = 0;             // level-0 texels covered
  static std::shared_ptr<const ChartCover> of(const GpuMesh& mesh, int resolution);
};

// The gather in compute shaders (texel_gather.comp) for all the sides of a wave: where the address pass runs
// in compute (GPUs whose fragment stage is narrow), X's texels are visited by every invocation of the GPU, not
// drawn through the graphics stages. Two dispatches for up to kGroup sides of one mesh and map resolution: the
// first keeps the tiles whose box meets the side's camera (and that list triangles), the second runs a
// workgroup a kept (tile, side), indirectly: each invocation takes one texel and every triangle of the tile's
// list that faces the camera and whose footprint grown by half a texel holds it, with the surface point (and normal) where the triangle's affine map puts the texel's centre: the
// texels texel.geom's conservative draw gives fragments, within the tests' tolerance (its view clip is applied
// per texel here), and the same update per (texel, triangle), the deepest winning.
class ComputeGather {
 public:
  ComputeGather();
  struct Side {
    const SideUpdate* u = nullptr;
    const GpuMesh* mesh = nullptr;
    const gl::Texture2D* height = nullptr;
    glm::dmat4 viewProjection{1}, model{1};
    float farthestOther = 0;
    Scratch scratch;
  };
  // First (before the address pass): keeps each side's tiles near its camera and grows the side's slot's pixel
  // rectangle in `reach` (AddressPasses::reach) to hold where their texels and the pixels a bilinear read takes
  // lie: the address pass then rasterises no pixel outside it. `sides` must live until gather().
  void cull(const std::vector<Side>& sides, int addressMap, const gl::Buffer& reach);
  // Then (after the address pass and a texture-fetch barrier): the kept tiles' texels. No barriers of its own.
  void gather(const AddressPasses& passes, const gl::Buffer& region);
  // The last run's kept tiles (summed over its sides) and all of its sides' tiles (read back: waits; tests).
  std::pair<size_t, size_t> lastKept() const;

 private:
  static constexpr int kGroup = 14;  // X's height maps from bindings::gather::kHeights (units 2 .. 15)
  static constexpr size_t kHeadUints = 64;  // a dispatch's head in keptHead_ (256 bytes: any binding alignment)
  gl::Program program_;
  gl::Uniform<int> uSize_{program_, "uSize"}, uFirst_{program_, "uFirst"}, uMode_{program_, "uMode"};
  // The sides; each dispatch's kept tiles (texel_gather.comp's Kept) and, 256 bytes a dispatch, their count and
  // indirect dispatch (KeptHead: made new each run, from the CPU).
  gl::Buffer entries_, kept_, keptHead_;
  std::vector<size_t> keptAt_;     // the last run's dispatches' offsets into kept_
  size_t tilesRun_ = 0;            // the last run's sides' tiles, all of them
  struct Dispatch {                // up to kGroup sides of one mesh and resolution
    size_t first, count;
    std::shared_ptr<const TexelCover> cover;
    const GpuMesh* mesh;
  };
  std::vector<const Side*> order_;  // the sides by kind (the entries' order)
  std::vector<Dispatch> dispatches_;
  void bind(size_t dispatch) const;
};

class ScatterUpdate {
 public:
  ScatterUpdate();
  void run(const SideUpdate& u, const AddressPasses& passes, const gl::Texture2D& height,
           const Scratch& scratch, const gl::Buffer& region);

 private:
  gl::Program program_;
  gl::Uniform<int> uSide_{program_, "uSide"}, uResolution_{program_, "uResolution"},
      uTangentMode_{program_, "uTangentMode"};
  gl::Uniform<glm::ivec2> uSize_{program_, "uSize"};
  gl::Uniform<float> uDepthToHeight_{program_, "uDepthToHeight"}, uTangentFloor_{program_, "uTangentFloor"},
      uPushDepth_{program_, "uPushDepth"};
  gl::Uniform<glm::vec3> uViewNormal_{program_, "uViewNormal"};
  gl::Uniform<GLuint> uScratchBase_{program_, "uScratchBase"};
};

// Ring width (texels) of the crater rim for a dent whose touched region is w x h texels: craterRing(), found on
// the GPU (rim_dispatch.comp) with the passes' dispatch sizes: nothing is read back.
class CraterRims {
 public:
  CraterRims();
  // The rim of side's dent into the scratch; its ring width stays in ring() for the commit.
  void run(int side, int resolution, const gl::Texture2D& height, const Scratch& scratch,
           const gl::Buffer& region);
  // Per side: the rim passes' indirect dispatch sizes (3 uints each), then the ring widths (2 ints).
  const gl::Buffer& ring() const { return rim_; }

 private:
  gl::Program program_, dispatch_;
  gl::Uniform<int> uSide_{program_, "uSide"}, uResolution_{program_, "uResolution"}, uMode_{program_, "uMode"};
  gl::Uniform<GLuint> uScratchBase_{program_, "uScratchBase"};
  gl::Uniform<int> dSide_{dispatch_, "uSide"}, dResolution_{dispatch_, "uResolution"};
  gl::Buffer sums_;
  gl::Buffer rim_{8 * sizeof(GLuint), nullptr, GL_DYNAMIC_STORAGE_BIT};
};

class ReadbackUpdate {
 public:
  void run(const SideUpdate& u, const AddressPasses& passes, const gl::Texture2D& height, bool craterRims,
           const Scratch& scratch, gl::Buffer& region, const PhaseMark& phase);

 private:
  void scatter(const SideUpdate& u, const AddressPasses& passes, const std::vector<float>& h, bool craterRims,
               std::vector<float>& out, GLint box[4]);
  std::vector<float> ca_, da_, cb_, db_, na_;
};

class CommitPass {
 public:
  CommitPass();
  // One side of an event to commit: X (null: nothing to commit on this side), its new heights, and the crater
  // rim's CraterRims::ring() buffer when it has a rim (the region grows by its ring).
  struct Side {
    Surface* x = nullptr;
    const gl::Buffer* rim = nullptr;
    Scratch scratch;
    int statsIndex = 0;
  };
  // Writes each side's new heights into its X's map over its region (sides[k]: region slot k), counts what
  // changed into stats entry statsIndex, puts the scratch back to untouched, and regenerates the normals and the
  // bound pyramid there. The sides (different maps) go stage by stage, one memory barrier a stage for all, each
  // stage one dispatch for up to kGroup sides (the bound's levels above level 0: one a map). With `changes` (the
  // Deformer's change log, dent_commit.comp's layout), the texels changed in maps that keep a log are appended.
  void run(const std::vector<Side>& sides, const gl::Buffer& region, const gl::Buffer& stats,
           const gl::Buffer* changes, const PhaseMark& phase);
  // Normals and the bound pyramid over texels [lo, hi] of a map (inclusive).
  void normals(const SurfaceMaps& maps, int resolution, float slopeScale, glm::ivec2 lo, glm::ivec2 hi);

 private:
  void reserve(size_t sides);
  static constexpr int kGroup = 8;  // sides a dispatch: their maps from bindings::commit (8 image units: GL's least)
  gl::Program dispatch_, commit_, normals_, bound_, boundUp_;
  gl::Uniform<int> dCount_{dispatch_, "uCount"}, dTile_{dispatch_, "uTile"};
  gl::Uniform<int> cFirst_{commit_, "uFirst"};
  // normal_map.comp and height_bound.comp run over a wave's sides (uFull 0) or one whole map (uFull 1, its
  // region and resolution in uFullRegion, uFullResolution).
  gl::Uniform<int> nFirst_{normals_, "uFirst"}, nFull_{normals_, "uFull"}, nFullResolution_{normals_, "uFullResolution"};
  gl::Uniform<glm::ivec4> nFullRegion_{normals_, "uFullRegion"};
  gl::Uniform<float> nFullSlopeScale_{normals_, "uFullSlopeScale"};
  gl::Uniform<int> bFirst_{bound_, "uFirst"}, bFull_{bound_, "uFull"}, bFullResolution_{bound_, "uFullResolution"},
      bTile_{bound_, "uTile"}, bLevel_{bound_, "uLevel"};
  gl::Uniform<glm::ivec4> bFullRegion_{bound_, "uFullRegion"};
  gl::Uniform<int> upFirst_{boundUp_, "uFirst"}, upTile_{boundUp_, "uTile"};
  size_t sides_ = 0;
  // Per slot: the region grown by a texel (ivec4); per side the entry (commit_side.glsl); per group of kGroup
  // the commit's, the normals' and level 0 of the bound's indirect dispatch (9 uints).
  gl::Buffer normalRegion_, entries_, args_;
  gl::Buffer noChanges_;  // bound at kChanges when nothing is logged (capacity 0)
};

}  // namespace crumple::deform
