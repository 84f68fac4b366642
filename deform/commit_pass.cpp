// The commit of one side's new heights over its touched region, and the
// normal map regenerated there (also used for whole maps at creation).
#include <algorithm>

#include "deform/passes.h"

namespace crumple::deform {

CommitPass::CommitPass()
    : dispatch_(computeProgram("region_dispatch.comp")),
      commit_(computeProgram("dent_commit.comp")),
      normals_(computeProgram("normal_map.comp")),
      bound_(computeProgram("height_bound.comp")),
      boundUp_(computeProgram("height_bound_up.comp")) {
  dSide_ = dispatch_.uniform("uSide");
  dResolution_ = dispatch_.uniform("uResolution");
  dGrow_ = dispatch_.uniform("uGrow");
  dTile_ = dispatch_.uniform("uTile");
  cSide_ = commit_.uniform("uSide");
  cStatsIndex_ = commit_.uniform("uStatsIndex");
  cBumpDepth_ = commit_.uniform("uBumpDepth");
  cScratchBase_ = commit_.uniform("uScratchBase");
  cResolution_ = commit_.uniform("uResolution");
  nSide_ = normals_.uniform("uSide");
  nFullRegion_ = normals_.uniform("uFullRegion");
  nResolution_ = normals_.uniform("uResolution");
  nSlopeScale_ = normals_.uniform("uSlopeScale");
}

void CommitPass::reserve(size_t sides) {
  if (sides <= sides_) return;
  sides_ = std::max<size_t>(sides, 2);
  indirect_ = render::Buffer(sides_ * kIndirect * sizeof(GLuint), nullptr, GL_DYNAMIC_STORAGE_BIT);
  normalRegion_ = render::Buffer(sides_ * 4 * sizeof(GLint), nullptr, GL_DYNAMIC_STORAGE_BIT);
}

void CommitPass::run(const std::vector<Side>& sides, const render::Buffer& region, const render::Buffer& stats,
                     const PhaseMark& phase) {
  reserve(sides.size());
  // Each region becomes indirect dispatch sizes: the commit over it, the normals over it grown by a texel.
  dispatch_.use();
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, region.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, indirect_.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, normalRegion_.id());
  const int n = static_cast<int>(sides.size());
  for (int side = 0; side < n; ++side) {
    const Side& s = sides[static_cast<size_t>(side)];
    if (!s.x) continue;
    if (s.rim) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, s.rim->id());
    glUniform1i(dSide_, side);
    glUniform1i(dResolution_, s.x->resolution());
    glUniform1i(dGrow_, s.rim ? 1 : 0);
    glUniform1i(dTile_, SurfaceMaps::kBoundTile);
    glDispatchCompute(1, 1, 1);
  }
  glMemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);

  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, indirect_.id());
  commit_.use();
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, region.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, stats.id());
  for (int side = 0; side < n; ++side) {
    const Side& s = sides[static_cast<size_t>(side)];
    if (!s.x) continue;
    s.scratch.bind();
    glUniform1ui(cScratchBase_, s.scratch.offset);
    glUniform1i(cResolution_, s.x->resolution());
    glBindImageTexture(1, s.x->height().id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32F);
    glUniform1i(cSide_, side);
    glUniform1i(cStatsIndex_, s.statsIndex);
    glUniform1f(cBumpDepth_, s.x->bumpDepth());
    glDispatchComputeIndirect(static_cast<GLintptr>(side) * kIndirect * sizeof(GLuint));
  }
  glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  phase("commit");

  normals_.use();
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, normalRegion_.id());
  for (int side = 0; side < n; ++side) {
    const Side& s = sides[static_cast<size_t>(side)];
    if (!s.x) continue;
    glBindTextureUnit(0, s.x->height().id());
    glBindImageTexture(1, s.x->normal().id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
    glUniform1i(nSide_, side);
    glUniform4i(nFullRegion_, 0, 0, -1, -1);
    glUniform1i(nResolution_, s.x->resolution());
    glUniform1f(nSlopeScale_, s.x->bumpDepth() / (2 * s.x->texelSize()));
    glDispatchComputeIndirect(static_cast<GLintptr>(side * kIndirect + 3) * sizeof(GLuint));
  }
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
  phase("normal map");
  std::vector<const SurfaceMaps*> maps(sides.size(), nullptr);
  for (size_t k = 0; k < sides.size(); ++k)
    if (sides[k].x) maps[k] = &sides[k].x->maps();
  bounds(maps, 0, {0, 0}, {0, 0});
  phase("height bound");
}

