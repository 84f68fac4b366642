// The parallax-occlusion renderer on llvmpipe: golden images, dents that show
// while the silhouette stays, self-shadowing inside a deep dent.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>

#include <crumple/deform/deformer.h>
#include <crumple/engine/primitives.h>
#include <crumple/engine/scene_view.h>
#include <crumple/engine/simulation.h>
#include "gl_fixture.h"
#include <crumple/render/renderer.h>

using namespace crumple;
using namespace crumple::gl;
using namespace crumple::render;

namespace {

struct Stage {
  TriangleMesh plateMesh = boxMesh({2, 0.2, 2}, 256);
  TriangleMesh ballMesh = sphereMesh(0.25, 128);
  std::shared_ptr<deform::GpuMesh> plateGpu = std::make_shared<deform::GpuMesh>(plateMesh);
  std::shared_ptr<deform::GpuMesh> ballGpu = std::make_shared<deform::GpuMesh>(ballMesh);
  deform::Deformer deformer{{256, deform::Path::Gather}};
  std::unique_ptr<deform::Surface> plate;
  Stage(const Image* initial = nullptr) {
    const float texel = static_cast<float>(plateGpu->metresPerUv / 256);
    plate =
        std::make_unique<deform::Surface>(plateGpu, 256, 0.1f, 0.02f, deformer.createMaps(256, initial, 0.1f, texel));
  }
  void dent(double depth, glm::dvec3 at = {0, 0, 0}) {
    deform::DeformRequest rq;
    rq.a = {plate.get(), plateGpu.get(), glm::dmat4(1)};
    rq.b = {nullptr, ballGpu.get(), glm::translate(glm::dmat4(1), at + glm::dvec3(0, 0.1 + 0.25, 0))};
    rq.point = at + glm::dvec3(0, 0.1, 0);
    rq.normal = {0, 1, 0};
    rq.deformA = depth;
    deformer.deform(rq);
  }
  std::vector<RenderItem> items(bool withBall, glm::vec3 ballAt = {0.6f, 0.35f, -0.5f}) const {
    std::vector<RenderItem> v;
    RenderItem p;
    p.vao = plateGpu->vao.id();
    p.indexCount = plateGpu->indexCount;
    p.height = plate->height().id();
    p.normal = plate->normal().id();
    p.heightBound = plate->maps().bound.id();
    p.boundTile = deform::SurfaceMaps::kBoundTile;
    p.color = {0.72f, 0.55f, 0.42f};
    p.boundsMin = plateGpu->boundsMin;
    p.boundsMax = plateGpu->boundsMax;
    v.push_back(p);
    if (withBall) {
      RenderItem b;
      b.vao = ballGpu->vao.id();
      b.indexCount = ballGpu->indexCount;
      b.model = glm::translate(glm::mat4(1), ballAt);
      b.color = {0.8f, 0.8f, 0.85f};
      b.boundsMin = ballGpu->boundsMin;
      b.boundsMax = ballGpu->boundsMax;
      v.push_back(b);
    }
    return v;
  }
};

View topView() {
  View v;
  v.eye = {0.0f, 1.6f, 1.4f};
  v.target = {0, 0, 0};
  v.fovDegrees = 40;
  return v;
}

// Fraction of pixels whose channels differ by more than 5/255.
double fractionOff(const Image& a, const Image& b) {
  long off = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      bool bad = false;
      for (int c = 0; c < 3; ++c) bad = bad || std::abs(a.at(x, y, c) - b.at(x, y, c)) > 5.0f / 255.0f;
      off += bad;
    }
  return static_cast<double>(off) / (a.width * a.height);
}

float luma(const Image& img, int x, int y) {
  return 0.299f * img.at(x, y, 0) + 0.587f * img.at(x, y, 1) + 0.114f * img.at(x, y, 2);
}

// The darkest and brightest luma of the 3x3 neighbourhood of (x, y).
void neighbourhood(const Image& img, int x, int y, float& lo, float& hi) {
  lo = 1;
  hi = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      lo = std::min(lo, luma(img, x + dx, y + dy));
      hi = std::max(hi, luma(img, x + dx, y + dy));
    }
}

