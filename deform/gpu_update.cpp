// The updates that stay on the GPU: the per-texel gather (the default), the
// paper's scatter as a compute pass, and crater rims.
#include <algorithm>

#include <crumple/deform/passes.h>

namespace crumple::deform {

GatherUpdate::GatherUpdate()
    : program_({{GL_VERTEX_SHADER, "texel.vert", std::string(deformShader("texel.vert"))},
                {GL_GEOMETRY_SHADER, "texel.geom", std::string(deformShader("texel.geom"))},
                {GL_FRAGMENT_SHADER, "texel_gather.frag", deformSource("texel_gather.frag")}}) {}

void GatherUpdate::bindTexelSpace(int res) {
  auto it = texelSpace_.find(res);
  if (it == texelSpace_.end()) {
    it = texelSpace_.emplace(res, gl::Framebuffer()).first;
    glNamedFramebufferParameteri(it->second.id(), GL_FRAMEBUFFER_DEFAULT_WIDTH, res);
    glNamedFramebufferParameteri(it->second.id(), GL_FRAMEBUFFER_DEFAULT_HEIGHT, res);
  }
  it->second.bind();
}

void GatherUpdate::run(const SideUpdate& u, const GpuMesh& mesh, const gl::Texture2D& height, const glm::dmat4& vp,
                       const glm::dmat4& model, const AddressPasses& passes, float farthestOther,
                       const Scratch& scratch, const gl::Buffer& region) {
  program_.use();
  bindTexelSpace(u.resolution);
  glViewport(0, 0, u.resolution, u.resolution);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  const glm::mat4 mvp = glm::mat4(vp * model);
  const glm::mat3 nrm = glm::mat3(glm::transpose(glm::inverse(glm::dmat3(model))));
  uMvp_.set(mvp);
  uNormalToWorld_.set(nrm);
  gl::bindTexture(bindings::update::kAddressOther, passes.addressOther(u.side).id());
  gl::bindTexture(bindings::update::kDepthOther, passes.depthOther(u.side).id());
  gl::bindTexture(bindings::update::kHeightX, height.id());
  scratch.bind();
  uScratchBase_.set(scratch.offset);
  gl::bindStorage(bindings::kRegion, region.id());
  uSide_.set(u.side);
  uSize_.set(passes.size());
  uResolution_.set(u.resolution);
  uViewMargin_.set(4.0f / static_cast<float>(passes.size()));
  uFarthestOther_.set(farthestOther);
  uBumpReach_.set(u.bumpReach);
  uBumpToDepth_.set(u.bumpToDepth);
  uDepthToHeight_.set(u.depthToHeight);
  uTangentMode_.set(static_cast<int>(u.tangent));
  uTangentFloor_.set(u.tangentFloor);
  uPushDepth_.set(u.pushDepth);
  uViewNormal_.set(u.viewNormal);
  mesh.draw();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_CULL_FACE);
}

namespace {
// texel_gather.comp's Entry (std430).
struct GatherEntry {
  glm::mat4 mvp;
  glm::vec4 normalToWorld[3];
  glm::vec4 viewNormal;  // w: the view's half-size in clip units
  GLint slot, resolution, sampler, tangentMode;
  GLuint scratchBase;
  float farthestOther, bumpToDepth, depthToHeight;
  float tangentFloor, bumpReach, pushDepth, pad;
};
static_assert(sizeof(GatherEntry) == 176, "GatherEntry must match texel_gather.comp's std430 layout");
}  // namespace

ComputeGather::ComputeGather() : program_(computeProgram("texel_gather.comp")) {}

