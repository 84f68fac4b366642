#include <crumple/deform/deformer.h>

#include <crumple/deform/passes.h>
#include <crumple/gl/context.h>
#include <crumple/gl/state.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <chrono>
#include <map>
#include <optional>

namespace crumple::deform {

namespace shaders {
std::string_view shaderSource(std::string_view name);
}
std::string_view deformShader(std::string_view fileName) { return shaders::shaderSource(fileName); }

std::string deformSource(const char* name) {
  const std::string_view src = deformShader(name);
  std::string out;
  size_t at = 0;
  while (at < src.size()) {
    size_t end = src.find('\n', at);
    if (end == std::string_view::npos) end = src.size();
    const std::string_view line = src.substr(at, end - at);
    constexpr std::string_view kInclude = "#include \"";
    if (line.substr(0, kInclude.size()) == kInclude && line.size() > kInclude.size() + 1 && line.back() == '"')
      out += deformShader(line.substr(kInclude.size(), line.size() - kInclude.size() - 1));
    else
      out += line;
    out += '\n';
    at = end + 1;
  }
  return out;
}

const char* addressRasterName(AddressRaster r) {
  switch (r) {
    case AddressRaster::Compute:
      return "compute";
    case AddressRaster::Fragment:
      return "fragment";
    default:
      return "auto";
  }
}

AddressRaster resolveAddressRaster(AddressRaster r, const char* renderer) {
  if (r != AddressRaster::Auto) return r;
  return gl::fewGraphicsUnits(renderer) ? AddressRaster::Compute : AddressRaster::Fragment;
}

const char* pathName(Path p) {
  switch (p) {
    case Path::Gather:
      return "gather";
    case Path::Scatter:
      return "scatter";
    case Path::Readback:
      return "readback";
  }
  return "?";
}

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

AddressCamera addressCamera(const glm::dvec3& point, const glm::dvec3& n, const glm::dvec3 bx[2],
                            const glm::dvec3 bo[2]) {
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

namespace {
// The nearest and farthest window depths (0 at zNear, 1 at zFar) of the corners of world box b[0..1].
glm::dvec2 windowDepths(const AddressCamera& cam, const glm::dvec3 b[2]) {
  glm::dvec2 r(1e300, -1e300);
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 corner(c & 1 ? b[1].x : b[0].x, c & 2 ? b[1].y : b[0].y, c & 4 ? b[1].z : b[0].z);
    const double z = (-(cam.view * glm::dvec4(corner, 1)).z - cam.zNear) / (cam.zFar - cam.zNear);
    r = {std::min(r.x, z), std::max(r.y, z)};
  }
  return r;
}

// DeformOptions::addressRaster resolved for the current context's GPU.
AddressRaster resolveForThisGpu(AddressRaster r) {
  return resolveAddressRaster(r, reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
}
}  // namespace

int craterRing(int w, int h) { return std::clamp(std::max(w, h) / 4, 2, 16); }

struct Deformer::Impl {
  AddressRaster raster = AddressRaster::Fragment;  // DeformOptions::addressRaster resolved for this GPU
  long waves = 0;
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
  AddressPasses passes;
  GatherUpdate gather;
  std::optional<ComputeGather> computeGather;  // made on first use (the compute rasteriser's path)
  ScatterUpdate scatter;
  ReadbackUpdate readback;
  CraterRims rims;
  CommitPass commit;
  // The crease bevel (creaseBevel): its program, sampler and the relaxation's buffers (a vec4 a node, the largest
  // mesh's).
  std::optional<gl::Program> bevelProgram;
  std::optional<gl::Program> levelsProgram;  // chartLevels
  gl::Sampler bevelSampler{GL_LINEAR_MIPMAP_LINEAR, GL_LINEAR, GL_CLAMP_TO_EDGE};
  gl::Buffer bevelOwn, bevelA, bevelB;
  // The change log (Deformer::logChanges): count, capacity, then 3 uints an entry; mapped for as long as it lives.
  gl::Buffer changes;
  GLuint* changesMapped = nullptr;
  // New heights (passes.h, Scratch): per slot and resolution a range of one buffer, made on first use and kept.
  gl::Buffer scratchBuffer;
  size_t scratchUsed = 0;  // uints
  std::map<std::pair<int, int>, GLuint> scratchRanges;
  gl::Buffer region{4 * sizeof(GLint) * 2, nullptr, GL_DYNAMIC_STORAGE_BIT};  // touched texels per slot
  gl::Buffer stats;
  int statsCapacity = 0, statsUsed = 0, statsRead = -1;
  std::vector<GLuint> statsHost;
  const PhaseMark phaseMark = [this](const char* name) { phase(name); };

  explicit Impl(int addressMap) : passes(addressMap) {}

  // New heights as float bits, +infinity where nothing was written. The update
  // takes the minimum into it; the commit consumes the touched region and puts
  // +infinity back, so no deformation ever copies or clears a whole map.
  Scratch scratchFor(int slot, int resolution) {
    auto it = scratchRanges.find({slot, resolution});
    if (it == scratchRanges.end()) {
      const size_t texels = static_cast<size_t>(resolution) * static_cast<size_t>(resolution);
      if ((scratchUsed + texels) * sizeof(GLuint) > scratchBuffer.size()) {  // grows, keeping what it holds
        gl::Buffer bigger(std::max((scratchUsed + texels) * sizeof(GLuint), 2 * scratchBuffer.size()), nullptr);
        glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);  // the commits' writes, before the copy reads them
        if (scratchUsed)
          glCopyNamedBufferSubData(scratchBuffer.id(), bigger.id(), 0, 0,
                                   static_cast<GLsizeiptr>(scratchUsed * sizeof(GLuint)));
        scratchBuffer = std::move(bigger);
      }
      glClearNamedBufferSubData(scratchBuffer.id(), GL_R32UI, static_cast<GLintptr>(scratchUsed * sizeof(GLuint)),
                                static_cast<GLsizeiptr>(texels * sizeof(GLuint)), GL_RED_INTEGER, GL_UNSIGNED_INT,
                                &kUntouched);
      if (scratchUsed + texels > UINT32_MAX) throw std::length_error("deformation scratch over 2^32 texels");
      it = scratchRanges.emplace(std::make_pair(slot, resolution), static_cast<GLuint>(scratchUsed)).first;
      scratchUsed += texels;
    }
    return {&scratchBuffer, it->second};
  }

  int allocateStats() {
    if (statsUsed + 2 > statsCapacity) {
      const int cap = std::max(64, statsCapacity * 2);
      const std::vector<GLuint> zeros(static_cast<size_t>(cap) * 4, 0);
      gl::Buffer bigger(zeros.size() * sizeof(GLuint), zeros.data(), GL_DYNAMIC_STORAGE_BIT);
      glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);  // the commits' counts, before the copy reads them
      if (statsCapacity)
        glCopyNamedBufferSubData(stats.id(), bigger.id(), 0, 0,
                                 static_cast<GLsizeiptr>(statsCapacity) * 4 * sizeof(GLuint));
      stats = std::move(bigger);
      statsCapacity = cap;
    }
    const int h = statsUsed;
    statsUsed += 2;
    return h;
  }

