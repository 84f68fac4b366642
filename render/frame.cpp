// One frame of the renderer (Renderer::drawTo), a pass a function: the sun's frustum fitted around the items,
// the shadow map, the items (drawn in the fragment stage, or from a visibility buffer and shaded in compute), the
// sky behind them, the antialiasing.
#include <crumple/render/renderer_impl.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <glm/gtc/matrix_transform.hpp>

namespace crumple::render {

struct Renderer::Impl::Frame {
  Frame(Impl& impl, const RendererSettings& settings, const std::vector<RenderItem>& items_, const View& view_,
        RendererStats& stats_, const std::function<void(const char*)>& marker_, int width_, int height_)
      : m(impl), s(settings), items(items_), view(view_), stats(stats_), marker(marker_), width(width_),
        height(height_) {}
  Impl& m;
  const RendererSettings& s;
  const std::vector<RenderItem>& items;
  const View& view;
  RendererStats& stats;
  const std::function<void(const char*)>& marker;
  int width, height;
  bool fxaa = false, msaa = false, compute = false;
  glm::vec3 sunDir{0};
  glm::mat4 lightVP{1}, vp{1};
  float aspect = 1;
  PomFeatures features;          // the frame's part of every item's
  std::vector<GLuint> prepared;  // the programs given the frame's uniforms this frame
  GLuint current = 0;            // the program in use

