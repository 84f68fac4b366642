#include "deform/deformer.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <chrono>
#include <map>

namespace crumple::deform {

namespace shaders {
std::string_view shaderSource(std::string_view name);
}
std::string_view deformShader(std::string_view fileName) { return shaders::shaderSource(fileName); }

const char* pathName(Path p) {
  switch (p) {
    case Path::Gather: return "gather";
    case Path::Scatter: return "scatter";
    case Path::Readback: return "readback";
  }
  return "?";
}

namespace {
render::Program compute(const char* name) {
  return render::Program({{GL_COMPUTE_SHADER, name, std::string(deformShader(name))}});
}
GLuint groups(int n) { return static_cast<GLuint>((n + 15) / 16); }
}  // namespace

void worldBounds(const GpuMesh& mesh, const glm::dmat4& model, glm::dvec3 out[2]) {
  out[0] = glm::dvec3(1e300);
  out[1] = glm::dvec3(-1e300);
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 p(c & 1 ? mesh.boundsMax.x : mesh.boundsMin.x, c & 2 ? mesh.boundsMax.y : mesh.boundsMin.y,
                       c & 4 ? mesh.boundsMax.z : mesh.boundsMin.z);
    const glm::dvec3 w = glm::dvec3(model * glm::dvec4(p, 1));
    out[0] = glm::min(out[0], w);
    out[1] = glm::max(out[1], w);
  }
}

AddressCamera addressCamera(const glm::dvec3& point, const glm::dvec3& n, const glm::dvec3 bx[2], const glm::dvec3 bo[2]) {
  // Up: the world x or y axis, whichever is less aligned with the normal (figure 11, lines 6-8).
  const glm::dvec3 up = std::abs(n.y) < std::abs(n.x) ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
  glm::dvec3 corners[16];
  for (int c = 0; c < 8; ++c) {
    corners[c] = glm::dvec3(c & 1 ? bx[1].x : bx[0].x, c & 2 ? bx[1].y : bx[0].y, c & 4 ? bx[1].z : bx[0].z);
    corners[8 + c] = glm::dvec3(c & 1 ? bo[1].x : bo[0].x, c & 2 ? bo[1].y : bo[0].y, c & 4 ? bo[1].z : bo[0].z);
  }
  double reach = 0, size = 0;
  for (const auto& c : corners) reach = std::max(reach, glm::dot(c - point, n));
  size = std::max(glm::length(bx[1] - bx[0]), glm::length(bo[1] - bo[0]));
  const double margin = 0.01 + 0.01 * size;
  const double sCam = reach + margin;  // the view volume holds both bounding boxes
  const glm::dvec3 eye = point + n * sCam;
  AddressCamera cam;
  cam.view = glm::lookAt(eye, eye - n, up);
  double nearD = 1e300, farD = -1e300;
  glm::dvec2 lo[2] = {glm::dvec2(1e300), glm::dvec2(1e300)}, hi[2] = {glm::dvec2(-1e300), glm::dvec2(-1e300)};
  for (int c = 0; c < 16; ++c) {
    const glm::dvec3 v = glm::dvec3(cam.view * glm::dvec4(corners[c], 1));
    nearD = std::min(nearD, -v.z);
    farD = std::max(farD, -v.z);
    lo[c / 8] = glm::min(lo[c / 8], glm::dvec2(v));
    hi[c / 8] = glm::max(hi[c / 8], glm::dvec2(v));
  }
  cam.zNear = std::max(0.0, nearD - margin);
  cam.zFar = farD + margin;
  // The overlap lies within both projected boxes: fit the viewport to their
  // intersection (at most the smaller object's extent), square so texels are square.
  glm::dvec2 rlo = glm::max(lo[0], lo[1]), rhi = glm::min(hi[0], hi[1]);
  if (rhi.x <= rlo.x || rhi.y <= rlo.y) {
    const int smaller = glm::length(hi[0] - lo[0]) < glm::length(hi[1] - lo[1]) ? 0 : 1;
    rlo = lo[smaller];
    rhi = hi[smaller];
  }
  const glm::dvec2 centre = 0.5 * (rlo + rhi);
  cam.extent = std::max(rhi.x - rlo.x, rhi.y - rlo.y) * 1.02 + 1e-6;
  const double h = cam.extent / 2;
  cam.projection = glm::ortho(centre.x - h, centre.x + h, centre.y - h, centre.y + h, cam.zNear, cam.zFar);
  return cam;
}

