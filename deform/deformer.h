// The deformation stage of Wrotek, Rice & McGuire, section 4 and figure 11.
//
// For one collision event and each side X with deformX > 0: both bodies are
// placed at their collision poses, retracted by d_C and X advanced into the
// other by deformX along the normal; an orthographic camera looks at X along
// -N; the address-map passes render X's front faces (depth LESS) and the other
// body's back faces (depth GREATER) with colour = texture coordinate and depth
// offset by the height maps scaled by k'; where both wrote, X's map drops by
// dD (zfar - znear) / k, the deepest write winning per texel. Both sides are
// computed before either is committed.
//
// The paper scatters: each address-map pixel lowers the one texel it
// addresses, so where the touched region holds more texels than the address
// map has pixels, or the surface is oblique to N, texels are skipped and the
// dent has gaps (its section 6). Path::Gather (the default) goes past that:
// only the other body's depth pass is rendered; X's mesh is then drawn in its
// own texture space, one fragment per texel, and each texel's surface point is
// looked up in that depth map like a shadow-map lookup. Every texel of the
// footprint gets its value; the address map's size trades the dent's accuracy
// (the other body's depth is interpolated between its pixels), never its
// continuity. Where the address pass runs in compute (AddressRaster::Compute),
// so does this: X's texels are visited per tile of its map (texel_gather.comp)
// instead of drawn. Path::Scatter is the paper's update on the GPU (compute
// shaders, image atomics, an indirect dispatch over the touched region);
// Path::Readback is the paper's path as written: the address maps read back
// and a CPU scatter. Both are kept as references and give bit-identical maps.
#pragma once
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <memory>
#include <vector>

#include <crumple/deform/options.h>
#include <crumple/deform/surface.h>
#include <crumple/gl/objects.h>

namespace crumple::deform {

// Wall time of one phase of the last deformation (profile mode).
struct PhaseTime {
  const char* name;
  double ms;     // wall, with glFinish at both ends
  double gpuMs;  // GPU time between the phase's timestamps (GL_TIMESTAMP queries)
};
// Ring width (texels) of the crater rim for a dent whose touched region is w x h texels.
int craterRing(int w, int h);

// One body as the deformation sees it: its surface (null when it has no bump
// map: it still shapes the dent, as flat geometry) and its shape-frame-to-world
// transform at collision time.
struct DeformBody {
  Surface* surface = nullptr;
  const GpuMesh* mesh = nullptr;
  glm::dmat4 model{1};
};

struct DeformRequest {
  DeformBody a, b;
  glm::dvec3 point{0};   // P_C
  glm::dvec3 normal{0};  // N_C, out of A
  double penetration = 0;
  double deformA = 0, deformB = 0;  // t * percentDeform per side (m)
  // Each texel is dented by at most its side's depth along the normal, plus how far the two maps' bumps that
  // contacts do not feel reach (heights above flat: an image's relief, and the rims of a body whose dents are not
  // felt; Surface::unfeltHighest): X is retracted to first contact and advanced by its depth, so an overlap beyond
  // that was there before (a pose the contact did not measure, as a body rocking in its own crater or rolling over
  // a rim between its samples) and is not this event's to cut. false: no bound (the whole overlap is cut, as where
  // the other body is pressed in where it stands).
  bool boundByDepth = true;
};

// What one side's update did; filled when stats are fetched.
struct SideStats {
  int texelsChanged = 0;
  double maxDent = 0;      // m: largest drop of one texel, times k
  bool saturated = false;  // some texel reached 0
};

// The address-map camera for deforming the side whose outward normal is n.
struct AddressCamera {
  glm::dmat4 view{1}, projection{1};
  double zNear = 0, zFar = 1;
  double extent = 1;  // side of the square viewport (m)
};
AddressCamera addressCamera(const glm::dvec3& point, const glm::dvec3& n, const glm::dvec3 boundsX[2],
                            const glm::dvec3 boundsOther[2]);
// World AABB of a mesh under a transform.
void worldBounds(const GpuMesh& mesh, const glm::dmat4& model, glm::dvec3 out[2]);

class Deformer {
 public:
  explicit Deformer(const DeformOptions& options);
  ~Deformer();
  Deformer(const Deformer&) = delete;
  Deformer& operator=(const Deformer&) = delete;

  const DeformOptions& options() const { return options_; }
  // The rasteriser of the gather's address pass on this GPU (DeformOptions::addressRaster, Auto resolved).
  AddressRaster addressRaster() const;
  void setOptions(const DeformOptions& options);