void CommitPass::bounds(const std::vector<const SurfaceMaps*>& maps, int side, glm::ivec2 lo, glm::ivec2 hi) {
  // side >= 0: maps[k] is side k's, over its region on the GPU; side < 0: maps[0] alone over [lo, hi].
  reserve(2);
  bound_.use();
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, normalRegion_.id());
  glUniform1i(bound_.uniform("uTile"), SurfaceMaps::kBoundTile);
  if (side < 0) glUniform4i(bound_.uniform("uFullRegion"), lo.x, lo.y, hi.x, hi.y);
  int levels = 0;
  for (const SurfaceMaps* m : maps)
    if (m) levels = std::max(levels, m->boundLevels());
  // Over a region on the GPU, only level 0 level by level (its tiles read 16 x 16 height texels each: many
  // workgroups); the levels above in one workgroup a map.
  const int parallelLevels = side < 0 ? levels : std::min(levels, 1);
  for (int level = 0; level < parallelLevels; ++level) {
    glUniform1i(bound_.uniform("uLevel"), level);
    for (int k = 0; k < static_cast<int>(maps.size()); ++k) {
      const SurfaceMaps* m = maps[static_cast<size_t>(k)];
      if (!m || level >= m->boundLevels()) continue;
      const int resolution = m->height.width();
      glBindTextureUnit(0, m->height.id());
      glUniform1i(bound_.uniform("uSide"), side < 0 ? -1 : k);
      glUniform1i(bound_.uniform("uResolution"), resolution);
      glBindImageTexture(1, m->bound.id(), level, GL_FALSE, 0, GL_WRITE_ONLY, GL_R32F);
      glBindImageTexture(2, m->bound.id(), std::max(level - 1, 0), GL_FALSE, 0, GL_READ_ONLY, GL_R32F);
      // A region known here is dispatched over its tiles; the commit's (on the GPU, level 0 only) indirectly, as
      // region_dispatch.comp sized it. Level 0 takes a workgroup a bound texel, the levels above 8 x 8 texels.
      if (side >= 0) {
        glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, indirect_.id());
        glDispatchComputeIndirect(static_cast<GLintptr>(k * kIndirect + 6) * sizeof(GLuint));
        glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
        continue;
      }
      const int span = SurfaceMaps::kBoundTile << level;
      const int nx = hi.x / span - lo.x / span + 1, ny = hi.y / span - lo.y / span + 1;
      const int per = level == 0 ? 1 : 8;
      glDispatchCompute(static_cast<GLuint>((nx + per - 1) / per), static_cast<GLuint>((ny + per - 1) / per), 1);
    }
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  }
  if (side < 0) return;
  boundUp_.use();
  glUniform1i(boundUp_.uniform("uTile"), SurfaceMaps::kBoundTile);
  constexpr int kChunk = 7;  // levels a dispatch: uLevels[8] holds the one below and these
  for (int first = 0; first + 1 < levels; first += kChunk) {
    glUniform1i(boundUp_.uniform("uFirst"), first);
    for (int k = 0; k < static_cast<int>(maps.size()); ++k) {
      const SurfaceMaps* m = maps[static_cast<size_t>(k)];
      if (!m || first + 1 >= m->boundLevels()) continue;
      const int count = std::min(kChunk, m->boundLevels() - 1 - first);
      for (int i = 0; i <= count; ++i)
        glBindImageTexture(static_cast<GLuint>(i), m->bound.id(), first + i, GL_FALSE, 0, GL_READ_WRITE, GL_R32F);
      glUniform1i(boundUp_.uniform("uSide"), k);
      glUniform1i(boundUp_.uniform("uCount"), count);
      glUniform1i(boundUp_.uniform("uResolution"), m->height.width());
      glDispatchCompute(1, 1, 1);
    }
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  }
}

void CommitPass::normals(const SurfaceMaps& maps, int resolution, float slopeScale, glm::ivec2 lo, glm::ivec2 hi) {
  normals_.use();
  glBindTextureUnit(0, maps.height.id());
  glBindImageTexture(1, maps.normal.id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
  glUniform1i(nSide_, -1);
  glUniform4i(nFullRegion_, lo.x, lo.y, hi.x, hi.y);
  glUniform1i(nResolution_, resolution);
  glUniform1f(nSlopeScale_, slopeScale);
  glDispatchCompute(dispatchGroups(hi.x - lo.x + 1), dispatchGroups(hi.y - lo.y + 1), 1);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  bounds({&maps}, -1, lo, hi);
}

}  // namespace crumple::deform