// Of the pixels on an edge of `edges` (a step of 0.08 within their 3x3 neighbourhood), the share whose value
// in `img` lies between its two sides: partly covered pixels. An aliased edge has almost none; a smoothed
// staircase has many. `count`: how many edge pixels there were.
double edgeShare(const Image& img, const Image& edges, long* count = nullptr) {
  long edge = 0, mid = 0;
  for (int y = 1; y + 1 < img.height; ++y)
    for (int x = 1; x + 1 < img.width; ++x) {
      float lo, hi;
      neighbourhood(edges, x, y, lo, hi);
      if (hi - lo < 0.08f) continue;
      ++edge;
      const float t = (luma(img, x, y) - lo) / (hi - lo);
      mid += t > 0.2f && t < 0.8f;
    }
  if (count) *count = edge;
  return static_cast<double>(mid) / std::max(edge, 1L);
}

void compareGolden(const Image& img, const std::string& name) {
  const std::string path = std::string(CRUMPLE_GOLDEN_DIR) + "/" + name;
  if (std::getenv("CRUMPLE_UPDATE_GOLDEN")) {
    writePng(path, img, 8);
    MESSAGE("golden image rewritten: " << path);
    return;
  }
  REQUIRE_MESSAGE(std::filesystem::exists(path),
                  "missing golden image " << path << " (tools/update-golden.sh makes it)");
  const Image ref = readPng(path, 3);
  REQUIRE(ref.width == img.width);
  REQUIRE(ref.height == img.height);
  const double off = fractionOff(img, ref);
  MESSAGE(name << ": " << off * 100 << "% of pixels off by more than 5/255");
  CHECK(off <= 0.001);
}

Image bumpPattern(int n) {
  Image img(n, n, 1, 0.5f);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const float u = (x + 0.5f) / n, v = (y + 0.5f) / n;
      img.at(x, y) = 0.5f + 0.35f * std::sin(u * 60.0f) * std::sin(v * 60.0f);
    }
  return img;
}

}  // namespace

TEST_CASE("golden images: shaded, height and normal views") {
  test::glContext();
  const Image pattern = bumpPattern(256);
  Stage s(&pattern);
  s.dent(0.03, {0.3, 0, 0.2});
  Renderer r(192, 128);
  r.draw(s.items(true), topView());
  compareGolden(r.readPixels(), "pom_shaded.png");
  r.settings().debug = DebugView::Height;
  r.draw(s.items(true), topView());
  compareGolden(r.readPixels(), "pom_height.png");
  r.settings().debug = DebugView::Normal;
  r.draw(s.items(true), topView());
  compareGolden(r.readPixels(), "pom_normal.png");
  r.settings().debug = DebugView::Shaded;
  r.settings().parallax = ParallaxMode::OffsetLimited;
  r.draw(s.items(true), topView());
  compareGolden(r.readPixels(), "pom_offset_limited.png");
}

TEST_CASE("a frame leaves its shadow map (a depth texture compared on sampling) bound to no texture unit") {
  // A later program with a plain sampler on that unit (the deformer's) would meet it: undefined behaviour, which
  // NVIDIA's driver reports.
  test::glContext();
  Stage s;
  Renderer r(96, 64);
  r.draw(s.items(false), topView());
  GLint units = 0;
  glGetIntegerv(GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS, &units);
  int comparing = 0;
  for (GLint unit = 0; unit < std::min(units, 32); ++unit) {
    glActiveTexture(static_cast<GLenum>(GL_TEXTURE0 + unit));
    GLint texture = 0;
    glGetIntegerv(GL_TEXTURE_BINDING_2D, &texture);
    if (texture == 0) continue;
    GLint mode = GL_NONE;
    glGetTextureParameteriv(static_cast<GLuint>(texture), GL_TEXTURE_COMPARE_MODE, &mode);
    comparing += mode == GL_COMPARE_REF_TO_TEXTURE;
  }
  glActiveTexture(GL_TEXTURE0);
  CHECK(comparing == 0);
}

TEST_CASE("a dent shows in the pixels while the silhouette stays the same") {
  test::glContext();
  Stage s;
  Renderer r(160, 120);
  r.draw(s.items(false), topView());
  const Image before = r.readPixels();
  r.settings().debug = DebugView::Wireframe;
  r.draw(s.items(false), topView());
  const Image wireBefore = r.readPixels();
  r.settings().debug = DebugView::Shaded;

  s.dent(0.03);
  r.draw(s.items(false), topView());
  const Image after = r.readPixels();
  r.settings().debug = DebugView::Wireframe;
  r.draw(s.items(false), topView());
  const Image wireAfter = r.readPixels();

  // The plate's centre (0, 0.1, 0) projects near the middle of the image.
  int changedCentre = 0, changedFar = 0;
  for (int y = 0; y < after.height; ++y)
    for (int x = 0; x < after.width; ++x) {
      bool diff = false;
      for (int c = 0; c < 3; ++c) diff = diff || std::abs(after.at(x, y, c) - before.at(x, y, c)) > 2.0f / 255.0f;
      const bool centre = std::abs(x - after.width / 2) < 20 && std::abs(y - after.height / 2) < 16;
      (centre ? changedCentre : changedFar) += diff;
    }
  MESSAGE("changed pixels near the dent: " << changedCentre << ", elsewhere: " << changedFar);
  CHECK(changedCentre > 40);
  CHECK(changedFar < changedCentre);
  CHECK(fractionOff(wireBefore, wireAfter) == 0.0);  // the mesh did not change
}