  // One side of an event: its camera, matrices and update parameters.
  struct SidePlan {
    bool active = false;
    const DeformBody* x = nullptr;
    const DeformBody* other = nullptr;
    glm::dmat4 modelX{1}, vp{1};
    SideUpdate u;
    float otherBumpToDepth = 0, farthestOther = 0;
    float reachOther = 0;  // the compute pass B's cull depth: triangles of the other body wholly nearer cannot dent
  };
  // `side`: 0 (X is A) or 1; `slot`: where its targets, scratch and region are (2 e + side for event e of a wave).
  SidePlan plan(const DeformOptions& o, int side, int slot, const DeformBody& x, const DeformBody& other,
                const DeformRequest& rq, double depth);
  // The gather, all sides of a wave stage by stage; crater rims where asked (rimsMade).
  void gatherSlots(const DeformOptions& o, const std::vector<SidePlan>& p, std::vector<char>& rimsMade);
  // Events e[0..n) (surfaces all different), their stats handles into handles[0..n).
  void runWave(const DeformOptions& o, const DeformRequest* const* e, size_t n, int* handles);
  void reserveSlots(int slots) {
    passes.reserveSlots(slots);
    if (region.size() < static_cast<size_t>(slots) * 4 * sizeof(GLint))
      region = gl::Buffer(static_cast<size_t>(slots) * 4 * sizeof(GLint), nullptr, GL_DYNAMIC_STORAGE_BIT);
  }
  // The paper's update (scatter or read-back) of one side; whether it made a crater rim the commit must grow by.
  bool paperSide(const DeformOptions& o, const SidePlan& p);
};

