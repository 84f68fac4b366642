// The commit of one side's new heights over its touched region, and the
// normal map regenerated there (also used for whole maps at creation).
#include "deform/passes.h"

namespace crumple::deform {

CommitPass::CommitPass()
    : dispatch_(computeProgram("region_dispatch.comp")),
      commit_(computeProgram("dent_commit.comp")),
      normals_(computeProgram("normal_map.comp")) {
  dSide_ = dispatch_.uniform("uSide");
  dResolution_ = dispatch_.uniform("uResolution");
  dGrow_ = dispatch_.uniform("uGrow");
  cSide_ = commit_.uniform("uSide");
  cStatsIndex_ = commit_.uniform("uStatsIndex");
  cBumpDepth_ = commit_.uniform("uBumpDepth");
  nSide_ = normals_.uniform("uSide");
  nFullRegion_ = normals_.uniform("uFullRegion");
  nResolution_ = normals_.uniform("uResolution");
  nSlopeScale_ = normals_.uniform("uSlopeScale");
}

void CommitPass::run(int side, Surface& x, int grow, render::Texture2D& scratch, const render::Buffer& region,
                     const render::Buffer& stats, int statsIndex, const PhaseMark& phase) {
  const int res = x.resolution();
  // The region becomes indirect dispatch sizes: the commit over it, the normals over it grown by a texel.
  dispatch_.use();
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, region.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, indirect_.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, normalRegion_.id());
  glUniform1i(dSide_, side);
  glUniform1i(dResolution_, res);
  glUniform1i(dGrow_, grow);
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);

  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, indirect_.id());
  commit_.use();
  glBindImageTexture(0, scratch.id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32UI);
  glBindImageTexture(1, x.height().id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32F);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, region.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, stats.id());
  glUniform1i(cSide_, side);
  glUniform1i(cStatsIndex_, statsIndex);
  glUniform1f(cBumpDepth_, x.bumpDepth());
  glDispatchComputeIndirect(static_cast<GLintptr>(side) * 6 * sizeof(GLuint));
  glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  phase("commit");

  normals_.use();
  glBindTextureUnit(0, x.height().id());
  glBindImageTexture(1, x.normal().id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, normalRegion_.id());
  glUniform1i(nSide_, side);
  glUniform4i(nFullRegion_, 0, 0, -1, -1);
  glUniform1i(nResolution_, res);
  glUniform1f(nSlopeScale_, x.bumpDepth() / (2 * x.texelSize()));
  glDispatchComputeIndirect(static_cast<GLintptr>(side) * 6 * sizeof(GLuint) + 3 * sizeof(GLuint));
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
  phase("normal map");
}

void CommitPass::normals(const render::Texture2D& height, const render::Texture2D& normal, int resolution,
                         float slopeScale, glm::ivec2 lo, glm::ivec2 hi) {
  normals_.use();
  glBindTextureUnit(0, height.id());
  glBindImageTexture(1, normal.id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
  glUniform1i(nSide_, -1);
  glUniform4i(nFullRegion_, lo.x, lo.y, hi.x, hi.y);
  glUniform1i(nResolution_, resolution);
  glUniform1f(nSlopeScale_, slopeScale);
  glDispatchCompute(dispatchGroups(hi.x - lo.x + 1), dispatchGroups(hi.y - lo.y + 1), 1);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
}

}  // namespace crumple::deform