TEST_CASE("the height bound pyramid holds each tile's largest deviation, and skipping flat rays changes no pixel") {
  test::glContext();
  Stage s;
  s.dent(0.03, {0.5, 0, 0.3});
  s.dent(0.02, {-0.6, 0, -0.4});
  const deform::SurfaceMaps& maps = s.plate->maps();
  const Image height = s.plate->downloadHeight();
  const int tile = deform::SurfaceMaps::kBoundTile;
  REQUIRE(maps.bound.height() == 16);  // 256 texels in tiles of 16
  REQUIRE(maps.bound.width() == 24);   // the levels above level 0 beside it
  REQUIRE(maps.boundLevels() == 5);
  std::vector<float> atlas(24 * 16);
  glGetTextureImage(maps.bound.id(), 0, GL_RED, GL_FLOAT, static_cast<GLsizei>(atlas.size() * 4), atlas.data());
  std::vector<std::vector<float>> levels;
  for (int level = 0; level < maps.boundLevels(); ++level) {
    const int n = 16 >> level;
    const glm::ivec2 o = deform::SurfaceMaps::boundOrigin(16, level);
    levels.emplace_back(static_cast<size_t>(n) * n);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) levels.back()[static_cast<size_t>(y) * n + x] = atlas[static_cast<size_t>(o.y + y) * 24 + o.x + x];
  }
  // The levels do not overlap: each texel of the atlas belongs to one level at most.
  std::vector<int> owners(atlas.size(), 0);
  for (int level = 0; level < maps.boundLevels(); ++level) {
    const glm::ivec2 o = deform::SurfaceMaps::boundOrigin(16, level);
    for (int y = 0; y < (16 >> level); ++y)
      for (int x = 0; x < (16 >> level); ++x) ++owners[static_cast<size_t>(o.y + y) * 24 + o.x + x];
  }
  CHECK(*std::max_element(owners.begin(), owners.end()) == 1);
  int dented = 0, flat = 0;
  for (int ty = 0; ty < 16; ++ty)
    for (int tx = 0; tx < 16; ++tx) {
      float m = 0;
      for (int y = ty * tile; y < (ty + 1) * tile; ++y)
        for (int x = tx * tile; x < (tx + 1) * tile; ++x) m = std::max(m, std::abs(height.at(x, y) - 0.5f));
      CHECK(levels[0][static_cast<size_t>(ty) * 16 + tx] == m);
      (m > 0 ? dented : flat)++;
    }
  MESSAGE("tiles dented: " << dented << ", flat: " << flat);
  CHECK(dented > 2);
  CHECK(flat > dented);
  for (size_t level = 1; level < levels.size(); ++level) {
    const int n = 16 >> level;
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        auto below = [&](int dx, int dy) { return levels[level - 1][static_cast<size_t>(2 * y + dy) * (2 * n) + 2 * x + dx]; };
        CHECK(levels[level][static_cast<size_t>(y) * n + x] ==
              std::max(std::max(below(0, 0), below(1, 0)), std::max(below(0, 1), below(1, 1))));
      }
  }
  // The same frames with every ray marched (no bound), from above and at a grazing angle, self-shadowing on.
  Renderer r(200, 150);
  r.settings().sunDirection = glm::normalize(glm::vec3(-1.0f, -0.4f, 0.2f));
  View grazing = topView();
  grazing.eye = {0.0f, 0.35f, 2.2f};
  for (const View& view : {topView(), grazing}) {
    std::vector<RenderItem> items = s.items(true);
    r.draw(items, view);
    const Image skipping = r.readPixels();
    items[0].heightBound = 0;
    r.draw(items, view);
    const Image marching = r.readPixels();
    float worst = 0;
    for (size_t i = 0; i < skipping.pixels.size(); ++i)
      worst = std::max(worst, std::abs(skipping.pixels[i] - marching.pixels[i]));
    MESSAGE("largest difference, skipping vs marching every ray: " << worst * 255 << "/255");
    CHECK(worst <= 1.0f / 255.0f + 1e-6f);
  }
  // The shader does skip by the bound: a pyramid of zeros (a false one) hides the dents' parallax.
  Texture2D zeros(24, 16, GL_R32F);  // the pyramid's 5 levels side by side
  const float zero = 0.0f;
  glClearTexImage(zeros.id(), 0, GL_RED, GL_FLOAT, &zero);
  std::vector<RenderItem> items = s.items(false);
  r.draw(items, topView());
  const Image marched = r.readPixels();
  items[0].heightBound = zeros.id();
  r.draw(items, topView());
  const double hidden = fractionOff(marched, r.readPixels());
  MESSAGE("pixels changed by a false zero bound: " << hidden * 100 << "%");
  CHECK(hidden > 0.002);
}