Deformer::Deformer(const DeformOptions& options)
    : impl_(std::make_unique<Impl>(options.addressMap)), options_(options) {
  impl_->raster = resolveForThisGpu(options.addressRaster);
}
Deformer::~Deformer() = default;

void Deformer::setOptions(const DeformOptions& options) {
  if (options.addressMap != impl_->passes.size()) impl_->passes.resize(options.addressMap);
  if (options.addressRaster != options_.addressRaster) impl_->raster = resolveForThisGpu(options.addressRaster);
  options_ = options;
}

const gl::Texture2D& Deformer::lastAddressMap() const {
  return options_.path == Path::Gather ? impl_->passes.addressOther(0) : impl_->passes.addressX(0);
}
std::pair<size_t, size_t> Deformer::lastRasterTiles() const { return impl_->passes.tilesRun(0); }
std::pair<size_t, size_t> Deformer::lastGatherTiles() const {
  return impl_->computeGather ? impl_->computeGather->lastKept() : std::pair<size_t, size_t>{0, 0};
}
const std::vector<PhaseTime>& Deformer::profile() const { return impl_->phases; }

void Deformer::chartLevels(Surface& s) {
  const gl::Texture2D& height = s.maps().height;
  const std::shared_ptr<const ChartCover> cover = ChartCover::of(s.mesh(), height.width());
  if (cover->covered == 0) return;  // (no uvs: the levels GL made stay)
  Impl& m = *impl_;
  if (!m.levelsProgram) m.levelsProgram.emplace(computeProgram("height_levels.comp"));
  const gl::StateGuard callerState;
  const gl::Program& p = *m.levelsProgram;
  p.use();
  namespace b = bindings::levels;
  gl::bindStorage(b::kCover, cover->cover.id());
  const GLint stage = p.location("uStage"), size = p.location("uSize"), fromSize = p.location("uFromSize");
  const GLint coverTo = p.location("uCoverTo"), coverFrom = p.location("uCoverFrom");
  const int levels = static_cast<int>(cover->offsets.size());
  auto sizeOf = [&](int level) {
    return glm::ivec2(std::max(1, height.width() >> level), std::max(1, height.height() >> level));
  };
  auto run = [&](int which, int level, int from) {
    const glm::ivec2 to = sizeOf(level);
    p.set(stage, which);
    p.set(size, to);
    p.set(fromSize, sizeOf(from));
    p.set(coverTo, cover->offsets[static_cast<size_t>(level)]);
    p.set(coverFrom, cover->offsets[static_cast<size_t>(from)]);
    gl::bindImageLevel(b::kTo, height.id(), level, GL_READ_WRITE, GL_R32F);
    gl::bindImageLevel(b::kFrom, height.id(), from, GL_READ_ONLY, GL_R32F);
    glDispatchCompute(static_cast<GLuint>((to.x + 7) / 8), static_cast<GLuint>((to.y + 7) / 8), 1);
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
  };
  for (int level = 1; level < levels; ++level) run(0, level, level - 1);
  for (int level = levels - 2; level >= 1; --level) run(1, level, level + 1);
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
}