  // Runs both sides of one event. Returns a handle to its stats (two entries).
  int deform(const DeformRequest& request);
  // Runs the events in order, with the results of running them one by one, bit for bit; returns their handles.
  // With the compute rasteriser (AddressRaster::Compute) on the gather path, events in a row whose surfaces are
  // all different (neither side of one touches a surface of another) run as one wave: each stage of all their
  // sides before one memory barrier, rather than each event's stages with barriers of their own, and each stage
  // one dispatch for many sides (up to 8 to 16, or a mesh's), not one a side. A wave holds
  // at most as many events as DeformOptions::waveMemory allows.
  std::vector<int> deform(const std::vector<DeformRequest>& requests);
  // Waves run so far (a single event is one).
  long wavesRun() const;
  // The most events a wave holds under these options (DeformOptions::waveMemory at its address map); 1 where
  // waves do not apply (the paper's paths, crater rims, the fragment stage's rasteriser).
  size_t waveLimit() const;
  // Stats of handle h (side 0 = A, 1 = B). Reads the small stats buffer back once.
  SideStats stats(int handle, int side);

  // Maps for a new surface: a flat map or the given image, with its normal map.
  std::shared_ptr<SurfaceMaps> createMaps(int resolution, const gl::Image* initial, float bumpDepth,
                                          float texelSize);
  // Recomputes the normal map of a surface over texels [lo, hi] (inclusive).
  void regenerateNormals(Surface& s, glm::ivec2 lo, glm::ivec2 hi);
  // The last address map of side 0, for the renderer's debug view: the uv of X
  // (scatter paths) or of the other body (the gather renders only its pass).
  const gl::Texture2D& lastAddressMap() const;
  // With the address pass in compute: the tiles of lastAddressMap's map its raster ran (those with triangles to
  // test), and the map's tiles (read back from the GPU; for tests).
  std::pair<size_t, size_t> lastRasterTiles() const;
  // With the gather in compute (the compute rasteriser): the texel tiles of X's maps the last deformation's gather
  // kept (those near the contact) and all of them, over its sides (read back from the GPU; for tests).
  std::pair<size_t, size_t> lastGatherTiles() const;
  // The change log: once started, each commit appends, for every texel it changes in a map whose surface has a
  // log id (Surface::setChangeLog), an entry of three uints (the id, the texel y * resolution + x, the new height's
  // float bits) to a buffer the CPU reads where the GPU wrote it (persistently mapped, client storage: on a
  // discrete GPU the shader's writes cross the bus, nothing else does). Entries of one commit come in no set order,
  // a texel at most once; commits in the order they ran. logChanges(capacity) starts it (capacity: entries);
  // fenceChanges() makes the commits so far visible to the CPU once the returned fence signals (the caller waits
  // on it and deletes it); changes() then reads them; clearChanges() empties the log for the commits after it.
  struct Changes {
    const GLuint* entries = nullptr;  // 3 uints an entry
    size_t count = 0;                 // entries written (at most the capacity)
    bool overflowed = false;          // more changed than the capacity holds: the log is incomplete
  };
  void logChanges(size_t capacity);
  GLsync fenceChanges();
  Changes changes() const;
  void clearChanges();
  // For the displaced renderer: makes `s`'s crease bevel (SurfaceMaps::crease, crease_bevel.comp) if its map
  // changed since it was last made (nothing for a map no commit has changed, or a mesh without a node graph).
  // Each node of the mesh is drawn within an edge's length of where any neighbour that moved further went, so a
  // panel crushed against an undented one across a hard edge meets it in a bevel of 1:1, not a wall: rounds of
  // that relaxation over the mesh's edges, as many as the bump depth spans short edges (at most 32).
  // Before it makes the bevel, the map's mip levels are made again over its uv charts alone (chartLevels): the
  // bevel and the displaced renderer read coarse levels, where an atlas's undented gutters would otherwise blend
  // into a crushed chart's edge.
  void creaseBevel(Surface& s);
  // `s`'s height map's levels above level 0 over its mesh's uv charts alone (height_levels.comp, ChartCover): each
  // texel the mean of the covered level-0 texels under it, a texel no chart covers the level above's value at its
  // centre. Level 0 is unchanged.
  void chartLevels(Surface& s);
  // Phases of the last deform() when options().profile is set (empty otherwise).
  const std::vector<PhaseTime>& profile() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  DeformOptions options_;
};

// Shaders of the deform layer embedded at build time.
std::string_view deformShader(std::string_view fileName);

}  // namespace crumple::deform