void ComputeGather::cull(const std::vector<Side>& in, int addressMap, const gl::Buffer& reach) {
  order_.clear();
  dispatches_.clear();
  keptAt_.clear();
  tilesRun_ = 0;
  if (in.empty()) return;
  // Sides grouped by mesh and resolution (a tile list each), in order of first appearance; dispatches of kGroup.
  std::vector<std::pair<const GpuMesh*, int>> kinds;
  for (const Side& s : in)
    if (std::find(kinds.begin(), kinds.end(), std::make_pair(s.mesh, s.u->resolution)) == kinds.end())
      kinds.emplace_back(s.mesh, s.u->resolution);
  for (const auto& k : kinds)
    for (const Side& s : in)
      if (s.mesh == k.first && s.u->resolution == k.second) order_.push_back(&s);
  const float lim = 1.0f + 4.0f / static_cast<float>(addressMap);  // texel.geom's view, a few pixels grown
  std::vector<GatherEntry> entries(order_.size());
  for (size_t e = 0; e < order_.size(); ++e) {
    const Side& s = *order_[e];
    const SideUpdate& u = *s.u;
    GatherEntry& g = entries[e];
    g.mvp = glm::mat4(s.viewProjection * s.model);
    const glm::mat3 nrm = glm::mat3(glm::transpose(glm::inverse(glm::dmat3(s.model))));
    for (int c = 0; c < 3; ++c) g.normalToWorld[c] = glm::vec4(nrm[c], 0);
    g.viewNormal = glm::vec4(u.viewNormal, lim);
    g.slot = u.side;
    g.resolution = u.resolution;
    g.sampler = 0;  // set per dispatch below
    g.tangentMode = static_cast<GLint>(u.tangent);
    g.scratchBase = s.scratch.offset;
    g.farthestOther = s.farthestOther;
    g.bumpToDepth = u.bumpToDepth;
    g.depthToHeight = u.depthToHeight;
    g.tangentFloor = u.tangentFloor;
    g.bumpReach = u.bumpReach;
    g.pushDepth = u.pushDepth;
    g.pad = 0;
  }
  for (size_t e = 0; e < order_.size();) {  // runs of one kind, kGroup sides at most
    const GpuMesh* mesh = order_[e]->mesh;
    const int res = order_[e]->u->resolution;
    size_t f = e + 1;
    while (f < order_.size() && f - e < kGroup && order_[f]->mesh == mesh && order_[f]->u->resolution == res) ++f;
    dispatches_.push_back({e, f - e, TexelCover::of(*mesh, res), mesh});
    for (size_t k = e; k < f; ++k) entries[k].sampler = static_cast<GLint>(k - e);
    e = f;
  }
  freshBuffer(entries_, entries.size() * sizeof(GatherEntry), entries.data());
  // Each dispatch's kept tiles: up to sides x tiles items, 256-byte aligned; its head (count, indirect x y z) at
  // 256 bytes a dispatch in keptHead_.
  size_t keptBytes = 0;
  for (const Dispatch& d : dispatches_) {
    keptAt_.push_back(keptBytes);
    const size_t tiles = d.cover->tiles();
    keptBytes += (d.count * tiles * sizeof(GLuint) + 255) / 256 * 256;
    tilesRun_ += d.count * tiles;
  }
  if (kept_.size() < keptBytes) kept_ = gl::Buffer(std::max(keptBytes, 2 * kept_.size()), nullptr);
  std::vector<GLuint> heads(dispatches_.size() * kHeadUints, 0);
  for (size_t k = 0; k < dispatches_.size(); ++k) heads[k * kHeadUints + 2] = heads[k * kHeadUints + 3] = 1;
  freshBuffer(keptHead_, heads.size() * sizeof(GLuint), heads.data());
  program_.use();
  uSize_.set(addressMap);
  uMode_.set(0);
  gl::bindStorage(bindings::gather::kEntries, entries_.id());
  gl::bindStorage(bindings::gather::kReach, reach.id());
  for (size_t k = 0; k < dispatches_.size(); ++k) {
    bind(k);
    const Dispatch& d = dispatches_[k];
    const size_t tiles = d.cover->tiles();
    glDispatchCompute(static_cast<GLuint>((tiles + 255) / 256), 1, static_cast<GLuint>(d.count));
  }
}

void ComputeGather::bind(size_t k) const {
  const Dispatch& d = dispatches_[k];
  namespace b = bindings::gather;
  gl::bindStorage(b::kVertices, d.mesh->vertices.id());
  gl::bindStorage(b::kIndices, d.mesh->indices.id());
  gl::bindStorage(b::kTileStart, d.cover->start.id());
  gl::bindStorage(b::kTileTriangles, d.cover->triangles.id());
  gl::bindStorage(b::kTileBoxes, d.cover->boxes.id());
  const size_t tiles = d.cover->tiles();
  gl::bindStorage(b::kKept, kept_.id(), static_cast<GLintptr>(keptAt_[k]),
                  static_cast<GLsizeiptr>(std::max<size_t>(d.count * tiles, 1) * sizeof(GLuint)));
  gl::bindStorage(b::kKeptHead, keptHead_.id(), static_cast<GLintptr>(k * kHeadUints * sizeof(GLuint)),
                  static_cast<GLsizeiptr>(4 * sizeof(GLuint)));
  uFirst_.set(static_cast<GLint>(d.first));
}

