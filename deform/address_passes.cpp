// The address-map passes of figure 11 (RenderPassA/B), into per-side targets.
#include <algorithm>
#include <glm/gtc/type_ptr.hpp>

#include "deform/passes.h"

namespace crumple::deform {

namespace {
render::Program addressProgram() {
  return render::Program({{GL_VERTEX_SHADER, "address.vert", std::string(deformShader("address.vert"))},
                          {GL_FRAGMENT_SHADER, "address.frag", std::string(deformShader("address.frag"))}});
}
}  // namespace

AddressPasses::AddressPasses(int size)
    : program_(addressProgram()),
      bin_(computeProgram("address_bin.comp")),
      raster_(computeProgram("address_raster.comp")) {
  bMvp_ = bin_.uniform("uModelViewProjection");
  bSize_ = bin_.uniform("uSize");
  bTriangles_ = bin_.uniform("uTriangles");
  bCapacity_ = bin_.uniform("uCapacity");
  bReach_ = bin_.uniform("uReach");
  rSize_ = raster_.uniform("uSize");
  rTriangles_ = raster_.uniform("uTriangles");
  rCapacity_ = raster_.uniform("uCapacity");
  rBumpToDepth_ = raster_.uniform("uBumpToDepth");
  rMode_ = raster_.uniform("uMode");
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
  const int slots = std::max(2, static_cast<int>(addressO_.size()));
  addressO_.clear();
  depthO_.clear();
  bins_.clear();
  for (int s = 0; s < slots; ++s) makeSlot();
  for (int s = 0; s < 2; ++s) {
    addressX_[s] = render::Texture2D(n, n, GL_RG32F);
    depthX_[s] = render::Texture2D(n, n, GL_R32F);
    normalX_[s] = render::Texture2D(n, n, GL_RGBA16F);
    depthBuffer_[s] = render::Texture2D(n, n, GL_DEPTH_COMPONENT32F);
    for (auto* t : {&addressX_[s], &depthX_[s], &normalX_[s]}) t->setFilter(GL_NEAREST, GL_NEAREST);
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

size_t AddressPasses::slotBytes(int n) {
  const size_t pixels = static_cast<size_t>(n) * static_cast<size_t>(n);
  return pixels * (8 + 4) + pixels / (kTile * kTile) * (kTileCapacity + 2) * sizeof(GLuint);
}

void AddressPasses::makeSlot() {
  const int n = size_;
  addressO_.emplace_back(n, n, GL_RG32F);
  depthO_.emplace_back(n, n, GL_R32F);
  addressO_.back().setFilter(GL_NEAREST, GL_NEAREST);
  depthO_.back().setFilter(GL_NEAREST, GL_NEAREST);
  const size_t tiles = static_cast<size_t>((n + kTile - 1) / kTile) * static_cast<size_t>((n + kTile - 1) / kTile);
  Bins b;
  b.tiles = tiles;
  b.count = render::Buffer((tiles + 6) * sizeof(GLuint), nullptr);  // Bins: what it holds
  b.list = render::Buffer(tiles * kTileCapacity * sizeof(GLuint), nullptr);
  b.active = render::Buffer(tiles * sizeof(GLuint), nullptr);
  bins_.push_back(std::move(b));
}

void AddressPasses::reserveSlots(int slots) {
  while (static_cast<int>(addressO_.size()) < slots) makeSlot();
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
  bins_[side].held = Held::Unknown;
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

void AddressPasses::binOther(int side, const DeformBody& other, const glm::dmat4& vp, const glm::dmat4& model,
                             float reach) {
  const GpuMesh& mesh = *other.mesh;
  const int triangles = mesh.indexCount / 3;
  Bins& b = bins_[side];
  const size_t setupBytes = static_cast<size_t>(std::max(triangles, 1)) * 6 * 4 * sizeof(float);
  if (b.setup.size() < setupBytes) {
    b.setup = render::Buffer(std::max(setupBytes, 2 * b.setup.size()), nullptr);
    b.large = render::Buffer(b.setup.size() / (6 * 4), nullptr);  // a uint a triangle
  }
  b.triangles = triangles;
  if (b.held == Held::Tiles) b.held = Held::Unknown;  // the reset below loses which tiles the raster wrote
  glClearNamedBufferData(b.count.id(), GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, nullptr);
  if (triangles == 0) return;
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, mesh.vertices.id());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, mesh.indices.id());
  b.bind();
  bin_.use();
  const glm::mat4 mvp = glm::mat4(vp * model);
  glUniformMatrix4fv(bMvp_, 1, GL_FALSE, glm::value_ptr(mvp));
  glUniform1i(bSize_, size_);
  glUniform1i(bTriangles_, triangles);
  glUniform1i(bCapacity_, kTileCapacity);
  glUniform1f(bReach_, reach);
  constexpr int kRowGroups = 32768;  // address_bin.comp's workgroups a row
  glDispatchCompute(static_cast<GLuint>(std::min(triangles, kRowGroups)),
                    static_cast<GLuint>((triangles + kRowGroups - 1) / kRowGroups), 1);
}

void AddressPasses::clearOther(int side) {
  Bins& b = bins_[side];
  if (b.held == Held::None) return;
  b.bind();
  raster_.use();
  glUniform1i(rSize_, size_);
  glUniform1i(rMode_, b.held == Held::Tiles ? 1 : 2);
  glBindImageTexture(0, addressO_[side].id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RG32F);
  glBindImageTexture(1, depthO_[side].id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_R32F);
  if (b.held == Held::Tiles) {  // the tiles the last raster wrote, as its lists still give them
    glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, b.count.id());
    glDispatchComputeIndirect(static_cast<GLintptr>((b.tiles + 2) * sizeof(GLuint)));
    glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
  } else {
    glDispatchCompute(static_cast<GLuint>(std::min<size_t>(b.tiles, 65535)), 1, 1);
  }
  b.held = Held::None;
}

void AddressPasses::rasterOther(int side, const DeformBody& other, float bumpToDepth) {
  Bins& b = bins_[side];
  if (b.held != Held::None) {  // a caller that did not clear first (clearOther, then a barrier)
    clearOther(side);
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  }
  b.bind();
  raster_.use();
  glUniform1i(rSize_, size_);
  glUniform1i(rTriangles_, b.triangles);
  glUniform1i(rCapacity_, kTileCapacity);
  glUniform1f(rBumpToDepth_, bumpToDepth);
  glUniform1i(rMode_, 0);
  glBindTextureUnit(0, other.surface ? other.surface->height().id() : flat_.id());
  // The pixels of tiles with nothing to test keep "none" (what a tile with no triangle over a pixel writes
  // there): clearOther put it back on the tiles written before; the raster runs over the active tiles only.
  glBindImageTexture(0, addressO_[side].id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RG32F);
  glBindImageTexture(1, depthO_[side].id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_R32F);
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, b.count.id());
  glDispatchComputeIndirect(static_cast<GLintptr>((b.tiles + 2) * sizeof(GLuint)));
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
  b.held = Held::Tiles;
}

std::pair<size_t, size_t> AddressPasses::tilesRun(int side) const {
  const Bins& b = bins_[static_cast<size_t>(side)];
  GLuint tail[6] = {};
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glGetNamedBufferSubData(b.count.id(), static_cast<GLintptr>(b.tiles * sizeof(GLuint)), sizeof tail, tail);
  return {tail[5] ? b.tiles : tail[1], b.tiles};
}

}  // namespace crumple::deform