int craterRing(int w, int h) { return std::clamp(std::max(w, h) / 4, 2, 16); }

namespace {
// The CPU twin of crater_rim.comp (the read-back path must give the same maps).
void craterRimsCpu(std::vector<float>& out, const std::vector<float>& old, int res, GLint box[4]) {
  if (box[2] < box[0]) return;
  const int ring = craterRing(box[2] - box[0] + 1, box[3] - box[1] + 1);
  const float kFixed = 1048576.0f;
  auto dented = [&](int x, int y) { return out[size_t(y) * res + x] < old[size_t(y) * res + x]; };
  const int x0 = std::max(box[0] - ring, 0), y0 = std::max(box[1] - ring, 0);
  const int x1 = std::min(box[2] + ring, res - 1), y1 = std::min(box[3] + ring, res - 1);
  uint32_t volumeSum = 0, weightSum = 0;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const size_t i = size_t(y) * res + x;
      if (out[i] < old[i]) volumeSum += static_cast<uint32_t>((old[i] - out[i]) * kFixed + 0.5f);
    }
  std::vector<float> weight(size_t(x1 - x0 + 1) * (y1 - y0 + 1), -1.0f);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      if (dented(x, y)) continue;
      float best = float(ring) + 1.0f;
      for (int dy = -ring; dy <= ring; ++dy)
        for (int dx = -ring; dx <= ring; ++dx) {
          const int qx = x + dx, qy = y + dy;
          if (qx < box[0] || qy < box[1] || qx > box[2] || qy > box[3]) continue;
          const float d = std::sqrt(float(dx * dx + dy * dy));
          if (d < best && dented(qx, qy)) best = d;
        }
      if (best > float(ring)) continue;
      const float w = 1.0f - best / float(ring + 1);
      weight[size_t(y - y0) * (x1 - x0 + 1) + (x - x0)] = w;
      weightSum += static_cast<uint32_t>(w * kFixed + 0.5f);
    }
  const float volume = float(volumeSum) / kFixed, weights = std::max(float(weightSum) / kFixed, 1e-6f);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const float w = weight[size_t(y - y0) * (x1 - x0 + 1) + (x - x0)];
      if (w < 0) continue;
      const size_t i = size_t(y) * res + x;
      out[i] = std::min(old[i] + volume * w / weights, 1.0f);
    }
  box[0] = x0;
  box[1] = y0;
  box[2] = x1;
  box[3] = y1;
}
}  // namespace