void Deformer::creaseBevel(Surface& s) {
  SurfaceMaps& maps = s.mutableMaps();
  const GpuMesh& mesh = s.mesh();
  if (maps.version == 0 || maps.creaseVersion == maps.version || mesh.nodeCount == 0) return;
  chartLevels(s);
  Impl& m = *impl_;
  if (!m.bevelProgram) m.bevelProgram.emplace(computeProgram("crease_bevel.comp"));
  const size_t bytes = static_cast<size_t>(mesh.nodeCount) * 4 * sizeof(float);
  if (m.bevelOwn.size() < bytes) {
    m.bevelOwn = gl::Buffer(bytes, nullptr, 0);
    m.bevelA = gl::Buffer(bytes, nullptr, 0);
    m.bevelB = gl::Buffer(bytes, nullptr, 0);
  }
  if (maps.crease.size() != bytes) maps.crease = gl::Buffer(bytes, nullptr, 0);
  const gl::StateGuard callerState;
  const gl::Program& p = *m.bevelProgram;
  p.use();
  namespace b = bindings::bevel;
  p.set(p.location("uNodes"), static_cast<int>(mesh.nodeCount));
  p.set(p.location("uBumpDepth"), s.bumpDepth());
  p.set(p.location("uTexel"), s.texelSize());
  const GLint stage = p.location("uStage");
  gl::bindTexture(b::kHeight, maps.height.id());
  gl::bindSampler(b::kHeight, m.bevelSampler.id());  // (the map's own filter reads level 0 alone)
  gl::bindStorage(b::kUvs, mesh.nodeUvs.id());
  gl::bindStorage(b::kLinks, mesh.nodeLinks.id());
  gl::bindStorage(b::kFrames, mesh.nodeFrames.id());
  gl::bindStorage(b::kOwn, m.bevelOwn.id());
  const GLuint groups = (mesh.nodeCount + 63) / 64;
  auto run = [&](int which, const gl::Buffer& from, const gl::Buffer& to) {
    p.set(stage, which);
    gl::bindStorage(b::kFrom, from.id());
    gl::bindStorage(b::kTo, to.id());
    glDispatchCompute(groups, 1, 1);
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  };
  run(0, m.bevelB, m.bevelA);
  // Each round reaches an edge further; a bevel of 1:1 spans at most the bump depth.
  const int rounds = std::clamp(static_cast<int>(std::ceil(s.bumpDepth() / mesh.shortEdge)) + 1, 1, 32);
  for (int r = 0; r < rounds; ++r) {
    run(1, m.bevelA, m.bevelB);
    std::swap(m.bevelA, m.bevelB);
  }
  run(2, m.bevelA, maps.crease);
  gl::bindSampler(b::kHeight, 0);
  maps.creaseVersion = maps.version;
}

void Deformer::logChanges(size_t capacity) {
  Impl& m = *impl_;
  m.changes = gl::Buffer((2 + 3 * capacity) * sizeof(GLuint), nullptr,
                         GL_MAP_READ_BIT | GL_MAP_WRITE_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT |
                             GL_CLIENT_STORAGE_BIT);
  m.changesMapped = static_cast<GLuint*>(
      glMapNamedBufferRange(m.changes.id(), 0, static_cast<GLsizeiptr>(m.changes.size()),
                            GL_MAP_READ_BIT | GL_MAP_WRITE_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT));
  if (!m.changesMapped) throw std::runtime_error("deformer: could not map the change log's buffer");
  m.changesMapped[0] = 0;
  m.changesMapped[1] = static_cast<GLuint>(capacity);
}

GLsync Deformer::fenceChanges() {
  // The shaders' writes to a persistently mapped buffer reach the CPU through this barrier, then the fence.
  glMemoryBarrier(GL_CLIENT_MAPPED_BUFFER_BARRIER_BIT);
  return glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
}

Deformer::Changes Deformer::changes() const {
  const Impl& m = *impl_;
  if (!m.changesMapped) return {};
  const size_t count = m.changesMapped[0], capacity = m.changesMapped[1];
  return {m.changesMapped + 2, std::min(count, capacity), count > capacity};
}

void Deformer::clearChanges() {
  if (impl_->changesMapped) impl_->changesMapped[0] = 0;  // (coherent: seen by the commands issued after it)
}
AddressRaster Deformer::addressRaster() const { return impl_->raster; }
long Deformer::wavesRun() const { return impl_->waves; }
size_t Deformer::waveLimit() const {
  const bool waves = options_.path == Path::Gather && impl_->raster == AddressRaster::Compute && !options_.craterRims;
  return waves ? std::max<size_t>(1, options_.waveMemory / (2 * AddressPasses::slotBytes(options_.addressMap))) : 1;
}