TEST_CASE("self-shadowing: a deep dent lit at a grazing angle has shadowed texels inside it") {
  test::glContext();
  Stage s;
  s.dent(0.045);
  Renderer r(160, 120);
  r.settings().sunDirection = glm::normalize(glm::vec3(-1.0f, -0.25f, 0.0f));  // low sun from +x
  r.settings().shadows = false;
  // Shading alone: FXAA after it may brighten a pixel by blending in a neighbour (seen once on an NVIDIA GPU).
  r.settings().antialias = Antialias::None;
  r.draw(s.items(false), topView());
  const Image lit = [&] {
    r.settings().selfShadow = false;
    r.draw(s.items(false), topView());
    return r.readPixels();
  }();
  r.settings().selfShadow = true;
  r.draw(s.items(false), topView());
  const Image shadowed = r.readPixels();
  int darker = 0, brighter = 0;
  for (size_t i = 0; i < lit.pixels.size(); i += 3) {
    const float a = lit.pixels[i] + lit.pixels[i + 1] + lit.pixels[i + 2];
    const float b = shadowed.pixels[i] + shadowed.pixels[i + 1] + shadowed.pixels[i + 2];
    darker += b < a - 0.05f;
    brighter += b > a + 0.01f;
  }
  MESSAGE("pixels darkened by self-shadowing: " << darker);
  CHECK(darker > 20);
  CHECK(brighter == 0);
}

TEST_CASE("tracked vehicle: wheels and belts are drawn, and the grousers keep their place on the ground") {
  test::glContext();
  Simulation sim(loadScene(std::string(CRUMPLE_SCENES) + "/tank-tracks.json"), true);
  REQUIRE(sim.vehicles().size() == 1);
  const VehicleRuntime& tank = sim.vehicles().front();
  // 8 wheels, and a belt and its grousers on each side, all among the render items.
  CHECK(sim.vehicleParts().size() == 12);
  CHECK(renderItems(sim).size() == sim.bodies().size() + 12);
  for (int s = 0; s < 240; ++s) sim.step();  // settled and under way
  const double pitch = tank.pitch;
  auto phase = [&] { return std::fmod(sim.treadModel(tank, 0, true)[3].x, pitch); };
  const double belt0 = sim.treadModel(tank, 0, false)[3].x, phase0 = phase();
  for (int s = 0; s < 48; ++s) {
    sim.step();
    double d = std::abs(phase() - phase0);
    d = std::min(d, pitch - d);  // around the pitch
    CHECK(d < 0.01 * pitch);
  }
  // Meanwhile the belt went on with the body, more than a pitch.
  CHECK(sim.treadModel(tank, 0, false)[3].x - belt0 > pitch);
}

