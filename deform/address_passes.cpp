// The address-map passes of figure 11 (RenderPassA/B), into per-side targets.
#include <glm/gtc/type_ptr.hpp>

#include "deform/passes.h"

namespace crumple::deform {

namespace {
render::Program addressProgram() {
  return render::Program({{GL_VERTEX_SHADER, "address.vert", std::string(deformShader("address.vert"))},
                          {GL_FRAGMENT_SHADER, "address.frag", std::string(deformShader("address.frag"))}});
}
}  // namespace

AddressPasses::AddressPasses(int size) : program_(addressProgram()) {
  uMvp_ = program_.uniform("uModelViewProjection");
  uNormalToWorld_ = program_.uniform("uNormalToWorld");
  uSign_ = program_.uniform("uSign");
  uBumpToDepth_ = program_.uniform("uBumpToDepth");
  const float half = 0.5f;
  flat_.upload(GL_RED, GL_FLOAT, &half);
  resize(size);
}

void AddressPasses::resize(int n) {
  size_ = n;
  for (int s = 0; s < 2; ++s) {
    addressX_[s] = render::Texture2D(n, n, GL_RG32F);
    depthX_[s] = render::Texture2D(n, n, GL_R32F);
    normalX_[s] = render::Texture2D(n, n, GL_RGBA16F);
    addressO_[s] = render::Texture2D(n, n, GL_RG32F);
    depthO_[s] = render::Texture2D(n, n, GL_R32F);
    depthBuffer_[s] = render::Texture2D(n, n, GL_DEPTH_COMPONENT32F);
    for (auto* t : {&addressX_[s], &depthX_[s], &normalX_[s], &addressO_[s], &depthO_[s]})
      t->setFilter(GL_NEAREST, GL_NEAREST);
    fboX_[s] = render::Framebuffer();
    fboX_[s].attachColor(addressX_[s], 0);
    fboX_[s].attachColor(depthX_[s], 1);
    fboX_[s].attachColor(normalX_[s], 2);
    fboX_[s].attachDepth(depthBuffer_[s]);
    const GLenum bufsX[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    glNamedFramebufferDrawBuffers(fboX_[s].id(), 3, bufsX);
    fboX_[s].checkComplete();
    fboO_[s] = render::Framebuffer();
    fboO_[s].attachColor(addressO_[s], 0);
    fboO_[s].attachColor(depthO_[s], 1);
    fboO_[s].attachDepth(depthBuffer_[s]);
    const GLenum bufsO[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glNamedFramebufferDrawBuffers(fboO_[s].id(), 2, bufsO);
    fboO_[s].checkComplete();
  }
}

void AddressPasses::draw(const DeformBody& body, const glm::dmat4& vp, const glm::dmat4& model, float sign,
                         float bumpToDepth) {
  const glm::mat4 mvp = glm::mat4(vp * model);
  const glm::mat3 nrm = glm::mat3(glm::transpose(glm::inverse(glm::dmat3(model))));
  glUniformMatrix4fv(uMvp_, 1, GL_FALSE, glm::value_ptr(mvp));
  glUniformMatrix3fv(uNormalToWorld_, 1, GL_FALSE, glm::value_ptr(nrm));
  glUniform1f(uSign_, sign);
  glUniform1f(uBumpToDepth_, bumpToDepth);
  glBindTextureUnit(0, body.surface ? body.surface->height().id() : flat_.id());
  body.mesh->draw();
}

namespace {
const float kNoAddress[4] = {-1, -1, 0, 0};
const float kOne = 1.0f, kZero = 0.0f, kZero4[4] = {0, 0, 0, 0};
void beginPass() {
  glEnable(GL_DEPTH_TEST);
  glDepthMask(GL_TRUE);
  glEnable(GL_CULL_FACE);
  glDisable(GL_BLEND);
}
}  // namespace

void AddressPasses::drawX(int side, const DeformBody& x, const glm::dmat4& vp, const glm::dmat4& model,
                          float bumpToDepth, bool normals) {
  beginPass();
  glViewport(0, 0, size_, size_);
  program_.use();
  fboX_[side].bind();
  glClearNamedFramebufferfv(fboX_[side].id(), GL_COLOR, 0, kNoAddress);
  glClearNamedFramebufferfv(fboX_[side].id(), GL_COLOR, 1, &kOne);
  // The normal attachment only serves the tangent-space correction: without
  // it the pass writes (and clears) 8 bytes a pixel fewer.
  const GLenum bufs[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1,
                          normals ? GLenum(GL_COLOR_ATTACHMENT2) : GLenum(GL_NONE)};
  glNamedFramebufferDrawBuffers(fboX_[side].id(), 3, bufs);
  if (normals) glClearNamedFramebufferfv(fboX_[side].id(), GL_COLOR, 2, kZero4);
  glClearNamedFramebufferfv(fboX_[side].id(), GL_DEPTH, 0, &kOne);
  glDepthFunc(GL_LESS);
  glCullFace(GL_BACK);
  draw(x, vp, model, -1.0f, bumpToDepth);
}

void AddressPasses::drawOther(int side, const DeformBody& other, const glm::dmat4& vp, const glm::dmat4& model,
                              float bumpToDepth, bool alone) {
  beginPass();
  glViewport(0, 0, size_, size_);
  program_.use();
  fboO_[side].bind();
  glClearNamedFramebufferfv(fboO_[side].id(), GL_COLOR, 0, kNoAddress);
  glClearNamedFramebufferfv(fboO_[side].id(), GL_COLOR, 1, &kOne);
  if (alone) glClearNamedFramebufferfv(fboO_[side].id(), GL_DEPTH, 0, &kZero);
  glDepthFunc(GL_GREATER);
  glCullFace(GL_FRONT);
  draw(other, vp, model, 1.0f, bumpToDepth);
  glDepthFunc(GL_LESS);
  glCullFace(GL_BACK);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

}  // namespace crumple::deform