std::shared_ptr<SurfaceMaps> Deformer::createMaps(int resolution, const gl::Image* initial, float bumpDepth,
                                                  float texelSize) {
  auto maps = std::make_shared<SurfaceMaps>(resolution);
  if (initial) {
    std::vector<float> grey(static_cast<size_t>(resolution) * resolution);
    for (int y = 0; y < resolution; ++y)
      for (int x = 0; x < resolution; ++x) grey[static_cast<size_t>(y) * resolution + x] = initial->at(x, y, 0);
    maps->height.upload(GL_RED, GL_FLOAT, grey.data());
    maps->highest = *std::max_element(grey.begin(), grey.end());
    maps->imageHighest = maps->highest;
  } else {
    maps->highest = 0.5f;
    maps->imageHighest = 0.5f;
    const float half = 0.5f;
    glClearTexImage(maps->height.id(), 0, GL_RED, GL_FLOAT, &half);
  }
  impl_->commit.normals(*maps, resolution, bumpDepth / (2 * texelSize), {0, 0}, {resolution - 1, resolution - 1});
  return maps;
}

void Deformer::regenerateNormals(Surface& s, glm::ivec2 lo, glm::ivec2 hi) {
  impl_->commit.normals(s.maps(), s.resolution(), s.bumpDepth() / (2 * s.texelSize()), lo, hi);
}

Deformer::Impl::SidePlan Deformer::Impl::plan(const DeformOptions& o, int side, int slot, const DeformBody& x,
                                              const DeformBody& other, const DeformRequest& rq, double depth) {
  SidePlan p;
  p.active = true;
  p.x = &x;
  p.other = &other;
  // The normal as owned by X, pointing towards the other body.
  const glm::dvec3 n = side == 0 ? rq.normal : -rq.normal;
  // Retract by d_C to first contact, then advance X into the other by its deformation.
  p.modelX = glm::translate(glm::dmat4(1), n * (depth - rq.penetration)) * x.model;
  glm::dvec3 bx[2], bo[2];
  worldBounds(*x.mesh, p.modelX, bx);
  worldBounds(*other.mesh, other.model, bo);
  const AddressCamera cam = addressCamera(rq.point, n, bx, bo);
  const double range = cam.zFar - cam.zNear;
  p.vp = cam.projection * cam.view;
  SideUpdate& u = p.u;
  u.side = slot;
  u.resolution = x.surface->resolution();
  u.depthToHeight = static_cast<float>(range / x.surface->bumpDepth());
  u.bumpToDepth = static_cast<float>(x.surface->bumpDepthCollide() / range);
  u.tangent = o.tangent;
  u.tangentFloor = o.tangentFloor;
  u.viewNormal = glm::vec3(n);
  p.otherBumpToDepth = other.surface ? static_cast<float>(other.surface->bumpDepthCollide() / range) : 0.0f;
  // How far each body's bumps move its points in window depth at most (X's towards the camera, the other's away):
  // (h - 0.5) k' / range with h its map's highest (a flat map's bumps move nothing).
  auto raise = [](float highest, double bumpToDepth) { return (static_cast<double>(highest) - 0.5) * bumpToDepth; };
  const double raiseX = raise(x.surface->maps().highest, u.bumpToDepth);
  const double raiseOther = other.surface ? raise(other.surface->maps().highest, p.otherBumpToDepth) : 0.0;
  u.bumpReach = static_cast<float>(raiseX);
  // The cut's bound counts only the relief the contact did not feel: a body whose dents are felt had its dents
  // and rims measured (its image's relief not), so an overlap past them is a pose the contact never saw.
  const double unfeltX = raise(x.surface->unfeltHighest(), u.bumpToDepth);
  const double unfeltOther = other.surface ? raise(other.surface->unfeltHighest(), p.otherBumpToDepth) : 0.0;
  u.pushDepth = rq.boundByDepth ? static_cast<float>(depth / range + unfeltX + unfeltOther)
                                : 2.0f;  // window depths lie in [0, 1]
  // The other body's farthest window depth (its bounds, with its bumps): X's texels beyond it cannot dent.
  p.farthestOther = static_cast<float>(windowDepths(cam, bo).y + raiseOther + 1e-6);
  // X's nearest window depth (its bounds, raised by its bumps): the other body's depth must pass it to dent.
  const double nearest = windowDepths(cam, bx).x - raiseX - raiseOther;
  p.reachOther = static_cast<float>(nearest - 1e-6);
  return p;
}