TEST_CASE("FXAA: edges are smoothed, flat areas keep their pixels, and it can be turned off") {
  test::glContext();
  Stage s;
  s.dent(0.03, {0.3, 0, 0.2});
  Renderer r(192, 128);
  View v = topView();
  v.eye = {0.9f, 1.2f, 1.9f};  // the plate's edges slanted against the sky, the ball's silhouette round
  CHECK(r.settings().antialias == Antialias::Fxaa);  // on by default
  r.settings().antialias = Antialias::None;
  r.draw(s.items(true), v);
  const Image off = r.readPixels();
  r.settings().antialias = Antialias::Fxaa;
  r.draw(s.items(true), v);
  const Image on = r.readPixels();
  long changed = 0, flatChanged = 0, flat = 0;
  for (int y = 1; y + 1 < off.height; ++y)
    for (int x = 1; x + 1 < off.width; ++x) {
      float lo, hi;
      neighbourhood(off, x, y, lo, hi);
      bool diff = false;
      for (int c = 0; c < 3; ++c) diff = diff || std::abs(on.at(x, y, c) - off.at(x, y, c)) > 1.5f / 255.0f;
      changed += diff;
      if (hi - lo < 0.02f) {
        ++flat;
        flatChanged += diff;
      }
    }
  const double midOff = edgeShare(off, off), midOn = edgeShare(on, off);
  if (const char* dir = std::getenv("CRUMPLE_FXAA_DUMP")) {
    writePng(std::string(dir) + "/fxaa_off.png", off, 8);
    writePng(std::string(dir) + "/fxaa_on.png", on, 8);
  }
  MESSAGE("FXAA changed " << changed << " pixels; flat pixels changed " << flatChanged << " of " << flat
                          << "; edge pixels between their sides " << midOff * 100 << "% -> " << midOn * 100 << "%");
  CHECK(changed > 100);
  CHECK(changed < off.width * off.height / 5);  // edges only
  CHECK(flat > off.width * off.height / 4);
  CHECK(flatChanged == 0);
  CHECK(midOn > 1.5 * midOff);
  // Debug views are never filtered.
  r.settings().debug = DebugView::Height;
  r.draw(s.items(true), v);
  const Image heightOn = r.readPixels();
  r.settings().antialias = Antialias::None;
  r.draw(s.items(true), v);
  CHECK(fractionOff(heightOn, r.readPixels()) == 0.0);
}

TEST_CASE("MSAA: edge pixels take their covered share, flat areas keep their pixels, debug views are not resolved") {
  test::glContext();
  Stage s;
  s.dent(0.03, {0.3, 0, 0.2});
  Renderer r(192, 128);
  View v = topView();
  v.eye = {0.9f, 1.2f, 1.9f};
  r.settings().antialias = Antialias::None;
  r.draw(s.items(true), v);
  const Image off = r.readPixels();
  r.settings().antialias = Antialias::Msaa;
  r.draw(s.items(true), v);
  const Image on = r.readPixels();
  r.draw(s.items(true), v);
  CHECK(fractionOff(on, r.readPixels()) == 0.0);  // the same every time
  // Edge pixels of the aliased frame whose MSAA value lies between the two sides, and pixels of flat regions
  // that moved (every sample of a flat pixel sees the same surface: their mean is the one sample, to rounding).
  long edge = 0, flat = 0, flatMoved = 0;
  const double midOff = edgeShare(off, off), midOn = edgeShare(on, off, &edge);
  for (int y = 1; y + 1 < off.height; ++y)
    for (int x = 1; x + 1 < off.width; ++x) {
      float lo, hi;
      neighbourhood(off, x, y, lo, hi);
      if (hi - lo >= 0.02f) continue;
      ++flat;
      flatMoved += std::abs(luma(on, x, y) - luma(off, x, y)) > 3.0f / 255.0f;
    }
  MESSAGE("MSAA: edge pixels between their sides " << 100.0 * midOff << "% -> " << 100.0 * midOn
                                                   << "%; flat pixels moved " << flatMoved << " of " << flat);
  CHECK(edge > 100);
  CHECK(midOn > 1.5 * midOff);
  CHECK(flat > off.width * off.height / 4);
  CHECK(flatMoved < flat / 100);
  // Debug views draw straight into the target.
  r.settings().debug = DebugView::Height;
  r.draw(s.items(true), v);
  const Image heightMsaa = r.readPixels();
  r.settings().antialias = Antialias::None;
  r.draw(s.items(true), v);
  CHECK(fractionOff(heightMsaa, r.readPixels()) == 0.0);
}

