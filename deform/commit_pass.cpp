// The commit of one side's new heights over its touched region, and the
// normal map regenerated there (also used for whole maps at creation).
#include <algorithm>

#include <crumple/deform/passes.h>

namespace crumple::deform {

namespace {
// commit_side.glsl's CommitEntry (std430).
struct CommitEntry {
  GLint slot, resolution, grow, statsIndex;
  GLuint scratchBase;
  float bumpDepth, slopeScale;
  GLint group, changeLog;
};
static_assert(sizeof(CommitEntry) == 36, "CommitEntry must match commit_side.glsl");
}  // namespace

CommitPass::CommitPass()
    : dispatch_(computeProgram("region_dispatch.comp")),
      commit_(computeProgram("dent_commit.comp")),
      normals_(computeProgram("normal_map.comp")),
      bound_(computeProgram("height_bound.comp")),
      boundUp_(computeProgram("height_bound_up.comp")) {}

void CommitPass::reserve(size_t sides) {
  if (sides <= sides_) return;
  sides_ = std::max<size_t>(sides, 2);
  normalRegion_ = gl::Buffer(sides_ * 4 * sizeof(GLint), nullptr, GL_DYNAMIC_STORAGE_BIT);
}

void CommitPass::run(const std::vector<Side>& sides, const gl::Buffer& region, const gl::Buffer& stats,
                     const gl::Buffer* changes, const PhaseMark& phase) {
  // Sides (by slot; some without X) in groups of kGroup, a dispatch a group and stage; each group dispatched
  // over the largest region of its sides (region_dispatch.comp), the others' workgroups returning at once.
  reserve(sides.size());
  std::vector<CommitEntry> entries;
  std::vector<const Side*> of;
  const gl::Buffer* rim = nullptr;
  for (size_t slot = 0; slot < sides.size(); ++slot) {
    const Side& s = sides[slot];
    if (!s.x) continue;
    if (s.rim) s.x->heightsMayRise();
    s.x->changed();
    const GLint group = static_cast<GLint>(entries.size() / kGroup);
    entries.push_back({static_cast<GLint>(slot), s.x->resolution(), s.rim ? 1 : 0, s.statsIndex, s.scratch.offset,
                       s.x->bumpDepth(), s.x->bumpDepth() / (2 * s.x->texelSize()), group,
                       changes ? s.x->changeLog() : -1});
    of.push_back(&s);
    if (s.rim) rim = s.rim;
  }
  const int n = static_cast<int>(entries.size()), groups = (n + kGroup - 1) / kGroup;
  if (n == 0) return;
  freshBuffer(entries_, entries.size() * sizeof(CommitEntry), entries.data());
  std::vector<GLuint> args(static_cast<size_t>(groups) * 9, 0);
  for (int g = 0; g < groups; ++g)
    for (int stage = 0; stage < 3; ++stage) args[static_cast<size_t>(g) * 9 + 3 * stage + 2] = std::min(kGroup, n - g * kGroup);
  freshBuffer(args_, args.size() * sizeof(GLuint), args.data());
  namespace b = bindings::commit;
  gl::bindStorage(bindings::kRegion, region.id());
  gl::bindStorage(b::kStats, stats.id());
  of.front()->scratch.bind();
  gl::bindStorage(b::kNormalRegion, normalRegion_.id());
  gl::bindStorage(b::kEntries, entries_.id());
  // The regions (grown by their rims) become the groups' dispatch sizes.
  dispatch_.use();
  gl::bindStorage(b::kArgs, args_.id());
  gl::bindStorage(b::kRim, (rim ? rim : &region)->id());  // read only where a side grows
  dCount_.set(n);
  dTile_.set(SurfaceMaps::kBoundTile);
  glDispatchCompute(static_cast<GLuint>((n + 63) / 64), 1, 1);
  glMemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  of.front()->scratch.bind();
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, args_.id());
  // `first`: the program's uFirst (its group's first entry).
  auto eachGroup = [&](const gl::Program& program, const gl::Uniform<int>& first, int stage, const auto& bind) {
    program.use();
    for (int g = 0; g < groups; ++g) {
      for (int k = g * kGroup; k < std::min(n, (g + 1) * kGroup); ++k) bind(k - g * kGroup, *of[static_cast<size_t>(k)]->x);
      first.set(g * kGroup);
      glDispatchComputeIndirect(static_cast<GLintptr>(g * 9 + 3 * stage) * sizeof(GLuint));
    }
  };
  if (!changes && !noChanges_.id()) {
    const GLuint none[2] = {0, 0};  // count, capacity: nothing is written
    noChanges_ = gl::Buffer(sizeof none, none, GL_DYNAMIC_STORAGE_BIT);
  }
  gl::bindStorage(b::kChanges, (changes ? changes : &noChanges_)->id());
  eachGroup(commit_, cFirst_, 0, [](int k, const Surface& x) {
    gl::bindImage(b::kMaps + k, x.height().id(), GL_READ_WRITE, GL_R32F);
  });
  glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  phase("commit");
  nFull_.set(0);
  eachGroup(normals_, nFirst_, 1, [](int k, const Surface& x) {
    gl::bindTexture(b::kHeights + k, x.height().id());
    gl::bindImage(b::kMaps + k, x.normal().id(), GL_WRITE_ONLY, GL_RGBA8);
  });
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  phase("normal map");
  bFull_.set(0);
  bTile_.set(SurfaceMaps::kBoundTile);
  eachGroup(bound_, bFirst_, 2, [](int k, const Surface& x) {
    gl::bindTexture(b::kHeights + k, x.height().id());
    gl::bindImage(b::kMaps + k, x.maps().bound.id(), GL_READ_WRITE, GL_R32F);
  });
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
  glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  // The levels above level 0: one workgroup a map, all its levels (height_bound_up.comp), 8 maps a dispatch.
  boundUp_.use();
  upTile_.set(SurfaceMaps::kBoundTile);
  for (int g = 0; g < groups; ++g) {
    const int count = std::min(kGroup, n - g * kGroup);
    for (int k = 0; k < count; ++k)
      gl::bindImage(b::kMaps + k, of[static_cast<size_t>(g * kGroup + k)]->x->maps().bound.id(), GL_READ_WRITE, GL_R32F);
    upFirst_.set(g * kGroup);
    glDispatchCompute(1, 1, static_cast<GLuint>(count));
  }
  glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  phase("height bound");
  // Each map's levels once (one map may hold two sides: a body against itself, maps shared until made unique).
  std::vector<GLuint> maps;
  for (const Side* side : of) maps.push_back(side->x->height().id());
  std::sort(maps.begin(), maps.end());
  maps.erase(std::unique(maps.begin(), maps.end()), maps.end());
  for (GLuint id : maps) glGenerateTextureMipmap(id);
  phase("height levels");
}