void ComputeGather::gather(const AddressPasses& passes, const gl::Buffer& region) {
  if (dispatches_.empty()) return;
  program_.use();
  namespace b = bindings::gather;
  uSize_.set(passes.size());
  uMode_.set(1);
  gl::bindStorage(bindings::kRegion, region.id());
  order_.front()->scratch.bind();
  gl::bindStorage(b::kEntries, entries_.id());
  gl::bindTexture(b::kAddressOthers, passes.addressOthers().id());
  gl::bindTexture(b::kDepthOthers, passes.depthOthers().id());
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, keptHead_.id());
  for (size_t k = 0; k < dispatches_.size(); ++k) {
    bind(k);
    const Dispatch& d = dispatches_[k];
    for (size_t j = 0; j < d.count; ++j)
      gl::bindTexture(b::kHeights + j, order_[d.first + j]->height->id());
    // The array's other units hold nothing (not a texture of an earlier program's, of another type).
    gl::unbindTextures(b::kHeights + d.count, static_cast<GLsizei>(kGroup - d.count));
    glDispatchComputeIndirect(static_cast<GLintptr>((k * kHeadUints + 1) * sizeof(GLuint)));
  }
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
}

std::pair<size_t, size_t> ComputeGather::lastKept() const {
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  size_t kept = 0;
  for (size_t k = 0; k < keptAt_.size(); ++k) {
    GLuint count = 0;
    glGetNamedBufferSubData(keptHead_.id(), static_cast<GLintptr>(k * kHeadUints * sizeof(GLuint)), sizeof count, &count);
    kept += count;
  }
  return {kept, tilesRun_};
}

ScatterUpdate::ScatterUpdate() : program_(computeProgram("dent_update.comp")) {}

void ScatterUpdate::run(const SideUpdate& u, const AddressPasses& passes, const gl::Texture2D& height,
                        const Scratch& scratch, const gl::Buffer& region) {
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  program_.use();
  namespace b = bindings::update;
  gl::bindTexture(b::kAddressX, passes.addressX(u.side).id());
  gl::bindTexture(b::kDepthX, passes.depthX(u.side).id());
  gl::bindTexture(b::kAddressOther, passes.addressOther(u.side).id());
  gl::bindTexture(b::kDepthOther, passes.depthOther(u.side).id());
  gl::bindTexture(b::kNormalX, passes.normalX(u.side).id());
  gl::bindTexture(b::kHeightX, height.id());
  scratch.bind();
  uScratchBase_.set(scratch.offset);
  gl::bindStorage(bindings::kRegion, region.id());
  uSide_.set(u.side);
  uSize_.set(glm::ivec2(passes.size(), passes.size()));
  uResolution_.set(u.resolution);
  uDepthToHeight_.set(u.depthToHeight);
  uTangentMode_.set(static_cast<int>(u.tangent));
  uTangentFloor_.set(u.tangentFloor);
  uPushDepth_.set(u.pushDepth);
  uViewNormal_.set(u.viewNormal);
  glDispatchCompute(dispatchGroups(passes.size()), dispatchGroups(passes.size()), 1);
}

CraterRims::CraterRims()
    : program_(computeProgram("crater_rim.comp")), dispatch_(computeProgram("rim_dispatch.comp")) {}

void CraterRims::run(int side, int res, const gl::Texture2D& height, const Scratch& scratch,
                     const gl::Buffer& region) {
  // The ring width depends on the dent's size: found on the GPU from the region, with the dispatch sizes.
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  const GLuint zero[4] = {0, 0, 0, 0};
  freshBuffer(sums_, sizeof zero, zero);
  dispatch_.use();
  gl::bindStorage(bindings::kRegion, region.id());
  gl::bindStorage(bindings::rim::kRim, rim_.id());
  dSide_.set(side);
  dResolution_.set(res);
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  program_.use();
  scratch.bind();
  uScratchBase_.set(scratch.offset);
  gl::bindTexture(bindings::rim::kHeight, height.id());
  gl::bindStorage(bindings::rim::kSums, sums_.id());
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, rim_.id());
  uSide_.set(side);
  uResolution_.set(res);
  for (int mode = 0; mode < 3; ++mode) {
    uMode_.set(mode);
    glDispatchComputeIndirect(static_cast<GLintptr>(side) * 3 * sizeof(GLuint));
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  }
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
}

}  // namespace crumple::deform