TEST_CASE("procedural textures vary the surface, each its own way, the same every time") {
  test::glContext();
  Stage s;
  Renderer r(160, 120);
  r.settings().antialias = Antialias::None;
  r.settings().shadows = false;
  auto render = [&](SurfaceTexture t, float scale = 1.0f) {
    std::vector<RenderItem> items = s.items(false);
    items[0].texture = t;
    items[0].textureScale = scale;
    items[0].color = {0.6f, 0.6f, 0.6f};
    r.draw(items, topView());
    return r.readPixels();
  };
  // Spread of the luma over the middle of the plate (the dent-free flat top).
  auto spread = [](const Image& img) {
    double sum = 0, sum2 = 0;
    int n = 0;
    for (int y = 40; y < 80; ++y)
      for (int x = 50; x < 110; ++x) {
        const double l = 0.299 * img.at(x, y, 0) + 0.587 * img.at(x, y, 1) + 0.114 * img.at(x, y, 2);
        sum += l;
        sum2 += l * l;
        ++n;
      }
    const double mean = sum / n;
    return std::sqrt(std::max(0.0, sum2 / n - mean * mean));
  };
  const Image none = render(SurfaceTexture::None);
  const double flat = spread(none);
  double previous = -1;
  for (SurfaceTexture t : {SurfaceTexture::Asphalt, SurfaceTexture::Concrete, SurfaceTexture::Clay}) {
    CAPTURE(static_cast<int>(t));
    const Image a = render(t, 0.25f), b = render(t, 0.25f);  // features a quarter of their size: more in view
    const double sd = spread(a);
    MESSAGE("texture " << static_cast<int>(t) << ": luma spread " << sd << " (plain " << flat << ")");
    CHECK(sd > flat + 0.005);
    CHECK(fractionOff(a, b) == 0.0);          // deterministic
    CHECK(fractionOff(a, none) > 0.05);  // it shows on the plate
    CHECK(fractionOff(a, render(t, 1.0f)) > 0.1);  // the scale changes it
    CHECK(sd != previous);
    previous = sd;
  }
}

TEST_CASE("view culling and the shadow cache leave the picture as a fresh renderer draws it") {
  test::glContext();
  Stage s;
  // The ball rolls over the plate (inside the box the sun's frustum is fitted to): a renderer that drew the
  // earlier frames (the plate's shadow from its cache) and a fresh one draw the last frame alike.
  const glm::vec3 path[4] = {{-0.6f, 0.35f, -0.4f}, {-0.2f, 0.35f, -0.3f}, {0.2f, 0.35f, -0.2f}, {0.6f, 0.35f, -0.1f}};
  Renderer warm(160, 112);
  for (const glm::vec3& at : path) warm.draw(s.items(true, at), topView());
  CHECK(warm.stats().shadowCasters == 1);  // the ball alone: the plate stood still
  CHECK_FALSE(warm.stats().shadowCacheRedrawn);
  Renderer fresh(160, 112);
  fresh.draw(s.items(true, path[3]), topView());
  CHECK(fresh.stats().shadowCasters == 2);
  const Image a = warm.readPixels(), b = fresh.readPixels();
  long differ = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) differ += a.pixels[i] != b.pixels[i];
  CHECK(differ == 0);
  // A still caster that moves is drawn again with the others.
  std::vector<RenderItem> moved = s.items(true, path[3]);
  moved[0].model = glm::translate(glm::mat4(1), glm::vec3(0, -0.01f, 0));
  warm.draw(moved, topView());
  CHECK(warm.stats().shadowCacheRedrawn);

  // A ball behind the camera is not drawn, and the picture is the one without it.
  Renderer r(160, 112);
  r.draw(s.items(false), topView());
  const Image without = r.readPixels();
  CHECK(r.stats().drawn == 1);
  r.draw(s.items(true, {0.0f, 1.0f, 3.0f}), topView());
  CHECK(r.stats().culled == 1);
  CHECK(r.stats().drawn == 1);
  CHECK(fractionOff(r.readPixels(), without) <= 0.002);  // only the ball's shadow may differ
}