  void draw(GLuint finalTarget);
  void mark(const char* part) const {
    if (marker) marker(part);
  }
  bool computeShaded();
  void fitSun();
  void drawShadowMap();
  void drawAddressView();
  void listVisible();
  void use(const PomProgram& p);
  void bindItem(const PomProgram& p, const RenderItem& it);
  PomFeatures itemFeatures(const RenderItem& it, bool displaced) const;
  bool displaced(const RenderItem& it) const {
    return (s.displace || view.displace) && it.height && s.debug != DebugView::Wireframe;
  }
  void shadeInCompute(GLuint target);
  void drawItems();
  void drawSky();
  void finish(GLuint finalTarget);
};

void Renderer::drawTo(GLuint finalTarget, const std::vector<RenderItem>& items, const View& view) {
  stats_ = {};
  Impl::Frame frame{*impl_, settings_, items, view, stats_, mark_, width_, height_};
  frame.draw(finalTarget);
}

void Renderer::Impl::Frame::draw(GLuint finalTarget) {
  // The shaded view draws into sceneFbo when antialiased, filtered into the target at the end.
  fxaa = s.antialias == Antialias::Fxaa && s.debug == DebugView::Shaded;
  msaa = s.antialias == Antialias::Msaa && s.debug == DebugView::Shaded;
  compute = computeShaded();
  stats.computeShaded = compute;
  const GLuint target = fxaa || compute ? m.sceneFbo.id() : msaa ? m.multisampled(width, height) : finalTarget;
  fitSun();
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  if (s.ibl && s.debug == DebugView::Shaded) m.prepareLight(s);
  mark("light");
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  if (s.shadows && s.debug == DebugView::Shaded) drawShadowMap();
  mark("shadow map");

  glBindFramebuffer(GL_FRAMEBUFFER, target);
  glViewport(0, 0, width, height);
  glEnable(GL_FRAMEBUFFER_SRGB);
  const glm::vec3 sky = glm::pow(glm::vec3(0.62f, 0.72f, 0.85f), glm::vec3(2.2f));
  glClearColor(sky.r, sky.g, sky.b, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  if (s.debug == DebugView::Address) {
    drawAddressView();
    return;
  }
  aspect = static_cast<float>(width) / static_cast<float>(height);
  const glm::mat4 viewM = glm::lookAt(view.eye, view.target, view.up);
  const glm::mat4 proj = glm::perspective(glm::radians(view.fovDegrees), aspect, view.zNear, view.zFar);
  vp = proj * viewM;
  features.mode = static_cast<int>(s.parallax);
  features.debug = static_cast<int>(s.debug);
  features.shadows = s.shadows && s.debug == DebugView::Shaded;
  features.selfShadow = s.selfShadow;
  features.ibl = s.ibl;
  gl::bindTexture(pom::kShadowMap, m.shadowMap.id());
  gl::bindTexture(pom::kPrefiltered, m.prefiltered.id());
  gl::bindTexture(pom::kIrradiance, m.irradiance.id());
  gl::bindTexture(pom::kBrdfLut, m.lut.id());
  if (s.debug == DebugView::Wireframe) glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
  glVertexAttrib3f(3, 1.0f, 1.0f, 1.0f);  // the colour of vertex arrays without one: white
  listVisible();
  if (compute)
    shadeInCompute(target);
  else
    drawItems();
  glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
  mark("items");
  if (s.debug == DebugView::Shaded) drawSky();
  mark("sky");
  finish(finalTarget);
}

// Shading in compute from a visibility buffer (RendererSettings::shading): the shaded view without MSAA, no
// displaced item, every item's vertices in GpuMesh's layout. It writes sceneColor: FXAA filters it into the
// target, or without antialiasing a blit copies it there.
bool Renderer::Impl::Frame::computeShaded() {
  bool yes = (s.shading == Shading::Compute || (s.shading == Shading::Auto && m.fewGraphicsUnits)) && !msaa &&
             s.debug == DebugView::Shaded;
  std::vector<Impl::MeshBuffers>& buffers = m.itemBuffers;  // each item's, asked of GL once a frame
  buffers.clear();
  for (size_t i = 0; yes && i < items.size(); ++i) {
    buffers.push_back(m.meshBuffers(itemVao(items[i], s)));
    yes = !((s.displace || view.displace) && items[i].height) && buffers.back().vertices != 0;
  }
  return yes;
}

// The sun's orthographic frustum, fitted around everything.
void Renderer::Impl::Frame::fitSun() {
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const auto& it : items) {
    for (int c = 0; c < 8; ++c) {
      const glm::vec3 p(c & 1 ? it.boundsMax.x : it.boundsMin.x, c & 2 ? it.boundsMax.y : it.boundsMin.y,
                        c & 4 ? it.boundsMax.z : it.boundsMin.z);
      const glm::vec3 w = glm::vec3(it.model * glm::vec4(p, 1));
      lo = glm::min(lo, w);
      hi = glm::max(hi, w);
    }
  }
  if (items.empty()) lo = hi = glm::vec3(0);
  // The box it is fitted to is kept while everything stays inside it and it is not much larger (so the
  // shadow map of the still casters stays valid while bodies move about in it); refitted with a margin.
  const float fitRadius = std::max(0.5f * glm::length(hi - lo), 0.5f);
  const bool inside = glm::all(glm::greaterThanEqual(lo, m.sunFitLo)) && glm::all(glm::lessThanEqual(hi, m.sunFitHi));
  if (!inside || 0.5f * glm::length(m.sunFitHi - m.sunFitLo) > 1.1f * fitRadius) {
    m.sunFitLo = lo - glm::vec3(0.02f * fitRadius);
    m.sunFitHi = hi + glm::vec3(0.02f * fitRadius);
  }
  const glm::vec3 centre = 0.5f * (m.sunFitLo + m.sunFitHi);
  const float radius = std::max(0.5f * glm::length(m.sunFitHi - m.sunFitLo), 0.5f);
  sunDir = glm::normalize(s.sunDirection);
  const glm::vec3 sunUp = std::abs(sunDir.y) > 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  const glm::mat4 lightView = glm::lookAt(centre - sunDir * radius * 2.0f, centre, sunUp);
  const glm::mat4 lightProj = glm::ortho(-radius, radius, -radius, radius, 0.01f, radius * 4.0f);
  lightVP = lightProj * lightView;
}

// The sun's shadow map: the still casters from the cache (ShadowCache), the moving ones drawn over them.
void Renderer::Impl::Frame::drawShadowMap() {
  m.shadow.use();
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(2.0f, 4.0f);
  glViewport(0, 0, kShadowSize, kShadowSize);
  // Draws the items whose `still` flag is `which` (all of them without a cache).
  auto drawCasters = [&](bool cached, bool which) {
    for (size_t i = 0; i < items.size(); ++i) {
      if (cached && m.shadowCache.casters[i].still != which) continue;
      const RenderItem& it = items[i];
      ++stats.shadowCasters;
      const glm::mat4 mvp = lightVP * it.model;
      m.shadowMvp.set(mvp);
      glBindVertexArray(casterVao(it, s));
      glDrawElements(GL_TRIANGLES, casterIndexCount(it, s), GL_UNSIGNED_INT, nullptr);
    }
  };
  ShadowCache& cache = m.shadowCache;
  if (cache.update(items, s, lightVP)) {
    glBindFramebuffer(GL_FRAMEBUFFER, cache.stillFbo.id());
    glClear(GL_DEPTH_BUFFER_BIT);
    drawCasters(true, true);
    stats.shadowCacheRedrawn = true;
    cache.dirty = {0, 0, kShadowSize, kShadowSize};
  }
  glBindFramebuffer(GL_FRAMEBUFFER, m.shadowFbo.id());
  if (cache.valid) {
    const glm::ivec4 d = cache.dirty;
    if (d.z > d.x && d.w > d.y)
      glCopyImageSubData(cache.still.id(), GL_TEXTURE_2D, 0, d.x, d.y, 0, m.shadowMap.id(), GL_TEXTURE_2D, 0, d.x,
                         d.y, 0, d.z - d.x, d.w - d.y, 1);
    cache.dirty = cache.moversRect(items, lightVP);
    drawCasters(true, false);
  } else {
    glClear(GL_DEPTH_BUFFER_BIT);
    drawCasters(false, false);
    cache.dirty = {0, 0, kShadowSize, kShadowSize};
  }
  glDisable(GL_POLYGON_OFFSET_FILL);
}

// The address-map debug view: the map alone, over the whole frame.
void Renderer::Impl::Frame::drawAddressView() {
  m.addressView.use();
  gl::bindTexture(kSource, s.addressMap ? s.addressMap : m.flatHeight.id());
  glDisable(GL_DEPTH_TEST);
  glBindVertexArray(m.emptyVao.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_FRAMEBUFFER_SRGB);
}

// The items to draw (m.visible), front to back (by the distance of each item's bounds' centre from the eye; equal
// distances in the given order): the depth test then rejects hidden fragments before the parallax march runs on
// them (pom.frag writes no depth nearer than the mesh and discards nothing, so early depth testing holds).
// Items wholly outside the view are dropped (displaced ones with their bounds grown by the map's range).
void Renderer::Impl::Frame::listVisible() {
  std::vector<std::pair<float, size_t>>& order = m.drawOrder;  // kept: no allocation a frame
  order.resize(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    const glm::vec3 c = glm::vec3(items[i].model * glm::vec4(0.5f * (items[i].boundsMin + items[i].boundsMax), 1.0f));
    order[i] = {glm::dot(c - view.eye, c - view.eye), i};
  }
  std::stable_sort(
      order.begin(), order.end(),
      [](const std::pair<float, size_t>& a, const std::pair<float, size_t>& b) { return a.first < b.first; });
  std::vector<size_t>& visible = m.visible;
  visible.clear();
  for (const auto& [distance, index] : order) {
    const RenderItem& it = items[index];
    const glm::vec3 grow(displaced(it) ? it.bumpDepth : 0.0f);
    if (outsideClip(vp * it.model, it.boundsMin - grow, it.boundsMax + grow)) {
      ++stats.culled;
      continue;
    }
    ++stats.drawn;
    visible.push_back(index);
  }
}

// `p` in use; the frame's uniforms given to it the first time this frame that it draws.
void Renderer::Impl::Frame::use(const PomProgram& p) {
  p.program.use();
  current = p.program.id();
  if (std::find(prepared.begin(), prepared.end(), p.program.id()) != prepared.end()) return;
  prepared.push_back(p.program.id());
  p.viewProjection.set(vp);
  p.lightViewProjection.set(lightVP);
  p.eye.set(view.eye);
  p.toSun.set(-sunDir);
  p.sunColor.set(s.sunColor);
  p.skyColor.set(s.skyColor);
  p.groundColor.set(s.groundColor);
  p.exposure.set(s.exposure);
  p.prefilteredMaxLod.set(static_cast<float>(kPrefilterLevels - 1));
  p.minSteps.set(s.minSteps);
  p.maxSteps.set(s.maxSteps);
  p.lodFade.set(glm::vec2(s.lodFadeStart, s.lodFadeEnd));
  // The displaced path's tessellation.
  p.viewport.set(glm::vec2(static_cast<float>(width), static_cast<float>(height)));
  p.segmentPixels.set(std::max(s.displaceSegmentPixels, 0.5f));
  p.pixelAngle.set(2.0f * std::tan(glm::radians(view.fovDegrees) * 0.5f) / static_cast<float>(height));
  p.maxLevel.set(32.0f);  // llvmpipe drew torn, flickering faces at 64
}

// The item's own uniforms and maps, in either path's program.
void Renderer::Impl::Frame::bindItem(const PomProgram& p, const RenderItem& it) {
  p.model.set(it.model);
  p.normalMatrix.set(glm::transpose(glm::inverse(glm::mat3(it.model))));
  p.bumpDepth.set(it.bumpDepth);
  p.color.set(it.color);
  p.metallic.set(it.metallic);
  p.roughness.set(it.roughness);
  p.worldToModel.set(glm::inverse(it.model));
  p.textureScale.set(it.textureScale);
  m.bindLook(p, it);
  gl::bindTexture(pom::kHeight, it.height ? it.height : m.flatHeight.id());
  gl::bindTexture(pom::kNormalMap, it.normal ? it.normal : m.flatNormal.id());
  gl::bindTexture(pom::kHeightBound, it.height && it.heightBound ? it.heightBound : m.noBound.id());
  p.boundTile.set(it.height && it.heightBound ? it.boundTile : 1 << 20);
}

PomFeatures Renderer::Impl::Frame::itemFeatures(const RenderItem& it, bool displaced) const {
  PomFeatures f = features;
  f.maps = it.height != 0;
  f.look = it.look != nullptr && it.look->materialCount() > 0;
  f.texture = static_cast<int>(it.texture);
  f.displaced = displaced;
  return f;
}

// The visibility pass (the item and triangle nearest at each pixel, into the frame's depth), then each item's
// pixels shaded over its rectangle on screen.
void Renderer::Impl::Frame::shadeInCompute(GLuint target) {
  m.visibilityFbo.bind();
  const GLuint none[4] = {0xffffffffu, 0, 0, 0};
  const float far = 1.0f;
  glClearNamedFramebufferuiv(m.visibilityFbo.id(), GL_COLOR, 0, none);
  glClearNamedFramebufferfv(m.visibilityFbo.id(), GL_DEPTH, 0, &far);
  mark("visibility clear");
  for (size_t index : m.visible) {
    const RenderItem& it = items[index];
    if (it.height && features.mode == static_cast<int>(ParallaxMode::Occlusion)) {
      // A bump-mapped item at the depth its parallax march finds (what rests in a dent is seen in it), its
      // shading features left out (they shade nothing here: fewer variants).
      PomFeatures f = itemFeatures(it, false);
      f.look = f.shadows = f.selfShadow = f.ibl = false;
      f.texture = 0;
      const PomProgram& p = m.pomVisibility(f);
      if (p.program.id() != current) use(p);
      bindItem(p, it);
      p.item.set(static_cast<GLuint>(index));
    } else {
      if (current != m.visibility.id()) {
        m.visibility.use();
        current = m.visibility.id();
      }
      m.visibilityMvp.set(vp * it.model);
      m.visibilityItem.set(static_cast<GLuint>(index));
    }
    glBindVertexArray(itemVao(it, s));  // the simplified mesh where the settings ask for it
    glDrawElements(GL_TRIANGLES, itemIndexCount(it, s), GL_UNSIGNED_INT, nullptr);
  }
  mark("visibility");  // (a profile's "items" is then the shading alone)
  const glm::mat4 inverseVp = glm::inverse(vp);
  gl::bindTexture(pom::kVisibilityIds, m.visibilityIds.id());
  gl::bindImage(pom::kShaded, m.sceneColorView.id(), GL_WRITE_ONLY, GL_RGBA8);
  for (size_t index : m.visible) {
    const RenderItem& it = items[index];
    const PomProgram& p = m.pomCompute(itemFeatures(it, false));
    if (p.program.id() != current) {
      use(p);
      p.invViewProjection.set(inverseVp);
      p.frameSize.set(glm::ivec2(width, height));
    }
    bindItem(p, it);
    const glm::ivec4 rect = screenRect(vp * it.model, it.boundsMin, it.boundsMax, width, height);
    if (rect.z <= 0 || rect.w <= 0) continue;
    p.item.set(static_cast<GLuint>(index));
    p.rect.set(rect);
    const Impl::MeshBuffers& b = m.itemBuffers[index];
    gl::bindStorage(pom::kVertices, b.vertices);
    gl::bindStorage(pom::kIndices, b.indices);
    glDispatchCompute(static_cast<GLuint>((rect.z + 7) / 8), static_cast<GLuint>((rect.w + 7) / 8), 1);
  }
  glMemoryBarrier(GL_FRAMEBUFFER_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  glBindFramebuffer(GL_FRAMEBUFFER, target);
}

// The items in the fragment stage: parallax occlusion, or displaced geometry (tessellated) where asked.
void Renderer::Impl::Frame::drawItems() {
  for (size_t index : m.visible) {
    const RenderItem& it = items[index];
    const bool displace = displaced(it);
    const PomProgram& p = m.pom(itemFeatures(it, displace));
    if (p.program.id() != current) use(p);
    bindItem(p, it);
    if (displace) {
      const bool seams = it.seamEdges && it.seamVertices;
      p.seams.set(seams ? 1 : 0);
      if (seams) {
        gl::bindStorage(pom::kSeamEdges, it.seamEdges);
        gl::bindStorage(pom::kSeamVertices, it.seamVertices);
      }
      const bool creased = it.vertexNodes && it.crease;
      p.creased.set(creased ? 1 : 0);
      if (creased) {
        gl::bindStorage(pom::kVertexNodes, it.vertexNodes);
        gl::bindStorage(pom::kCrease, it.crease);
      }
      p.metresPerUv.set(it.metresPerUv);
      gl::bindSampler(pom::kHeight, m.displacedHeight.id());
      glBindVertexArray(it.vao);
      glPatchParameteri(GL_PATCH_VERTICES, 3);
      glDrawElements(GL_PATCHES, it.indexCount, GL_UNSIGNED_INT, nullptr);
      gl::bindSampler(pom::kHeight, 0);
    } else {
      glBindVertexArray(itemVao(it, s));
      glDrawElements(GL_TRIANGLES, itemIndexCount(it, s), GL_UNSIGNED_INT, nullptr);
    }
  }
}

// The sky behind everything: only the pixels still at the far plane run it.
void Renderer::Impl::Frame::drawSky() {
  m.sky.use();
  m.setSkyUniforms(s);
  const glm::vec3 fwd = glm::normalize(view.target - view.eye);
  const glm::vec3 right = glm::normalize(glm::cross(fwd, view.up));
  const glm::vec3 up = glm::cross(right, fwd);
  const float tanY = std::tan(glm::radians(view.fovDegrees) * 0.5f);
  const glm::mat3 basis(right * tanY * aspect, up * tanY, fwd);
  m.skyUniforms.basis.set(basis);
  m.skyUniforms.background.set(1);
  m.skyUniforms.exposure.set(s.exposure);
  glDepthFunc(GL_LEQUAL);
  glDepthMask(GL_FALSE);
  glBindVertexArray(m.emptyVao.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);
}

// Antialiasing (FXAA or the MSAA resolve) or the compute path's copy into the target; the state left clean.
void Renderer::Impl::Frame::finish(GLuint finalTarget) {
  if (fxaa) m.antialias(finalTarget, width, height);
  if (msaa) m.resolve(finalTarget, width, height);
  if (compute && !fxaa)  // sRGB decoded and encoded again (as the fragment stage's writes into the target are)
    glBlitNamedFramebuffer(m.sceneFbo.id(), finalTarget, 0, 0, width, height, 0, 0, width, height,
                           GL_COLOR_BUFFER_BIT, GL_NEAREST);
  mark("antialias");
  glDisable(GL_FRAMEBUFFER_SRGB);
  // The shadow map compares depths: a later program's plain sampler on its unit would meet it (NVIDIA flags the
  // state as undefined behaviour even where the sampler reads nothing), so it is not left bound.
  gl::bindTexture(pom::kShadowMap, 0);
}

}  // namespace crumple::render
