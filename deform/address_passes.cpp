// The address-map passes of figure 11 (RenderPassA/B), into per-side targets.
#include <algorithm>
#include <climits>

#include <crumple/deform/passes.h>

namespace crumple::deform {

namespace {
gl::Program addressProgram() {
  return gl::Program({{GL_VERTEX_SHADER, "address.vert", std::string(deformShader("address.vert"))},
                          {GL_FRAGMENT_SHADER, "address.frag", std::string(deformShader("address.frag"))}});
}
}  // namespace

AddressPasses::AddressPasses(int size)
    : program_(addressProgram()),
      bin_(computeProgram("address_bin.comp")),
      raster_(computeProgram("address_raster.comp")) {
  const float half = 0.5f;
  flat_.upload(GL_RED, GL_FLOAT, &half);
  resize(size);
}

void AddressPasses::resize(int n) {
  size_ = n;
  for (int s = 0; s < 2; ++s) {
    addressX_[s] = gl::Texture2D(n, n, GL_RG32F);
    depthX_[s] = gl::Texture2D(n, n, GL_R32F);
    normalX_[s] = gl::Texture2D(n, n, GL_RGBA16F);
    depthBuffer_[s] = gl::Texture2D(n, n, GL_DEPTH_COMPONENT32F);
    for (auto* t : {&addressX_[s], &depthX_[s], &normalX_[s]}) t->setFilter(GL_NEAREST, GL_NEAREST);
    fboX_[s] = gl::Framebuffer();
    fboX_[s].attachColor(addressX_[s], 0);
    fboX_[s].attachColor(depthX_[s], 1);
    fboX_[s].attachColor(normalX_[s], 2);
    fboX_[s].attachDepth(depthBuffer_[s]);
    const GLenum bufsX[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    glNamedFramebufferDrawBuffers(fboX_[s].id(), 3, bufsX);
    fboX_[s].checkComplete();
  }
  makeSlots(std::max(2, slots()));
}

size_t AddressPasses::slotBytes(int n) {
  const size_t pixels = static_cast<size_t>(n) * static_cast<size_t>(n);
  return pixels * (8 + 4) + pixels / (kTile * kTile) * (kTileCapacity + 2) * sizeof(GLuint);
}

size_t AddressPasses::tiles() const {
  const size_t side = static_cast<size_t>((size_ + kTile - 1) / kTile);
  return side * side;
}

void AddressPasses::makeSlots(int slots) {
  const int n = size_;
  addressArray_ = gl::TextureArray(n, n, slots, GL_RG32F);
  depthArray_ = gl::TextureArray(n, n, slots, GL_R32F);
  addressO_.clear();
  depthO_.clear();
  for (int s = 0; s < slots; ++s) {
    addressO_.push_back(gl::Texture2D::layerView(addressArray_, s));
    depthO_.push_back(gl::Texture2D::layerView(depthArray_, s));
    addressO_.back().setFilter(GL_NEAREST, GL_NEAREST);
    depthO_.back().setFilter(GL_NEAREST, GL_NEAREST);
  }
  held_.assign(static_cast<size_t>(slots), Held::Unknown);
  const size_t t = tiles(), k = static_cast<size_t>(slots);
  count_ = gl::Buffer(k * countStride() * sizeof(GLuint), nullptr);
  list_ = gl::Buffer(k * t * kTileCapacity * sizeof(GLuint), nullptr);
  active_ = gl::Buffer(k * t * sizeof(GLuint), nullptr);
  reach_ = gl::Buffer(k * 4 * sizeof(GLint), nullptr);
  for (int s = 0; s < 2; ++s) {  // the fragment stage's pass B draws into slots 0 and 1
    fboO_[s] = gl::Framebuffer();
    fboO_[s].attachColor(addressO_[static_cast<size_t>(s)], 0);
    fboO_[s].attachColor(depthO_[static_cast<size_t>(s)], 1);
    fboO_[s].attachDepth(depthBuffer_[s]);
    const GLenum bufsO[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glNamedFramebufferDrawBuffers(fboO_[s].id(), 2, bufsO);
    fboO_[s].checkComplete();
  }
}

void clearBoxes(gl::Buffer& buffer, int boxes) {
  std::vector<GLint> empty(std::max(static_cast<size_t>(boxes), buffer.size() / (4 * sizeof(GLint))) * 4);
  for (size_t k = 0; k < empty.size(); k += 4) {
    empty[k] = empty[k + 1] = INT_MAX;
    empty[k + 2] = empty[k + 3] = -1;
  }
  freshBuffer(buffer, empty.size() * sizeof(GLint), empty.data());
}

void freshBuffer(gl::Buffer& buffer, size_t bytes, const void* data) {
  buffer = gl::Buffer(bytes, data, GL_DYNAMIC_STORAGE_BIT);
}

void AddressPasses::clearReach(int slots) { clearBoxes(reach_, slots); }

void AddressPasses::reserveSlots(int slots) {
  if (slots > this->slots()) makeSlots(std::max(slots, 2 * this->slots()));
}

void AddressPasses::draw(const DeformBody& body, const glm::dmat4& vp, const glm::dmat4& model, float sign,
                         float bumpToDepth) {
  const glm::mat4 mvp = glm::mat4(vp * model);
  const glm::mat3 nrm = glm::mat3(glm::transpose(glm::inverse(glm::dmat3(model))));
  uMvp_.set(mvp);
  uNormalToWorld_.set(nrm);
  uSign_.set(sign);
  uBumpToDepth_.set(bumpToDepth);
  gl::bindTexture(bindings::address::kHeights, body.surface ? body.surface->height().id() : flat_.id());
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
  held_[static_cast<size_t>(side)] = Held::Unknown;
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

namespace {
// address_bin.comp's and address_raster.comp's Entry (std430): one side of the wave.
struct Entry {
  glm::mat4 mvp;
  GLint slot, triangles;
  GLuint setup;  // its first triangle's index into the wave's setups and large triangles
  GLint group;   // its raster dispatch (kGroup sides each)
  float reach, bumpToDepth;
  GLint sampler;  // its height map's texture unit in that dispatch
  GLint mode;     // the clear: 0 nothing, 1 the tiles its last raster listed, 2 every tile
};
static_assert(sizeof(Entry) == 96, "Entry must match the shaders' std430 layout");
}  // namespace

void AddressPasses::rasterOthers(const std::vector<OtherPass>& in, const PhaseMark& phase) {
  if (in.empty()) return;
  // Entries in order of their mesh's first appearance (a bins dispatch a mesh); raster groups of kGroup in a row.
  std::vector<const OtherPass*> order;
  std::vector<const GpuMesh*> meshes;
  for (const OtherPass& p : in)
    if (std::find(meshes.begin(), meshes.end(), p.other->mesh) == meshes.end()) meshes.push_back(p.other->mesh);
  for (const GpuMesh* m : meshes)
    for (const OtherPass& p : in)
      if (p.other->mesh == m) order.push_back(&p);
  const int n = static_cast<int>(order.size()), groups = (n + kGroup - 1) / kGroup;
  std::vector<Entry> entries(static_cast<size_t>(n));
  GLuint setup = 0;
  bool clears = false;
  for (int e = 0; e < n; ++e) {
    const OtherPass& p = *order[static_cast<size_t>(e)];
    const Held h = held_[static_cast<size_t>(p.slot)];
    entries[static_cast<size_t>(e)] = {glm::mat4(p.viewProjection * p.model), p.slot, p.other->mesh->indexCount / 3,
                                       setup, e / kGroup, p.reach, p.bumpToDepth, e % kGroup,
                                       h == Held::None ? 0 : h == Held::Tiles ? 1 : 2};
    clears = clears || h != Held::None;
    setup += static_cast<GLuint>(p.other->mesh->indexCount / 3);
  }
  const size_t setupBytes = std::max<size_t>(setup, 1) * 6 * 4 * sizeof(float);
  if (setup_.size() < setupBytes) {
    setup_ = gl::Buffer(std::max(setupBytes, 2 * setup_.size()), nullptr);
    large_ = gl::Buffer(setup_.size() / (6 * 4), nullptr);  // a uint a triangle
  }
  freshBuffer(entries_, entries.size() * sizeof(Entry), entries.data());
  std::vector<GLuint> args(static_cast<size_t>(groups) * 3);
  for (int g = 0; g < groups; ++g) {
    args[static_cast<size_t>(g) * 3 + 1] = 1;
    args[static_cast<size_t>(g) * 3 + 2] = static_cast<GLuint>(std::min(kGroup, n - g * kGroup));
  }
  freshBuffer(args_, args.size() * sizeof(GLuint), args.data());
  namespace b = bindings::address;
  gl::bindStorage(b::kSetup, setup_.id());
  gl::bindStorage(b::kTileCount, count_.id());
  gl::bindStorage(b::kTileList, list_.id());
  gl::bindStorage(b::kLarge, large_.id());
  gl::bindStorage(b::kActive, active_.id());
  gl::bindStorage(b::kEntries, entries_.id());
  gl::bindStorage(b::kArgs, args_.id());
  gl::bindStorage(b::kReach, reach_.id());
  gl::bindImage(b::kAddress, addressArray_.id(), GL_WRITE_ONLY, GL_RG32F, true);
  gl::bindImage(b::kDepth, depthArray_.id(), GL_WRITE_ONLY, GL_R32F, true);
  raster_.use();
  rSize_.set(size_);
  rCapacity_.set(kTileCapacity);
  if (clears) {  // "none" back where each side's last raster wrote (from its lists, before they are reset)
    rMode_.set(1);
    rFirst_.set(0);
    glDispatchCompute(static_cast<GLuint>(std::min<size_t>(tiles(), 1024)), 1, static_cast<GLuint>(n));
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  }
  // The sides' counts reset, slot runs in a row at once.
  std::vector<int> slots;
  for (const Entry& e : entries) slots.push_back(e.slot);
  std::sort(slots.begin(), slots.end());
  for (size_t a = 0; a < slots.size();) {
    size_t b = a + 1;
    while (b < slots.size() && slots[b] == slots[b - 1] + 1) ++b;
    const size_t stride = countStride() * sizeof(GLuint);
    glClearNamedBufferSubData(count_.id(), GL_R32UI, static_cast<GLintptr>(static_cast<size_t>(slots[a]) * stride),
                              static_cast<GLsizeiptr>((b - a) * stride), GL_RED_INTEGER, GL_UNSIGNED_INT, nullptr);
    a = b;
  }
  bin_.use();
  bSize_.set(size_);
  bCapacity_.set(kTileCapacity);
  constexpr int kRowGroups = 32768;  // address_bin.comp's workgroups a row
  for (int e = 0; e < n;) {
    const GpuMesh& mesh = *order[static_cast<size_t>(e)]->other->mesh;
    int f = e + 1;
    while (f < n && order[static_cast<size_t>(f)]->other->mesh == &mesh) ++f;
    const int triangles = mesh.indexCount / 3;
    if (triangles > 0) {
      gl::bindStorage(b::kVertices, mesh.vertices.id());
      gl::bindStorage(b::kIndices, mesh.indices.id());
      bFirst_.set(e);
      const int groups = (triangles + 63) / 64;  // 64 triangles a workgroup
      glDispatchCompute(static_cast<GLuint>(std::min(groups, kRowGroups)),
                        static_cast<GLuint>((groups + kRowGroups - 1) / kRowGroups), static_cast<GLuint>(f - e));
    }
    e = f;
  }
  phase("address bins");
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_COMMAND_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  raster_.use();
  rMode_.set(0);
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, args_.id());
  for (int g = 0; g < groups; ++g) {
    for (int e = g * kGroup; e < std::min(n, (g + 1) * kGroup); ++e) {
      const DeformBody& other = *order[static_cast<size_t>(e)]->other;
      gl::bindTexture(b::kHeights + (e - g * kGroup), other.surface ? other.surface->height().id() : flat_.id());
    }
    rFirst_.set(g * kGroup);
    glDispatchComputeIndirect(static_cast<GLintptr>(g) * 3 * sizeof(GLuint));
  }
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
  for (const Entry& e : entries) held_[static_cast<size_t>(e.slot)] = Held::Tiles;
}

std::pair<size_t, size_t> AddressPasses::tilesRun(int side) const {
  GLuint tail[6] = {};
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glGetNamedBufferSubData(count_.id(), static_cast<GLintptr>((static_cast<size_t>(side) * countStride() + tiles()) * sizeof(GLuint)),
                          sizeof tail, tail);
  if (!tail[5]) return {tail[1], tiles()};
  // Large triangles: every tile of the reach's rectangle (x0 | y0 << 16, x1 | y1 << 16).
  const int x0 = static_cast<int>(tail[2] & 0xffff), y0 = static_cast<int>(tail[2] >> 16);
  const int x1 = static_cast<int>(tail[3] & 0xffff), y1 = static_cast<int>(tail[3] >> 16);
  return {x1 < x0 || y1 < y0 ? 0 : static_cast<size_t>(x1 - x0 + 1) * static_cast<size_t>(y1 - y0 + 1), tiles()};
}

}  // namespace crumple::deform