TEST_CASE("simplified meshes: fewer triangles on the same vertices, shadow casters within a centimetre") {
  test::glContext();
  const TriangleMesh sphere = sphereMesh(0.5, 128, 48);
  const deform::GpuMesh g(sphere);
  REQUIRE(sphere.triangles.size() > deform::GpuMesh::kSimplifyAbove);
  CHECK(g.simplifiedIndexCount > 0);
  CHECK(g.simplifiedIndexCount <= g.indexCount);
  CHECK(g.shadowIndexCount > 0);
  CHECK(g.shadowIndexCount * 4 < g.indexCount);  // welded, the caster simplifies freely
  // Every vertex of the caster lies on the sphere within the tolerance and its triangles close the surface
  // to about it (each triangle's centroid is at most a centimetre inside the sphere).
  std::vector<float> p(static_cast<size_t>(g.shadowVertices.size() / sizeof(float)));
  glGetNamedBufferSubData(g.shadowVertices.id(), 0, static_cast<GLsizeiptr>(p.size() * sizeof(float)), p.data());
  std::vector<uint32_t> t(static_cast<size_t>(g.shadowIndexCount));
  glGetNamedBufferSubData(g.shadowIndices.id(), 0, static_cast<GLsizeiptr>(t.size() * sizeof(uint32_t)), t.data());
  double worstVertex = 0, worstCentroid = 0;
  for (size_t i = 0; i + 2 < p.size(); i += 3)
    worstVertex = std::max(worstVertex, std::abs(glm::length(glm::dvec3(p[i], p[i + 1], p[i + 2])) - 0.5));
  for (size_t k = 0; k + 2 < t.size(); k += 3) {
    glm::dvec3 c(0);
    for (int j = 0; j < 3; ++j) c += glm::dvec3(p[t[k + j] * 3], p[t[k + j] * 3 + 1], p[t[k + j] * 3 + 2]) / 3.0;
    worstCentroid = std::max(worstCentroid, 0.5 - glm::length(c));
  }
  MESSAGE("caster: " << g.shadowIndexCount / 3 << " of " << g.indexCount / 3 << " triangles, vertices off by "
                     << worstVertex * 1000 << " mm, centroids inside by " << worstCentroid * 1000 << " mm");
  CHECK(worstVertex < 1e-4);
  CHECK(worstCentroid < 0.012);
  // Drawn simplified, the picture is nearly the same.
  Stage s;
  std::vector<RenderItem> items = s.items(false);
  RenderItem ball;
  ball.vao = g.vao.id();
  ball.indexCount = g.indexCount;
  ball.simplifiedVao = g.simplifiedVao.id();
  ball.simplifiedIndexCount = g.simplifiedIndexCount;
  ball.shadowVao = g.shadowVao.id();
  ball.shadowIndexCount = g.shadowIndexCount;
  ball.model = glm::translate(glm::mat4(1), glm::vec3(0.2f, 0.6f, 0.0f));
  ball.boundsMin = g.boundsMin;
  ball.boundsMax = g.boundsMax;
  items.push_back(ball);
  Renderer full(160, 112), simple(160, 112);
  simple.settings().simplified = true;
  full.draw(items, topView());
  simple.draw(items, topView());
  const double off = fractionOff(full.readPixels(), simple.readPixels());
  MESSAGE("simplified vs full: " << off * 100 << "% of pixels off by more than 5/255");
  CHECK(off < 0.02);
}

TEST_CASE("pattern-box's print seen at a slant: skipping flat rays changes no pixel (the bound's level varies across a block)") {
  // The wall's -x face seen obliquely: neighbouring pixels choose different pyramid levels for their rays. On
  // llvmpipe a lod that varies across a block's pixels made one pixel clamp its tile to another level's size:
  // a one-pixel seam of unmarched rays ran through the print.
  test::glContext();
  Simulation sim(loadScene(std::string(CRUMPLE_SCENES) + "/pattern-box.json"), true);
  for (int s = 0; s < 120; ++s) sim.step();  // 0.5 s: the stamp has printed and left
  REQUIRE(sim.bodies().front().surface);
  Renderer r(640, 360);
  r.settings().antialias = Antialias::None;
  const View view = cameraView(sim.scene().cameras.front(), &sim);
  std::vector<RenderItem> items = renderItems(sim);
  r.draw(items, view);
  const Image skipping = r.readPixels();
  for (RenderItem& it : items) it.heightBound = 0;
  r.draw(items, view);
  const Image marching = r.readPixels();
  long off = 0;
  float worst = 0;
  for (size_t i = 0; i < skipping.pixels.size(); ++i) {
    const float d = std::abs(skipping.pixels[i] - marching.pixels[i]);
    worst = std::max(worst, d);
    off += d > 1.0f / 255.0f + 1e-6f;
  }
  MESSAGE("pattern-box: largest difference, skipping vs marching every ray: " << worst * 255 << "/255 (" << off
                                                                               << " channels off)");
  CHECK(off == 0);
}