void Deformer::Impl::gatherSlots(const DeformOptions& o, const std::vector<SidePlan>& p, std::vector<char>& rimsMade) {
  // Stage by stage over all sides (different targets): one barrier a stage for all of them.
  const int n = static_cast<int>(p.size());
  std::vector<ComputeGather::Side> sides;  // the compute gather's (it culls X's texel tiles before the raster)
  if (raster == AddressRaster::Compute) {
    // The last wave's gather read the targets (texture fetches) and its commit the buffers.
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
    for (int k = 0; k < n; ++k)
      if (p[k].active)
        sides.push_back({&p[k].u, p[k].x->mesh, &p[k].x->surface->height(), p[k].vp, p[k].modelX, p[k].farthestOther,
                         scratchFor(k, p[k].u.resolution)});
    if (!computeGather) computeGather.emplace();
    passes.clearReach(n);
    computeGather->cull(sides, passes.size(), passes.reach());
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    std::vector<AddressPasses::OtherPass> others;
    for (int k = 0; k < n; ++k)
      if (p[k].active) others.push_back({k, p[k].other, p[k].vp, p[k].other->model, p[k].reachOther, p[k].otherBumpToDepth});
    passes.rasterOthers(others, phaseMark);
  } else {
    for (int k = 0; k < n; ++k)
      if (p[k].active) passes.drawOther(k, *p[k].other, p[k].vp, p[k].other->model, p[k].otherBumpToDepth, true);
  }
  phase("address pass other");
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_FRAMEBUFFER_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  if (raster == AddressRaster::Compute) computeGather->gather(passes, region);  // X's texels in compute too
  for (int k = 0; k < n && raster != AddressRaster::Compute; ++k) {
    if (!p[k].active) continue;
    const DeformBody& x = *p[k].x;
    gather.run(p[k].u, *x.mesh, x.surface->height(), p[k].vp, p[k].modelX, passes, p[k].farthestOther,
               scratchFor(k, p[k].u.resolution), region);
  }
  glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  phase("gather (texels)");
  if (!o.craterRims) return;
  for (int k = 0; k < n; ++k) {  // waves of one event (slots 0 and 1) when rims are on
    if (!p[k].active) continue;
    rims.run(k, p[k].u.resolution, p[k].x->surface->height(), scratchFor(k, p[k].u.resolution), region);
    rimsMade[static_cast<size_t>(k)] = 1;
  }
}

bool Deformer::Impl::paperSide(const DeformOptions& o, const SidePlan& p) {
  const SideUpdate& u = p.u;
  const int side = u.side;
  const DeformBody& x = *p.x;
  const Scratch out = scratchFor(side, u.resolution);
  passes.drawX(side, x, p.vp, p.modelX, u.bumpToDepth, o.tangent != TangentMode::None);
  phase("address pass X");
  passes.drawOther(side, *p.other, p.vp, p.other->model, p.otherBumpToDepth, false);
  phase("address pass other");
  if (o.path == Path::Readback) {
    readback.run(u, passes, x.surface->height(), o.craterRims, out, region, phaseMark);
    return false;  // the CPU twin grew the region by the rim itself
  }
  scatter.run(u, passes, x.surface->height(), out, region);
  phase("update (compute)");
  if (!o.craterRims) return false;
  rims.run(side, u.resolution, x.surface->height(), out, region);
  return true;
}

