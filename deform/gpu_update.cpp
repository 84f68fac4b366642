// The updates that stay on the GPU: the per-texel gather (the default), the
// paper's scatter as a compute pass, and crater rims.
#include <algorithm>
#include <glm/gtc/type_ptr.hpp>

#include "deform/passes.h"

namespace crumple::deform {

GatherUpdate::GatherUpdate()
    : program_({{GL_VERTEX_SHADER, "texel.vert", std::string(deformShader("texel.vert"))},
                {GL_GEOMETRY_SHADER, "texel.geom", std::string(deformShader("texel.geom"))},
                {GL_FRAGMENT_SHADER, "texel_gather.frag", std::string(deformShader("texel_gather.frag"))}}) {
  uMvp_ = program_.uniform("uModelViewProjection");
  uNormalToWorld_ = program_.uniform("uNormalToWorld");
  uResolution_ = program_.uniform("uResolution");
  uViewMargin_ = program_.uniform("uViewMargin");
  uFarthestOther_ = program_.uniform("uFarthestOther");
  uBumpReach_ = program_.uniform("uBumpReach");
  uSide_ = program_.uniform("uSide");
  uSize_ = program_.uniform("uSize");
  uBumpToDepth_ = program_.uniform("uBumpToDepth");
  uDepthToHeight_ = program_.uniform("uDepthToHeight");
  uTangentMode_ = program_.uniform("uTangentMode");
  uTangentFloor_ = program_.uniform("uTangentFloor");
  uViewNormal_ = program_.uniform("uViewNormal");
}

void GatherUpdate::bindTexelSpace(int res) {
  auto it = texelSpace_.find(res);
  if (it == texelSpace_.end()) {
    it = texelSpace_.emplace(res, render::Framebuffer()).first;
    glNamedFramebufferParameteri(it->second.id(), GL_FRAMEBUFFER_DEFAULT_WIDTH, res);
    glNamedFramebufferParameteri(it->second.id(), GL_FRAMEBUFFER_DEFAULT_HEIGHT, res);
  }
  it->second.bind();
}

void GatherUpdate::run(const SideUpdate& u, const GpuMesh& mesh, const render::Texture2D& height, const glm::dmat4& vp,
                       const glm::dmat4& model, const AddressPasses& passes, float farthestOther,
                       const Scratch& scratch, const render::Buffer& region) {
  program_.use();
  bindTexelSpace(u.resolution);
  glViewport(0, 0, u.resolution, u.resolution);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  const glm::mat4 mvp = glm::mat4(vp * model);
  const glm::mat3 nrm = glm::mat3(glm::transpose(glm::inverse(glm::dmat3(model))));
  glUniformMatrix4fv(uMvp_, 1, GL_FALSE, glm::value_ptr(mvp));
  glUniformMatrix3fv(uNormalToWorld_, 1, GL_FALSE, glm::value_ptr(nrm));
  glBindTextureUnit(2, passes.addressOther(u.side).id());
  glBindTextureUnit(3, passes.depthOther(u.side).id());
  glBindTextureUnit(5, height.id());
  scratch.bind();
  glUniform1ui(program_.uniform("uScratchBase"), scratch.offset);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, region.id());
  glUniform1i(uSide_, u.side);
  glUniform1i(uSize_, passes.size());
  glUniform1i(uResolution_, u.resolution);
  glUniform1f(uViewMargin_, 4.0f / static_cast<float>(passes.size()));
  glUniform1f(uFarthestOther_, farthestOther);
  glUniform1f(uBumpReach_, 0.5f * u.bumpToDepth);
  glUniform1f(uBumpToDepth_, u.bumpToDepth);
  glUniform1f(uDepthToHeight_, u.depthToHeight);
  glUniform1i(uTangentMode_, static_cast<int>(u.tangent));
  glUniform1f(uTangentFloor_, u.tangentFloor);
  glUniform3fv(uViewNormal_, 1, glm::value_ptr(u.viewNormal));
  mesh.draw();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_CULL_FACE);
}

ScatterUpdate::ScatterUpdate() : program_(computeProgram("dent_update.comp")) {
  uSide_ = program_.uniform("uSide");
  uSize_ = program_.uniform("uSize");
  uResolution_ = program_.uniform("uResolution");
  uDepthToHeight_ = program_.uniform("uDepthToHeight");
  uTangentMode_ = program_.uniform("uTangentMode");
  uTangentFloor_ = program_.uniform("uTangentFloor");
  uViewNormal_ = program_.uniform("uViewNormal");
}

void ScatterUpdate::run(const SideUpdate& u, const AddressPasses& passes, const render::Texture2D& height,
                        const Scratch& scratch, const render::Buffer& region) {
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  program_.use();
  glBindTextureUnit(0, passes.addressX(u.side).id());
  glBindTextureUnit(1, passes.depthX(u.side).id());
  glBindTextureUnit(2, passes.addressOther(u.side).id());
  glBindTextureUnit(3, passes.depthOther(u.side).id());
  glBindTextureUnit(4, passes.normalX(u.side).id());
  glBindTextureUnit(5, height.id());
  scratch.bind();
  glUniform1ui(program_.uniform("uScratchBase"), scratch.offset);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, region.id());
  glUniform1i(uSide_, u.side);
  glUniform2i(uSize_, passes.size(), passes.size());
  glUniform1i(uResolution_, u.resolution);
  glUniform1f(uDepthToHeight_, u.depthToHeight);
  glUniform1i(uTangentMode_, static_cast<int>(u.tangent));
  glUniform1f(uTangentFloor_, u.tangentFloor);
  glUniform3fv(uViewNormal_, 1, glm::value_ptr(u.viewNormal));
  glDispatchCompute(dispatchGroups(passes.size()), dispatchGroups(passes.size()), 1);
}

CraterRims::CraterRims()
    : program_(computeProgram("crater_rim.comp")), dispatch_(computeProgram("rim_dispatch.comp")) {
  uSide_ = program_.uniform("uSide");
  uResolution_ = program_.uniform("uResolution");
  uMode_ = program_.uniform("uMode");
  dSide_ = dispatch_.uniform("uSide");
  dResolution_ = dispatch_.uniform("uResolution");
}

void CraterRims::run(int side, int res, const render::Texture2D& height, const Scratch& scratch,
                     const render::Buffer& region) {
  // The ring width depends on the dent's size: found on the GPU from the region, with the dispatch sizes.
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  const GLuint zero[2] = {0, 0};
  sums_.upload(static_cast<size_t>(side) * 2 * sizeof(GLuint), sizeof zero, zero);
  dispatch_.use();
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, region.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, rim_.id());
  glUniform1i(dSide_, side);
  glUniform1i(dResolution_, res);
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  program_.use();
  scratch.bind();
  glUniform1ui(program_.uniform("uScratchBase"), scratch.offset);
  glBindTextureUnit(1, height.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, sums_.id());
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, rim_.id());
  glUniform1i(uSide_, side);
  glUniform1i(uResolution_, res);
  for (int mode = 0; mode < 3; ++mode) {
    glUniform1i(uMode_, mode);
    glDispatchComputeIndirect(static_cast<GLintptr>(side) * 3 * sizeof(GLuint));
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  }
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
}

}  // namespace crumple::deform