TEST_CASE("shading from a visibility buffer in compute gives the fragment stage's picture") {
  // The shipped scenes' first camera after their dents formed: the pattern box's print (parallax march, dents
  // on both bodies), the crate's glTF look (textures, vertex colours), the mixed pile (procedural clay floor,
  // meshes, spheres).
  test::glContext();
  const struct {
    const char* scene;
    int steps;
  } cases[] = {{"pattern-box.json", 120}, {"crate-drop.json", 150}, {"mixed-pile.json", 240}};
  for (const auto& c : cases) {
    CAPTURE(c.scene);
    Simulation sim(loadScene(std::string(CRUMPLE_SCENES) + "/" + c.scene), true);
    for (int s = 0; s < c.steps; ++s) sim.step();
    const std::vector<RenderItem> items = renderItems(sim);
    const View view = cameraView(sim.scene().cameras.front(), &sim);
    Renderer forward(320, 180), compute(320, 180);
    forward.settings().shading = Shading::Forward;
    compute.settings().shading = Shading::Compute;
    forward.draw(items, view);
    compute.draw(items, view);
    CHECK_FALSE(forward.stats().computeShaded);
    REQUIRE(compute.stats().computeShaded);
    CHECK(compute.stats().drawn == forward.stats().drawn);
    const Image a = forward.readPixels(), b = compute.readPixels();
    const double off = fractionOff(a, b);
    double sum = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) sum += std::abs(a.pixels[i] - b.pixels[i]);
    MESSAGE(std::string(c.scene) << ": " << off * 100 << "% of pixels off by more than 5/255, mean difference "
                    << sum / a.pixels.size() * 255 << "/255");
    CHECK(off < 0.01);
    CHECK(sum / a.pixels.size() < 1.0 / 255);
    // Repeatable bit for bit.
    compute.draw(items, view);
    CHECK(fractionOff(b, compute.readPixels()) == 0.0);
    // With simplified meshes (the sandbox's setting) both draw the same triangles; without antialiasing the
    // compute path's frame is copied into the target.
    forward.settings().simplified = compute.settings().simplified = true;
    forward.draw(items, view);
    compute.draw(items, view);
    REQUIRE(compute.stats().computeShaded);
    CHECK(fractionOff(forward.readPixels(), compute.readPixels()) < 0.01);
    forward.settings().antialias = compute.settings().antialias = Antialias::None;
    forward.draw(items, view);
    compute.draw(items, view);
    REQUIRE(compute.stats().computeShaded);
    const double offPlain = fractionOff(forward.readPixels(), compute.readPixels());
    MESSAGE("  no antialiasing: " << offPlain * 100 << "% of pixels off by more than 5/255");
    CHECK(offPlain < 0.01);
    compute.settings().antialias = Antialias::Msaa;  // MSAA stays in the fragment stage
    compute.draw(items, view);
    CHECK_FALSE(compute.stats().computeShaded);
  }
}

TEST_CASE("shaded in compute, a ball resting in its crater is drawn inside it, as the fragment stage draws it") {
  // A crater 4 cm deep (a 25 cm ball's print) and a marble of 5 cm radius on its floor, 4 cm of it below the
  // plate's top, seen from above at a slant: the flat plate in front of the crater must not hide the marble's
  // lower part (the visibility pass writes the marched depth). Marble pixels: bluish grey (the plate is warm, lit
  // or in shadow).
  test::glContext();
  View view;
  view.eye = {0.0f, 0.55f, 0.9f};
  view.target = {0.0f, 0.1f, 0.0f};
  view.fovDegrees = 25;
  const glm::vec3 sunk{0.0f, 0.1f - 0.04f + 0.05f, 0.0f};
  auto ballPixels = [&](Stage& stage, Shading shading, Image* shaded) {
    Renderer r(240, 160);
    r.settings().shading = shading;
    r.settings().antialias = Antialias::None;
    std::vector<RenderItem> items = stage.items(true, sunk);
    items[1].model = glm::scale(items[1].model, glm::vec3(0.2f));  // the 25 cm ball's mesh at 5 cm
    r.draw(items, view);
    REQUIRE(r.stats().computeShaded == (shading == Shading::Compute));
    *shaded = r.readPixels();
    int n = 0;
    for (int y = 0; y < shaded->height; ++y)
      for (int x = 0; x < shaded->width; ++x) n += shaded->at(x, y, 2) > shaded->at(x, y, 0) + 0.02f;
    return n;
  };
  Stage dented, flat;
  dented.dent(0.04);
  Image forward, compute, onFlat;
  const int inForward = ballPixels(dented, Shading::Forward, &forward);
  const int inCompute = ballPixels(dented, Shading::Compute, &compute);
  const int flatForward = ballPixels(flat, Shading::Forward, &onFlat);  // its part below the plate's top hidden
  MESSAGE("marble pixels: fragment stage " << inForward << ", compute " << inCompute << ", undented plate "
                                           << flatForward);
  CHECK(inForward > flatForward + flatForward / 10);  // the crater shows the sunk part
  CHECK(std::abs(inCompute - inForward) <= inForward / 100);
  CHECK(fractionOff(forward, compute) < 0.002);
}