struct Deformer::Impl {
  // Profile mode: wall time per phase, glFinish at each boundary.
  std::vector<PhaseTime> phases;
  std::chrono::steady_clock::time_point mark;
  bool profiling = false;
  GLuint queries[2] = {0, 0};
  ~Impl() {
    if (queries[0]) glDeleteQueries(2, queries);
  }
  void beginProfile(bool on) {
    phases.clear();
    profiling = on;
    if (!on) return;
    if (!queries[0]) glCreateQueries(GL_TIMESTAMP, 2, queries);
    glFinish();
    glQueryCounter(queries[0], GL_TIMESTAMP);
    mark = std::chrono::steady_clock::now();
  }
  void phase(const char* name) {
    if (!profiling) return;
    glQueryCounter(queries[1], GL_TIMESTAMP);
    glFinish();
    const auto now = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now - mark).count();
    GLuint64 t0 = 0, t1 = 0;
    glGetQueryObjectui64v(queries[0], GL_QUERY_RESULT, &t0);
    glGetQueryObjectui64v(queries[1], GL_QUERY_RESULT, &t1);
    const double gpuMs = static_cast<double>(t1 - t0) * 1e-6;
    glQueryCounter(queries[0], GL_TIMESTAMP);
    mark = std::chrono::steady_clock::now();
    for (auto& p : phases)
      if (p.name == name) {  // the same phase on the other side adds up
        p.ms += ms;
        p.gpuMs += gpuMs;
        return;
      }
    phases.push_back({name, ms, gpuMs});
  }
  render::Program address{{{GL_VERTEX_SHADER, "address.vert", std::string(deformShader("address.vert"))},
                           {GL_FRAGMENT_SHADER, "address.frag", std::string(deformShader("address.frag"))}}};
  render::Program gather{{{GL_VERTEX_SHADER, "texel.vert", std::string(deformShader("texel.vert"))},
                          {GL_GEOMETRY_SHADER, "texel.geom", std::string(deformShader("texel.geom"))},
                          {GL_FRAGMENT_SHADER, "texel_gather.frag", std::string(deformShader("texel_gather.frag"))}}};
  // The gather draws in X's texture space and writes only through image
  // atomics: a framebuffer without attachments, sized to the map being drawn
  // (a software rasteriser bins the whole framebuffer: no larger than needed).
  render::Framebuffer texelSpace;
  int texelSpaceSize = 0;
  void bindTexelSpace(int res) {
    if (res != texelSpaceSize) {
      glNamedFramebufferParameteri(texelSpace.id(), GL_FRAMEBUFFER_DEFAULT_WIDTH, res);
      glNamedFramebufferParameteri(texelSpace.id(), GL_FRAMEBUFFER_DEFAULT_HEIGHT, res);
      texelSpaceSize = res;
    }
    texelSpace.bind();
  }
  render::Program update = compute("dent_update.comp");
  render::Program regionDispatch = compute("region_dispatch.comp");
  render::Program commit = compute("dent_commit.comp");
  render::Program normals = compute("normal_map.comp");
  render::Program rims = compute("crater_rim.comp");
  render::Buffer sums{4 * sizeof(GLuint), nullptr, GL_DYNAMIC_STORAGE_BIT};
  int size = 0;
  // Per side: address, depth copy, world normal; one depth buffer shared by the passes of a side.
  render::Texture2D addressX[2], depthX[2], normalX[2], addressO[2], depthO[2], depthBuffer[2];
  render::Framebuffer fboX[2], fboO[2];
  render::Texture2D flat{1, 1, GL_R32F};
  std::map<int, render::Texture2D> scratch[2];  // per resolution
  render::Buffer region{4 * sizeof(GLint) * 2, nullptr, GL_DYNAMIC_STORAGE_BIT};
  render::Buffer indirect{12 * sizeof(GLuint), nullptr, GL_DYNAMIC_STORAGE_BIT};
  render::Buffer normalRegion{4 * sizeof(GLint) * 2, nullptr, GL_DYNAMIC_STORAGE_BIT};
  render::Buffer stats;
  int statsCapacity = 0, statsUsed = 0, statsRead = -1;
  std::vector<GLuint> statsHost;

  void resize(int n) {
    size = n;
    for (int s = 0; s < 2; ++s) {
      addressX[s] = render::Texture2D(n, n, GL_RG32F);
      depthX[s] = render::Texture2D(n, n, GL_R32F);
      normalX[s] = render::Texture2D(n, n, GL_RGBA16F);
      addressO[s] = render::Texture2D(n, n, GL_RG32F);
      depthO[s] = render::Texture2D(n, n, GL_R32F);
      depthBuffer[s] = render::Texture2D(n, n, GL_DEPTH_COMPONENT32F);
      for (auto* t : {&addressX[s], &depthX[s], &normalX[s], &addressO[s], &depthO[s]}) t->setFilter(GL_NEAREST, GL_NEAREST);
      fboX[s] = render::Framebuffer();
      fboX[s].attachColor(addressX[s], 0);
      fboX[s].attachColor(depthX[s], 1);
      fboX[s].attachColor(normalX[s], 2);
      fboX[s].attachDepth(depthBuffer[s]);
      const GLenum bufsX[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
      glNamedFramebufferDrawBuffers(fboX[s].id(), 3, bufsX);
      fboX[s].checkComplete();
      fboO[s] = render::Framebuffer();
      fboO[s].attachColor(addressO[s], 0);
      fboO[s].attachColor(depthO[s], 1);
      fboO[s].attachDepth(depthBuffer[s]);
      const GLenum bufsO[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
      glNamedFramebufferDrawBuffers(fboO[s].id(), 2, bufsO);
      fboO[s].checkComplete();
    }
  }

  // New heights as float bits, +infinity where nothing was written. The update
  // takes the minimum into it; the commit consumes the touched region and puts
  // +infinity back, so no deformation ever copies or clears a whole map.
  render::Texture2D& scratchFor(int side, int resolution) {
    auto it = scratch[side].find(resolution);
    if (it == scratch[side].end()) {
      it = scratch[side].emplace(resolution, render::Texture2D(resolution, resolution, GL_R32UI)).first;
      const GLuint inf = kUntouched;
      glClearTexImage(it->second.id(), 0, GL_RED_INTEGER, GL_UNSIGNED_INT, &inf);
    }
    return it->second;
  }
  static constexpr GLuint kUntouched = 0x7f800000u;  // +infinity

  int allocateStats() {
    if (statsUsed + 2 > statsCapacity) {
      const int cap = std::max(64, statsCapacity * 2);
      render::Buffer bigger(static_cast<size_t>(cap) * 4 * sizeof(GLuint), nullptr, GL_DYNAMIC_STORAGE_BIT);
      std::vector<GLuint> zeros(static_cast<size_t>(cap) * 4, 0);
      bigger.upload(0, zeros.size() * sizeof(GLuint), zeros.data());
      if (statsCapacity) glCopyNamedBufferSubData(stats.id(), bigger.id(), 0, 0, static_cast<GLsizeiptr>(statsCapacity) * 4 * sizeof(GLuint));
      stats = std::move(bigger);
      statsCapacity = cap;
    }
    const int h = statsUsed;
    statsUsed += 2;
    return h;
  }
};

Deformer::Deformer(const DeformOptions& options) : impl_(std::make_unique<Impl>()), options_(options) {
  const float half = 0.5f;
  impl_->flat.upload(GL_RED, GL_FLOAT, &half);
  impl_->resize(options.addressMap);
}
Deformer::~Deformer() = default;

void Deformer::setOptions(const DeformOptions& options) {
  if (options.addressMap != impl_->size) impl_->resize(options.addressMap);
  options_ = options;
}

const render::Texture2D& Deformer::lastAddressMap() const {
  return options_.path == Path::Gather ? impl_->addressO[0] : impl_->addressX[0];
}
const std::vector<PhaseTime>& Deformer::profile() const { return impl_->phases; }

std::shared_ptr<SurfaceMaps> Deformer::createMaps(int resolution, const render::Image* initial, float bumpDepth,
                                                  float texelSize) {
  auto maps = std::make_shared<SurfaceMaps>(resolution);
  if (initial) {
    std::vector<float> grey(static_cast<size_t>(resolution) * resolution);
    for (int y = 0; y < resolution; ++y)
      for (int x = 0; x < resolution; ++x) grey[static_cast<size_t>(y) * resolution + x] = initial->at(x, y, 0);
    maps->height.upload(GL_RED, GL_FLOAT, grey.data());
  } else {
    const float half = 0.5f;
    glClearTexImage(maps->height.id(), 0, GL_RED, GL_FLOAT, &half);
  }
  Impl& m = *impl_;
  m.normals.use();
  glBindTextureUnit(0, maps->height.id());
  glBindImageTexture(1, maps->normal.id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
  glUniform1i(m.normals.uniform("uSide"), -1);
  glUniform4i(m.normals.uniform("uFullRegion"), 0, 0, resolution - 1, resolution - 1);
  glUniform1i(m.normals.uniform("uResolution"), resolution);
  glUniform1f(m.normals.uniform("uSlopeScale"), bumpDepth / (2 * texelSize));
  glDispatchCompute(groups(resolution), groups(resolution), 1);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  return maps;
}

void Deformer::regenerateNormals(Surface& s, glm::ivec2 lo, glm::ivec2 hi) {
  Impl& m = *impl_;
  m.normals.use();
  glBindTextureUnit(0, s.height().id());
  glBindImageTexture(1, s.normal().id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
  glUniform1i(m.normals.uniform("uSide"), -1);
  glUniform4i(m.normals.uniform("uFullRegion"), lo.x, lo.y, hi.x, hi.y);
  glUniform1i(m.normals.uniform("uResolution"), s.resolution());
  glUniform1f(m.normals.uniform("uSlopeScale"), s.bumpDepth() / (2 * s.texelSize()));
  glDispatchCompute(groups(hi.x - lo.x + 1), groups(hi.y - lo.y + 1), 1);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
}

int Deformer::deform(const DeformRequest& rq) {
  Impl& m = *impl_;
  m.beginProfile(options_.profile);
  const int handle = m.allocateStats();
  const GLint emptyRegion[8] = {INT_MAX, INT_MAX, -1, -1, INT_MAX, INT_MAX, -1, -1};
  m.region.upload(0, sizeof emptyRegion, emptyRegion);
  bool active[2] = {false, false};
  int rings[2] = {0, 0};  // crater ring width per side: the commit region grows by it
  GLint savedViewport[4];
  glGetIntegerv(GL_VIEWPORT, savedViewport);

  for (int side = 0; side < 2; ++side) {
    const DeformBody& X = side == 0 ? rq.a : rq.b;
    const DeformBody& O = side == 0 ? rq.b : rq.a;
    const double depth = side == 0 ? rq.deformA : rq.deformB;
    if (!X.surface || !(depth > 0) || !X.mesh || !O.mesh) continue;
    active[side] = true;
    // The normal as owned by X, pointing towards the other body.
    const glm::dvec3 n = side == 0 ? rq.normal : -rq.normal;
    // Retract by d_C to first contact, then advance X into the other by its deformation.
    const glm::dmat4 modelX = glm::translate(glm::dmat4(1), n * (depth - rq.penetration)) * X.model;
    const glm::dmat4& modelO = O.model;
    glm::dvec3 bx[2], bo[2];
    worldBounds(*X.mesh, modelX, bx);
    worldBounds(*O.mesh, modelO, bo);
    const AddressCamera cam = addressCamera(rq.point, n, bx, bo);
    const double range = cam.zFar - cam.zNear;
    const glm::dmat4 vp = cam.projection * cam.view;

    glViewport(0, 0, m.size, m.size);
    glEnable(GL_DEPTH_TEST);
    glDepthMask(GL_TRUE);
    glEnable(GL_CULL_FACE);
    glDisable(GL_BLEND);
    const float noAddress[4] = {-1, -1, 0, 0};
    const float one = 1.0f, zero = 0.0f, zero4[4] = {0, 0, 0, 0};
    const bool gather = options_.path == Path::Gather;
    m.address.use();
    auto draw = [&](const DeformBody& body, const glm::dmat4& model, float sign, float kCollide) {
      const glm::mat4 mvp = glm::mat4(vp * model);
      const glm::mat3 nrm = glm::mat3(glm::transpose(glm::inverse(glm::dmat3(model))));
      glUniformMatrix4fv(m.address.uniform("uModelViewProjection"), 1, GL_FALSE, glm::value_ptr(mvp));
      glUniformMatrix3fv(m.address.uniform("uNormalToWorld"), 1, GL_FALSE, glm::value_ptr(nrm));
      glUniform1f(m.address.uniform("uSign"), sign);
      glUniform1f(m.address.uniform("uBumpToDepth"), static_cast<float>(kCollide / range));
      glBindTextureUnit(0, body.surface ? body.surface->height().id() : m.flat.id());
      body.mesh->draw();
    };
    m.phase("setup");
    if (!gather) {
      // Pass A: front faces of X, depth LESS.
      m.fboX[side].bind();
      glClearNamedFramebufferfv(m.fboX[side].id(), GL_COLOR, 0, noAddress);
      glClearNamedFramebufferfv(m.fboX[side].id(), GL_COLOR, 1, &one);
      // The normal attachment only serves the tangent-space correction: without
      // it the pass writes (and clears) 8 bytes a pixel fewer.
      const bool normals = options_.tangent != TangentMode::None;
      const GLenum bufsX[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, normals ? GLenum(GL_COLOR_ATTACHMENT2) : GLenum(GL_NONE)};
      glNamedFramebufferDrawBuffers(m.fboX[side].id(), 3, bufsX);
      if (normals) glClearNamedFramebufferfv(m.fboX[side].id(), GL_COLOR, 2, zero4);
      glClearNamedFramebufferfv(m.fboX[side].id(), GL_DEPTH, 0, &one);
      glDepthFunc(GL_LESS);
      glCullFace(GL_BACK);
      draw(X, modelX, -1.0f, X.surface->bumpDepthCollide());
      m.phase("address pass X");
    }
    // Pass B: back faces of the other, depth GREATER: against X's depth (the
    // scatter), or the farthest back face anywhere (the gather's depth map).
    m.fboO[side].bind();
    glClearNamedFramebufferfv(m.fboO[side].id(), GL_COLOR, 0, noAddress);
    glClearNamedFramebufferfv(m.fboO[side].id(), GL_COLOR, 1, &one);
    if (gather) glClearNamedFramebufferfv(m.fboO[side].id(), GL_DEPTH, 0, &zero);
    glDepthFunc(GL_GREATER);
    glCullFace(GL_FRONT);
    draw(O, modelO, 1.0f, O.surface ? O.surface->bumpDepthCollide() : 0.0f);
    glDepthFunc(GL_LESS);
    glCullFace(GL_BACK);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    m.phase("address pass other");

    const int res = X.surface->resolution();
    render::Texture2D& scratch = m.scratchFor(side, res);
    const float depthToHeight = static_cast<float>(range / X.surface->bumpDepth());

    if (gather) {
      glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
      m.gather.use();
      m.bindTexelSpace(res);
      glViewport(0, 0, res, res);
      glDisable(GL_DEPTH_TEST);
      glDisable(GL_CULL_FACE);
      const glm::mat4 mvp = glm::mat4(vp * modelX);
      const glm::mat3 nrm = glm::mat3(glm::transpose(glm::inverse(glm::dmat3(modelX))));
      glUniformMatrix4fv(m.gather.uniform("uModelViewProjection"), 1, GL_FALSE, glm::value_ptr(mvp));
      glUniformMatrix3fv(m.gather.uniform("uNormalToWorld"), 1, GL_FALSE, glm::value_ptr(nrm));
      glBindTextureUnit(2, m.addressO[side].id());
      glBindTextureUnit(3, m.depthO[side].id());
      glBindTextureUnit(5, X.surface->height().id());
      glBindImageTexture(0, scratch.id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32UI);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.region.id());
      glUniform1i(m.gather.uniform("uSide"), side);
      glUniform1i(m.gather.uniform("uSize"), m.size);
      glUniform1i(m.gather.uniform("uResolution"), res);
      glUniform1f(m.gather.uniform("uViewMargin"), 4.0f / static_cast<float>(m.size));
      double farthest = 0;
      for (int c = 0; c < 8; ++c) {
        const glm::dvec3 corner(c & 1 ? bo[1].x : bo[0].x, c & 2 ? bo[1].y : bo[0].y, c & 4 ? bo[1].z : bo[0].z);
        farthest = std::max(farthest, (-(cam.view * glm::dvec4(corner, 1)).z - cam.zNear) / range);
      }
      if (O.surface) farthest += 0.5 * O.surface->bumpDepthCollide() / range;
      glUniform1f(m.gather.uniform("uFarthestOther"), static_cast<float>(farthest + 1e-6));
      glUniform1f(m.gather.uniform("uBumpReach"), static_cast<float>(0.5 * X.surface->bumpDepthCollide() / range));
      glUniform1f(m.gather.uniform("uBumpToDepth"), static_cast<float>(X.surface->bumpDepthCollide() / range));
      glUniform1f(m.gather.uniform("uDepthToHeight"), depthToHeight);
      glUniform1i(m.gather.uniform("uTangentMode"), static_cast<int>(options_.tangent));
      glUniform1f(m.gather.uniform("uTangentFloor"), options_.tangentFloor);
      glUniform3f(m.gather.uniform("uViewNormal"), static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z));
      X.mesh->draw();
      glBindFramebuffer(GL_FRAMEBUFFER, 0);
      glEnable(GL_DEPTH_TEST);
      glEnable(GL_CULL_FACE);
      glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
      m.phase("gather (texels)");
    } else if (options_.path == Path::Scatter) {
      glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
      m.update.use();
      glBindTextureUnit(0, m.addressX[side].id());
      glBindTextureUnit(1, m.depthX[side].id());
      glBindTextureUnit(2, m.addressO[side].id());
      glBindTextureUnit(3, m.depthO[side].id());
      glBindTextureUnit(4, m.normalX[side].id());
      glBindTextureUnit(5, X.surface->height().id());
      glBindImageTexture(0, scratch.id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32UI);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.region.id());
      glUniform1i(m.update.uniform("uSide"), side);
      glUniform2i(m.update.uniform("uSize"), m.size, m.size);
      glUniform1i(m.update.uniform("uResolution"), res);
      glUniform1f(m.update.uniform("uDepthToHeight"), depthToHeight);
      glUniform1i(m.update.uniform("uTangentMode"), static_cast<int>(options_.tangent));
      glUniform1f(m.update.uniform("uTangentFloor"), options_.tangentFloor);
      glUniform3f(m.update.uniform("uViewNormal"), static_cast<float>(n.x), static_cast<float>(n.y), static_cast<float>(n.z));
      glDispatchCompute(groups(m.size), groups(m.size), 1);
      m.phase("update (compute)");
    }
    if (options_.path != Path::Readback) {
      if (options_.craterRims) {
        // The ring width depends on the dent's size: read the region (4 ints) once.
        glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
        GLint box[4];
        glGetNamedBufferSubData(m.region.id(), static_cast<GLintptr>(side) * 4 * sizeof(GLint), sizeof box, box);
        if (box[2] >= box[0]) {
          const int ring = craterRing(box[2] - box[0] + 1, box[3] - box[1] + 1);
          rings[side] = ring;
          const GLuint zero[2] = {0, 0};
          m.sums.upload(static_cast<size_t>(side) * 2 * sizeof(GLuint), sizeof zero, zero);
          m.rims.use();
          glBindImageTexture(0, scratch.id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32UI);
          glBindTextureUnit(1, X.surface->height().id());
          glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.region.id());
          glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, m.sums.id());
          glUniform1i(m.rims.uniform("uSide"), side);
          glUniform1i(m.rims.uniform("uRing"), ring);
          glUniform1i(m.rims.uniform("uResolution"), res);
          const int w = std::min(res, box[2] - box[0] + 1 + 2 * ring), hgt = std::min(res, box[3] - box[1] + 1 + 2 * ring);
          for (int mode = 0; mode < 3; ++mode) {
            glUniform1i(m.rims.uniform("uMode"), mode);
            glDispatchCompute(groups(w), groups(hgt), 1);
            glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
          }
        }
      }
    } else {
      // The paper's path: read the address maps back and scatter on the CPU.
      const size_t px = static_cast<size_t>(m.size) * m.size;
      const bool tangent = options_.tangent != TangentMode::None;
      std::vector<float> ca(px * 2), da(px), cb(px * 2), db(px), na(tangent ? px * 4 : 0);
      // The address maps come back with glGetTextureImage on the attached
      // textures: on NVIDIA's driver glReadPixels of float targets took
      // 1 s at 512 (0.8 us a pixel) where this takes a few ms.
      glPixelStorei(GL_PACK_ALIGNMENT, 1);
      m.addressX[side].download(GL_RG, GL_FLOAT, ca.data(), ca.size() * sizeof(float));
      m.depthX[side].download(GL_RED, GL_FLOAT, da.data(), da.size() * sizeof(float));
      if (tangent) m.normalX[side].download(GL_RGBA, GL_FLOAT, na.data(), na.size() * sizeof(float));
      m.addressO[side].download(GL_RG, GL_FLOAT, cb.data(), cb.size() * sizeof(float));
      m.depthO[side].download(GL_RED, GL_FLOAT, db.data(), db.size() * sizeof(float));
      m.phase("read address maps");
      std::vector<float> h(static_cast<size_t>(res) * res);
      X.surface->height().download(GL_RED, GL_FLOAT, h.data(), h.size() * sizeof(float));
      m.phase("height map download");
      std::vector<float> out = h;
      GLint box[4] = {INT_MAX, INT_MAX, -1, -1};
      const glm::vec3 vn(n);
      for (size_t i = 0; i < px; ++i) {
        if (ca[i * 2] < 0.0f || cb[i * 2] < 0.0f) continue;
        float dD = db[i] - da[i];
        if (!(dD > 0.0f)) continue;
        if (tangent) {
          const float c = std::abs(glm::dot(glm::normalize(glm::vec3(na[i * 4], na[i * 4 + 1], na[i * 4 + 2])), vn));
          dD = options_.tangent == TangentMode::Multiply ? dD * c : dD / std::max(c, options_.tangentFloor);
        }
        const int tx = std::clamp(static_cast<int>(std::floor(ca[i * 2] * static_cast<float>(res))), 0, res - 1);
        const int ty = std::clamp(static_cast<int>(std::floor(ca[i * 2 + 1] * static_cast<float>(res))), 0, res - 1);
        const size_t t = static_cast<size_t>(ty) * res + tx;
        const float h2 = std::clamp(std::fma(-dD, depthToHeight, h[t]), 0.0f, 1.0f);  // as the GPU's dent_update.comp
        if (!(h2 < h[t])) continue;
        out[t] = std::min(out[t], h2);
        box[0] = std::min(box[0], tx);
        box[1] = std::min(box[1], ty);
        box[2] = std::max(box[2], tx);
        box[3] = std::max(box[3], ty);
      }
      if (options_.craterRims && box[2] >= box[0]) {
        rings[side] = 0;  // the CPU twin grows the box itself
        craterRimsCpu(out, h, res, box);
      }
      m.phase("cpu scatter");
      std::vector<GLuint> bits(out.size());
      std::memcpy(bits.data(), out.data(), out.size() * sizeof(float));
      for (size_t i = 0; i < out.size(); ++i)
        if (out[i] == h[i]) bits[i] = Impl::kUntouched;
      scratch.upload(GL_RED_INTEGER, GL_UNSIGNED_INT, bits.data());
      m.region.upload(static_cast<size_t>(side) * 4 * sizeof(GLint), sizeof box, box);
      m.phase("upload");
    }
  }
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_COMMAND_BARRIER_BIT);

  // Commit both sides only now, so that neither saw the other's new dent.
  for (int side = 0; side < 2; ++side) {
    if (!active[side]) continue;
    Surface& X = *(side == 0 ? rq.a : rq.b).surface;
    X.makeUnique();
    const int res = X.resolution();
    m.regionDispatch.use();
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.region.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, m.indirect.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, m.normalRegion.id());
    glUniform1i(m.regionDispatch.uniform("uSide"), side);
    glUniform1i(m.regionDispatch.uniform("uResolution"), res);
    glUniform1i(m.regionDispatch.uniform("uGrow"), rings[side]);
    glDispatchCompute(1, 1, 1);
    glMemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);

    glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, m.indirect.id());
    m.commit.use();
    glBindImageTexture(0, m.scratchFor(side, res).id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32UI);
    glBindImageTexture(1, X.height().id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32F);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, m.region.id());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, m.stats.id());
    glUniform1i(m.commit.uniform("uSide"), side);
    glUniform1i(m.commit.uniform("uStatsIndex"), handle + side);
    glUniform1f(m.commit.uniform("uBumpDepth"), X.bumpDepth());
    glDispatchComputeIndirect(static_cast<GLintptr>(side) * 6 * sizeof(GLuint));
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
    m.phase("commit");

    m.normals.use();
    glBindTextureUnit(0, X.height().id());
    glBindImageTexture(1, X.normal().id(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, m.normalRegion.id());
    glUniform1i(m.normals.uniform("uSide"), side);
    glUniform4i(m.normals.uniform("uFullRegion"), 0, 0, -1, -1);
    glUniform1i(m.normals.uniform("uResolution"), res);
    glUniform1f(m.normals.uniform("uSlopeScale"), X.bumpDepth() / (2 * X.texelSize()));
    glDispatchComputeIndirect(static_cast<GLintptr>(side) * 6 * sizeof(GLuint) + 3 * sizeof(GLuint));
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
    m.phase("normal map");
  }
  glBindBuffer(GL_DISPATCH_INDIRECT_BUFFER, 0);
  glViewport(savedViewport[0], savedViewport[1], savedViewport[2], savedViewport[3]);
  glDisable(GL_CULL_FACE);
  return handle;
}

SideStats Deformer::stats(int handle, int side) {
  Impl& m = *impl_;
  SideStats s;
  if (handle < 0 || handle + side >= m.statsUsed) return s;
  if (m.statsRead < m.statsUsed) {
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    m.statsHost.resize(static_cast<size_t>(m.statsUsed) * 4);
    glGetNamedBufferSubData(m.stats.id(), 0, static_cast<GLsizeiptr>(m.statsHost.size() * sizeof(GLuint)), m.statsHost.data());
    m.statsRead = m.statsUsed;
  }
  const size_t base = static_cast<size_t>(handle + side) * 4;
  s.texelsChanged = static_cast<int>(m.statsHost[base]);
  float dent;
  std::memcpy(&dent, &m.statsHost[base + 1], sizeof dent);
  s.maxDent = dent;
  s.saturated = m.statsHost[base + 2] > 0;
  return s;
}

}  // namespace crumple::deform