void Deformer::Impl::runWave(const DeformOptions& o, const DeformRequest* const* events, size_t n, int* handles) {
  beginProfile(o.profile);
  ++waves;
  const int slots = static_cast<int>(2 * n);
  reserveSlots(slots);
  clearBoxes(region, slots);
  std::vector<SidePlan> plans(static_cast<size_t>(slots));
  std::vector<char> rimsMade(static_cast<size_t>(slots), 0);  // the commit region grows by their ring
  const gl::StateGuard callerState;  // the passes' viewports, framebuffers, programs and depth and cull state
  for (size_t e = 0; e < n; ++e) {
    handles[e] = allocateStats();
    const DeformRequest& rq = *events[e];
    for (int side = 0; side < 2; ++side) {
      const DeformBody& x = side == 0 ? rq.a : rq.b;
      const DeformBody& other = side == 0 ? rq.b : rq.a;
      const double depth = side == 0 ? rq.deformA : rq.deformB;
      if (!x.surface || !(depth > 0) || !x.mesh || !other.mesh) continue;
      const int slot = static_cast<int>(2 * e) + side;
      plans[static_cast<size_t>(slot)] = plan(o, side, slot, x, other, rq, depth);
      scratchFor(slot, x.surface->resolution());  // made on first use (cleared to untouched) before the passes
    }
  }
  phase("setup");
  if (o.path == Path::Gather) {
    gatherSlots(o, plans, rimsMade);
  } else {  // waves of one event
    for (int slot = 0; slot < slots; ++slot)
      if (plans[static_cast<size_t>(slot)].active)
        rimsMade[static_cast<size_t>(slot)] = paperSide(o, plans[static_cast<size_t>(slot)]);
  }
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | GL_COMMAND_BARRIER_BIT);
  // Commit every side only now, so that neither side of an event saw the other's new dent (stage by stage).
  std::vector<CommitPass::Side> commits(static_cast<size_t>(slots));
  for (int slot = 0; slot < slots; ++slot) {
    if (!plans[static_cast<size_t>(slot)].active) continue;
    const size_t e = static_cast<size_t>(slot / 2);
    Surface& x = *(slot % 2 == 0 ? events[e]->a : events[e]->b).surface;
    x.makeUnique();
    commits[static_cast<size_t>(slot)] = {&x, rimsMade[static_cast<size_t>(slot)] ? &rims.ring() : nullptr,
                                          scratchFor(slot, x.resolution()), handles[e] + slot % 2};
  }
  commit.run(commits, region, stats, changesMapped ? &changes : nullptr, phaseMark);
}

int Deformer::deform(const DeformRequest& rq) {
  const DeformRequest* one = &rq;
  int handle = -1;
  impl_->runWave(options_, &one, 1, &handle);
  return handle;
}

std::vector<int> Deformer::deform(const std::vector<DeformRequest>& requests) {
  Impl& m = *impl_;
  std::vector<int> handles(requests.size(), -1);
  const size_t limit = waveLimit();
  std::vector<const DeformRequest*> wave;
  std::vector<const Surface*> used;
  size_t first = 0;
  auto flush = [&] {
    if (wave.empty()) return;
    m.runWave(options_, wave.data(), wave.size(), handles.data() + first);
    first += wave.size();
    wave.clear();
    used.clear();
  };
  for (const DeformRequest& rq : requests) {
    const Surface* surfaces[2] = {rq.a.surface, rq.b.surface};
    bool clash = wave.size() >= limit;
    for (const Surface* x : surfaces)
      if (x && std::find(used.begin(), used.end(), x) != used.end()) clash = true;
    if (clash) flush();
    wave.push_back(&rq);
    for (const Surface* x : surfaces)
      if (x) used.push_back(x);
  }
  flush();
  return handles;
}

SideStats Deformer::stats(int handle, int side) {
  Impl& m = *impl_;
  SideStats s;
  if (handle < 0 || handle + side >= m.statsUsed) return s;
  if (m.statsRead < m.statsUsed) {
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    // Only the entries written since the last read (each event's are written once, by its commit).
    const size_t from = static_cast<size_t>(std::max(m.statsRead, 0)) * 4;
    m.statsHost.resize(static_cast<size_t>(m.statsUsed) * 4);
    glGetNamedBufferSubData(m.stats.id(), static_cast<GLintptr>(from * sizeof(GLuint)),
                            static_cast<GLsizeiptr>((m.statsHost.size() - from) * sizeof(GLuint)),
                            m.statsHost.data() + from);
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