void CommitPass::normals(const SurfaceMaps& maps, int resolution, float slopeScale, glm::ivec2 lo, glm::ivec2 hi) {
  namespace b = bindings::commit;
  normals_.use();
  gl::bindTexture(b::kHeights, maps.height.id());
  gl::bindImage(b::kMaps, maps.normal.id(), GL_WRITE_ONLY, GL_RGBA8);
  nFull_.set(1);
  nFullRegion_.set(glm::ivec4(lo, hi));
  nFullResolution_.set(resolution);
  nFullSlopeScale_.set(slopeScale);
  glDispatchCompute(dispatchGroups(hi.x - lo.x + 1), dispatchGroups(hi.y - lo.y + 1), 1);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  // The bound pyramid over [lo, hi], level by level.
  bound_.use();
  gl::bindTexture(b::kHeights, maps.height.id());
  bFull_.set(1);
  bFullRegion_.set(glm::ivec4(lo, hi));
  bFullResolution_.set(resolution);
  bTile_.set(SurfaceMaps::kBoundTile);
  for (int level = 0; level < maps.boundLevels(); ++level) {
    bLevel_.set(level);
    gl::bindImage(b::kMaps, maps.bound.id(), GL_READ_WRITE, GL_R32F);
    // Level 0 takes a workgroup a bound texel, the levels above 8 x 8 texels.
    const int span = SurfaceMaps::kBoundTile << level;
    const int nx = hi.x / span - lo.x / span + 1, ny = hi.y / span - lo.y / span + 1;
    const int per = level == 0 ? 1 : 8;
    glDispatchCompute(static_cast<GLuint>((nx + per - 1) / per), static_cast<GLuint>((ny + per - 1) / per), 1);
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  }
  glGenerateTextureMipmap(maps.height.id());
}

}  // namespace crumple::deform
