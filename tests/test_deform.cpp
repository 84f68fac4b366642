// The deformation stage against geometry: a sphere pressed into a plate leaves
// a spherical cap; the default (gather) path agrees with the per-texel CPU
// oracle; the paper's scatter on the GPU and read back agree bit for bit; dents
// hold together (no gaps) at any address map, map resolution and surface angle.
#include <doctest/doctest.h>

#include <algorithm>

#include <cmath>
#include <cstring>
#include <set>
#include <glm/gtc/matrix_transform.hpp>

#include <crumple/deform/bindings.h>
#include <crumple/deform/cpu_reference.h>
#include <crumple/deform/deformer.h>
#include <crumple/deform/passes.h>
#include <crumple/engine/primitives.h>
#include "dent_metrics.h"
#include "gl_fixture.h"
#include <crumple/deform/model/stress_strain.h>

using namespace crumple;
using namespace crumple::deform;
using doctest::Approx;

namespace {

// World position of every texel centre that lies on a triangle whose normal
// points along `facing` (any triangle when `facing` is zero; NaN elsewhere):
// the atlas inverted by rasterisation.
std::vector<glm::dvec3> texelPositions(const TriangleMesh& m, const glm::dmat4& model, int res, glm::dvec3 facing) {
  std::vector<glm::dvec3> out(static_cast<size_t>(res) * res, glm::dvec3(std::nan("")));
  for (const auto& t : m.triangles) {
    const glm::dvec3 p0(m.positions[t.x]), p1(m.positions[t.y]), p2(m.positions[t.z]);
    if (facing != glm::dvec3(0) && glm::dot(glm::normalize(glm::cross(p1 - p0, p2 - p0)), facing) < 0.9) continue;
    const glm::dvec2 a = glm::dvec2(m.uvs[t.x]) * double(res), b = glm::dvec2(m.uvs[t.y]) * double(res),
                     c = glm::dvec2(m.uvs[t.z]) * double(res);
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    for (int y = static_cast<int>(std::min({a.y, b.y, c.y})); y <= static_cast<int>(std::max({a.y, b.y, c.y})); ++y)
      for (int x = static_cast<int>(std::min({a.x, b.x, c.x})); x <= static_cast<int>(std::max({a.x, b.x, c.x})); ++x) {
        if (x < 0 || y < 0 || x >= res || y >= res) continue;
        const glm::dvec2 q(x + 0.5, y + 0.5);
        const double w0 = ((b.x - q.x) * (c.y - q.y) - (b.y - q.y) * (c.x - q.x)) / area;
        const double w1 = ((c.x - q.x) * (a.y - q.y) - (c.y - q.y) * (a.x - q.x)) / area;
        const double w2 = 1 - w0 - w1;
        if (w0 < -1e-9 || w1 < -1e-9 || w2 < -1e-9) continue;
        out[static_cast<size_t>(y) * res + x] = glm::dvec3(model * glm::dvec4(w0 * p0 + w1 * p1 + w2 * p2, 1));
      }
  }
  return out;
}

// Texels that belong to a chart of the atlas (their centre lies on a triangle).
std::vector<uint8_t> onSurface(const TriangleMesh& m, int res) {
  const auto pos = texelPositions(m, glm::dmat4(1), res, glm::dvec3(0));
  std::vector<uint8_t> out(pos.size());
  for (size_t i = 0; i < pos.size(); ++i) out[i] = !std::isnan(pos[i].x);
  return out;
}

struct SphereIntoPlate {
  static constexpr int kRes = 512;
  static constexpr double R = 0.25, k = 0.1, kc = 0.02;
  TriangleMesh plateMesh = boxMesh({2, 0.2, 2}, kRes);
  TriangleMesh ballMesh = sphereMesh(R, 256);
  std::shared_ptr<GpuMesh> plateGpu = std::make_shared<GpuMesh>(plateMesh);
  std::shared_ptr<GpuMesh> ballGpu = std::make_shared<GpuMesh>(ballMesh);
  glm::dmat4 plateModel{1};
  glm::dmat4 ballModel = glm::translate(glm::dmat4(1), glm::dvec3(0, 0.1 + R, 0));

  gl::Image run(Deformer& d, double depth) {
    auto maps = d.createMaps(kRes, nullptr, static_cast<float>(k), static_cast<float>(plateGpu->metresPerUv / kRes));
    Surface plate(plateGpu, kRes, static_cast<float>(k), static_cast<float>(kc), maps);
    const int h = d.deform(pressBall(&plate, depth));
    lastStats = d.stats(h, 0);
    return plate.downloadHeight();
  }
  SideStats lastStats;
  // The ball (ballModel, no surface of its own) pressed `depth` into `plate` at the top's centre.
  DeformRequest pressBall(Surface* plate, double depth) const {
    DeformRequest rq;
    rq.a = {plate, plateGpu.get(), plateModel};
    rq.b = {nullptr, ballGpu.get(), ballModel};
    rq.point = {0, 0.1, 0};
    rq.normal = {0, 1, 0};
    rq.deformA = depth;
    return rq;
  }
  // A ball (surface `ball`, mesh `mesh`) resting on `plate` over `at` (on the plate's top), both sides dented.
  DeformRequest ballOn(Surface* plate, Surface* ball, const GpuMesh* mesh, glm::dvec3 at, double deformA,
                       double deformB) const {
    DeformRequest rq;
    rq.a = {plate, plateGpu.get(), plateModel};
    rq.b = {ball, mesh, glm::translate(glm::dmat4(1), at + glm::dvec3(0, R, 0))};
    rq.point = at;
    rq.normal = {0, 1, 0};
    rq.deformA = deformA;
    rq.deformB = deformB;
    return rq;
  }
};

}  // namespace

TEST_CASE("a sphere pressed into a plate leaves a spherical cap of the predicted depth and radius") {
  test::glContext();
  SphereIntoPlate s;
  Deformer d({512, Path::Gather});
  const double depth = 0.02;
  const gl::Image h = s.run(d, depth);
  const auto pos = texelPositions(s.plateMesh, s.plateModel, SphereIntoPlate::kRes, {0, 1, 0});
  double maxDent = 0, dentRadius = 0, worstProfile = 0;
  const double texel = s.plateGpu->metresPerUv / SphereIntoPlate::kRes;
  for (size_t i = 0; i < pos.size(); ++i) {
    if (std::isnan(pos[i].x)) continue;
    const double dent = (0.5 - h.pixels[i]) * SphereIntoPlate::k;
    const double r = std::hypot(pos[i].x, pos[i].z);
    const double R = SphereIntoPlate::R;
    const double expected = r < R ? std::max(0.0, depth - R + std::sqrt(R * R - r * r)) : 0.0;
    maxDent = std::max(maxDent, dent);
    if (dent > 1e-4) dentRadius = std::max(dentRadius, r);
    // Profile: within the depth change across two texels of the slope at r.
    const double slope = r < R * 0.999 ? r / std::sqrt(R * R - r * r) : 10.0;
    const double allowed = 2 * texel * slope + 2e-4;
    worstProfile = std::max(worstProfile, std::abs(dent - expected) - allowed);
  }
  const double predictedRadius = std::sqrt(2 * SphereIntoPlate::R * depth - depth * depth);
  MESSAGE("cap depth " << maxDent << " (predicted " << depth << "), radius " << dentRadius << " (predicted "
                       << predictedRadius << "), texel " << texel);
  CHECK(maxDent == Approx(depth).epsilon(0.02));
  CHECK(std::abs(dentRadius - predictedRadius) <= 2 * texel);
  CHECK(worstProfile <= 0.0);
  CHECK(s.lastStats.texelsChanged > 100);
  CHECK(s.lastStats.maxDent == Approx(maxDent).epsilon(1e-4));
  CHECK_FALSE(s.lastStats.saturated);
}

TEST_CASE("the paper's scatter on the GPU and read back to the CPU give the same map") {
  test::glContext();
  SphereIntoPlate s;
  Deformer gpu({256, Path::Scatter}), readback({256, Path::Readback});
  const gl::Image a = s.run(gpu, 0.015);
  const gl::Image b = s.run(readback, 0.015);
  double diff = 0;
  int changed = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    diff = std::max(diff, double(std::abs(a.pixels[i] - b.pixels[i])));
    changed += a.pixels[i] < 0.5f;
  }
  CHECK(changed > 50);
  CHECK(diff <= 1e-5);
}

TEST_CASE("the default (gather) path agrees with the per-texel CPU oracle, at any address map") {
  test::glContext();
  SphereIntoPlate s;
  ReferenceBody x{&s.plateMesh, s.plateModel, nullptr, SphereIntoPlate::k, SphereIntoPlate::kc};
  ReferenceBody o{&s.ballMesh, s.ballModel, nullptr, 0.1, 0.02};
  gl::Image flat(SphereIntoPlate::kRes, SphereIntoPlate::kRes, 1, 0.5f);
  x.height = &flat;
  const gl::Image oracle = referenceDeform(x, o, {0, 0.1, 0}, {0, 1, 0}, 0, 0.015);
  int oracleChanged = 0;
  for (float v : oracle.pixels) oracleChanged += v < 0.5f;
  REQUIRE(oracleChanged > 300);
  for (int address : {32, 128, 512}) {
    Deformer gather({address, Path::Gather});
    const gl::Image a = s.run(gather, 0.015);
    double worst = 0;
    int changed = 0, missed = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) {
      changed += a.pixels[i] < 0.5f;
      // Texels the oracle dents by more than 0.1 mm must be dented.
      missed += oracle.pixels[i] < 0.499f && !(a.pixels[i] < 0.5f);
      worst = std::max(worst, double(std::abs(a.pixels[i] - oracle.pixels[i])));
    }
    MESSAGE("address map " << address << ": texels changed " << changed << " (oracle " << oracleChanged << "), missed "
                           << missed << ", max |gather - oracle| " << worst * SphereIntoPlate::k << " m");
    CHECK(missed == 0);
    // Only texels on the cap's rim, where the dent is ~0, may differ in whether they changed.
    CHECK(std::abs(changed - oracleChanged) <= oracleChanged / 50 + 8);
    // The ball's depth is interpolated between address-map pixels: a coarser map, a coarser shape.
    CHECK(worst * SphereIntoPlate::k <= (address >= 128 ? 2e-4 : 1e-3));
  }
}

TEST_CASE("the gather's address pass rasterised in compute gives the fragment stage's dent, overflowing tiles too") {
  // Address map 32: 4 x 4 tiles of 8 x 8 pixels under ~1500 back faces, so every tile list overflows its 64
  // entries and the raster step tests all triangles; 512: short lists.
  test::glContext();
  SphereIntoPlate s;
  for (int address : {32, 512}) {
    DeformOptions hw{address, Path::Gather};
    hw.addressRaster = AddressRaster::Fragment;
    DeformOptions cs{address, Path::Gather};
    cs.addressRaster = AddressRaster::Compute;
    Deformer hardware(hw), compute(cs);
    REQUIRE(compute.addressRaster() == AddressRaster::Compute);
    const gl::Image a = s.run(hardware, 0.015);
    const gl::Texture2D& ha = hardware.lastAddressMap();
    const gl::Image b = s.run(compute, 0.015);
    const gl::Texture2D& ca = compute.lastAddressMap();
    std::vector<float> am(static_cast<size_t>(address) * address * 2), cm(am.size());
    glGetTextureImage(ha.id(), 0, GL_RG, GL_FLOAT, static_cast<GLsizei>(am.size() * sizeof(float)), am.data());
    glGetTextureImage(ca.id(), 0, GL_RG, GL_FLOAT, static_cast<GLsizei>(cm.size() * sizeof(float)), cm.data());
    // The compute pass leaves out the ball's triangles that stay above the plate (they cannot dent it): it sees a
    // part of what the fragment stage sees, the cap around the contact, and there the same addresses.
    int seenA = 0, seenB = 0, extra = 0, holes = 0, uvDiffer = 0;
    double uvDiff = 0;
    auto seenIn = [&](const std::vector<float>& m, int x, int y) {
      return x >= 0 && y >= 0 && x < address && y < address && m[2 * (static_cast<size_t>(y) * address + x)] >= 0;
    };
    for (int y = 0; y < address; ++y)
      for (int x = 0; x < address; ++x) {
        const size_t i = 2 * (static_cast<size_t>(y) * address + x);
        const bool sa = am[i] >= 0, sb = cm[i] >= 0;
        seenA += sa;
        seenB += sb;
        extra += sb && !sa;
        // A crack between two kept triangles: an unseen pixel between seen ones.
        holes += !sb && ((seenIn(cm, x - 1, y) && seenIn(cm, x + 1, y)) || (seenIn(cm, x, y - 1) && seenIn(cm, x, y + 1)));
        if (!sa || !sb) continue;
        const double d = std::max(std::abs(am[i] - cm[i]), std::abs(am[i + 1] - cm[i + 1]));
        // At the atlas's seams one point has two addresses, one per chart: either is right.
        if (d > 2.0 / SphereIntoPlate::kRes)
          ++uvDiffer;
        else
          uvDiff = std::max(uvDiff, d);
      }
    double diff = 0;
    int changedA = 0, changedB = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) {
      diff = std::max(diff, double(std::abs(a.pixels[i] - b.pixels[i])));
      changedA += a.pixels[i] < 0.5f;
      changedB += b.pixels[i] < 0.5f;
    }
    // The raster ran the tiles the bins gave something to test: every tile with a seen pixel, few others.
    std::set<int> seenTiles;
    for (int y = 0; y < address; ++y)
      for (int x = 0; x < address; ++x)
        if (seenIn(cm, x, y)) seenTiles.insert((y / 8) * ((address + 7) / 8) + x / 8);
    const auto [tilesRun, tiles] = compute.lastRasterTiles();
    MESSAGE("address map " << address << ": the raster ran " << tilesRun << " of " << tiles << " tiles, "
                           << seenTiles.size() << " with a pixel seen");
    CHECK(tiles == static_cast<size_t>(((address + 7) / 8) * ((address + 7) / 8)));
    CHECK(tilesRun >= seenTiles.size());
    if (address >= 512) CHECK(tilesRun < tiles / 4);
    MESSAGE("address map " << address << ": pixels seen " << seenA << " (fragment stage) vs " << seenB
                           << " (compute: the part that can reach the plate), seen by compute only " << extra
                           << ", holes " << holes << "; addresses apart by over 2 texels " << uvDiffer
                           << ", others by at most " << uvDiff
                           << "; texels dented " << changedA << " vs " << changedB << ", max height difference "
                           << diff * SphereIntoPlate::k << " m");
    CHECK(seenA > address * address / 2);
    CHECK(seenB > 0);
    CHECK(seenB < seenA);
    // Only pixel centres on an edge (within rounding) may be covered by one and not the other; no cracks.
    CHECK(extra <= address / 16 + 2);
    CHECK(holes <= address / 16 + 2);
    CHECK(uvDiffer <= 2 * address);
    CHECK(changedA > 300);
    CHECK(std::abs(changedA - changedB) <= changedA / 100 + 4);
    CHECK(diff * SphereIntoPlate::k <= 2e-5);
  }
}

TEST_CASE("X's texels gathered in compute give the fragment stage's dents on both sides, curved ones too") {
  // Where the address pass runs in compute, so does the gather (texel_gather.comp: X's texels visited per tile
  // of its map instead of drawn in texture space). Both sides of a ball on a plate, the ball's map on a curved
  // surface (its charts' edges, texels reached by several triangles), with and without the tangent correction.
  test::glContext();
  SphereIntoPlate s;
  for (TangentMode tangent : {TangentMode::None, TangentMode::Divide}) {
    gl::Image maps[2][2];  // [compute][side]
    for (int compute = 0; compute < 2; ++compute) {
      DeformOptions o{256, Path::Gather};
      o.addressRaster = compute ? AddressRaster::Compute : AddressRaster::Fragment;
      o.tangent = tangent;
      Deformer d(o);
      Surface plate(s.plateGpu, SphereIntoPlate::kRes, float(SphereIntoPlate::k), float(SphereIntoPlate::kc),
                    d.createMaps(SphereIntoPlate::kRes, nullptr, float(SphereIntoPlate::k),
                                 float(s.plateGpu->metresPerUv / SphereIntoPlate::kRes)));
      Surface ball(s.ballGpu, 256, 0.1f, 0.02f, d.createMaps(256, nullptr, 0.1f, float(s.ballGpu->metresPerUv / 256)));
      d.deform(s.ballOn(&plate, &ball, s.ballGpu.get(), {0.05, 0.1, 0.02}, 0.012, 0.008));
      if (compute) {  // the gather ran the tiles of X's maps near the contact, not all of them
        const auto [kept, tiles] = d.lastGatherTiles();
        MESSAGE("the gather kept " << kept << " of " << tiles << " texel tiles");
        CHECK(kept > 0);
        CHECK(kept < tiles / 4);
      }
      maps[compute][0] = plate.downloadHeight();
      maps[compute][1] = ball.downloadHeight();
    }
    for (int side = 0; side < 2; ++side) {
      const gl::Image &a = maps[0][side], &b = maps[1][side];
      int changedA = 0, changedB = 0, apart = 0;
      double diff = 0, deepest = 0;  // height units (x k = 0.1 m)
      for (size_t i = 0; i < a.pixels.size(); ++i) {
        changedA += a.pixels[i] < 0.5f;
        changedB += b.pixels[i] < 0.5f;
        deepest = std::max(deepest, 0.5 - double(a.pixels[i]));
        const double d = std::abs(double(a.pixels[i]) - double(b.pixels[i]));
        apart += d * 0.1 > 1e-5;
        diff = std::max(diff, d);
      }
      const std::string label = std::string(tangent == TangentMode::None ? "no tangent correction" : "tangent divide") +
                                (side ? ", ball" : ", plate");
      MESSAGE(label << ": texels dented " << changedA << " (fragment) vs " << changedB << " (compute); apart by over "
                    << "0.01 mm " << apart << ", by at most " << diff * 0.1 << " m (the dent " << deepest * 0.1
                    << " m deep)");
      CHECK(changedA > 100);
      // The per-texel test reaches the texels the conservative draw does (on llvmpipe: all of them, to float
      // rounding); where a rasteriser's rule for samples on an edge differed, a chart's edge on the texel grid
      // would take its neighbour's extrapolation: a row of texels, few.
      CHECK(std::abs(changedA - changedB) <= changedA / 100 + 4);
      CHECK(apart <= changedA / 100 + 4);
      CHECK(diff <= 0.1 * deepest);
    }
  }
}

TEST_CASE("the compute gather leaves no texture of another type on its sampler array's unused units") {
  // A cube map left on the array's last unit by an earlier program (the renderer's sky light) would sit in the gather's
  // sampler2D array: undefined behaviour, which NVIDIA's driver reports.
  test::glContext();
  SphereIntoPlate s;
  DeformOptions cs{128, Path::Gather};
  cs.addressRaster = AddressRaster::Compute;
  Deformer d(cs);
  GLuint cube = 0;
  glCreateTextures(GL_TEXTURE_CUBE_MAP, 1, &cube);
  glTextureStorage2D(cube, 1, GL_RGBA8, 4, 4);
  const gl::TextureUnit last = bindings::gather::kHeights + 13;  // texel_gather.comp's uHeights[14]: the last
  gl::bindTexture(last, cube);
  s.run(d, 0.01);
  REQUIRE(s.lastStats.texelsChanged > 0);
  glActiveTexture(GL_TEXTURE0 + last.index);
  GLint bound = 0;
  glGetIntegerv(GL_TEXTURE_BINDING_CUBE_MAP, &bound);
  glActiveTexture(GL_TEXTURE0);
  CHECK(bound == 0);
  glDeleteTextures(1, &cube);
}

TEST_CASE("the compute raster puts back \"none\" where its last event wrote: a used deformer gives a fresh one's map") {
  // The raster writes the active tiles only; the tiles an earlier event wrote are cleared from its lists. A
  // deformer that first took a larger event (the ball 4 cm deeper: more tiles, framed otherwise) must give the
  // next event's address map bit for bit as a fresh deformer does.
  test::glContext();
  SphereIntoPlate s;
  DeformOptions cs{128, Path::Gather};
  cs.addressRaster = AddressRaster::Compute;
  auto addressMap = [&](Deformer& d) {
    std::vector<float> m(size_t(cs.addressMap) * cs.addressMap * 2);
    glGetTextureImage(d.lastAddressMap().id(), 0, GL_RG, GL_FLOAT, static_cast<GLsizei>(m.size() * sizeof(float)),
                      m.data());
    return m;
  };
  Deformer used(cs), fresh(cs);
  const glm::dmat4 shallow = s.ballModel;
  s.ballModel = glm::translate(shallow, glm::dvec3(0.05, -0.04, 0));
  s.run(used, 0.01);
  const std::vector<float> deep = addressMap(used);
  s.ballModel = shallow;
  s.run(used, 0.01);
  s.run(fresh, 0.01);
  const std::vector<float> a = addressMap(used), b = addressMap(fresh);
  int seenDeep = 0, seen = 0, differ = 0;
  for (size_t i = 0; i < a.size(); i += 2) {
    seenDeep += deep[i] >= 0;
    seen += b[i] >= 0;
    differ += std::memcmp(&a[i], &b[i], 2 * sizeof(float)) != 0;
  }
  MESSAGE("pixels seen: deep event " << seenDeep << ", next event " << seen << "; differing " << differ);
  CHECK(seenDeep > seen);
  CHECK(seen > 0);
  CHECK(differ == 0);
}

TEST_CASE("large triangles (the plate's faces under a dented ball): the compute raster runs the reach's tiles only") {
  // X is the ball, the other body the plate, whose faces (0.5 m triangles) each cover more than 1024 of the
  // address map's tiles: they go to the large list that every tile tests. The raster runs the tiles of the
  // pixels X's kept texels read (the reach), not the whole map; the dent is the fragment stage's; and a used
  // deformer (a deeper event first: a larger reach) puts "none" back over its last rectangle.
  test::glContext();
  SphereIntoPlate s;
  constexpr int kAddress = 512, kBallRes = 256;
  auto run = [&](Deformer& d, double depth) {
    Surface ball(s.ballGpu, kBallRes, 0.1f, 0.02f,
                 d.createMaps(kBallRes, nullptr, 0.1f, float(s.ballGpu->metresPerUv / kBallRes)));
    DeformRequest rq;
    rq.a = {&ball, s.ballGpu.get(), s.ballModel};
    rq.b = {nullptr, s.plateGpu.get(), s.plateModel};
    rq.point = {0, 0.1, 0};
    rq.normal = {0, -1, 0};
    rq.deformA = depth;
    d.deform(rq);
    return ball.downloadHeight();
  };
  auto addressMap = [&](Deformer& d) {
    std::vector<float> m(size_t(kAddress) * kAddress * 2);
    glGetTextureImage(d.lastAddressMap().id(), 0, GL_RG, GL_FLOAT, static_cast<GLsizei>(m.size() * sizeof(float)),
                      m.data());
    return m;
  };
  DeformOptions hw{kAddress, Path::Gather}, cs{kAddress, Path::Gather};
  hw.addressRaster = AddressRaster::Fragment;
  cs.addressRaster = AddressRaster::Compute;
  Deformer fragment(hw), compute(cs), used(cs);
  const gl::Image a = run(fragment, 0.01), b = run(compute, 0.01);
  const auto [tilesRun, tiles] = compute.lastRasterTiles();
  int changedA = 0, changedB = 0;
  double diff = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    changedA += a.pixels[i] < 0.5f;
    changedB += b.pixels[i] < 0.5f;
    diff = std::max(diff, double(std::abs(a.pixels[i] - b.pixels[i])));
  }
  run(used, 0.04);
  const size_t deepTiles = used.lastRasterTiles().first;
  run(used, 0.01);
  const std::vector<float> mu = addressMap(used), mc = addressMap(compute);
  int differ = 0, seen = 0;
  for (size_t i = 0; i < mu.size(); i += 2) {
    seen += mc[i] >= 0;
    differ += std::memcmp(&mu[i], &mc[i], 2 * sizeof(float)) != 0;
  }
  MESSAGE("ball texels dented " << changedA << " (fragment) vs " << changedB << " (compute), max difference "
                                << diff * 0.1 << " m; raster tiles " << tilesRun << " of " << tiles
                                << " (deeper event " << deepTiles << "); pixels seen " << seen << ", differing "
                                << differ);
  CHECK(changedA > 100);
  CHECK(std::abs(changedA - changedB) <= changedA / 100 + 4);
  CHECK(diff * 0.1 <= 2e-5);
  CHECK(tilesRun > 0);
  CHECK(tilesRun < tiles / 2);  // all of them before: the reach is the ball's lower half (the plate is 0.2 m deep)
  CHECK(deepTiles > tilesRun);
  CHECK(seen > 0);
  CHECK(differ == 0);
}

TEST_CASE("a batch of events runs in waves of different surfaces and gives the one-by-one maps bit for bit") {
  test::glContext();
  SphereIntoPlate s;
  constexpr int kPlates = 3;
  struct Bodies {
    std::vector<std::unique_ptr<Surface>> plates, balls;
  };
  auto make = [&](Deformer& d) {
    Bodies b;
    for (int i = 0; i < kPlates; ++i) {
      b.plates.push_back(std::make_unique<Surface>(
          s.plateGpu, SphereIntoPlate::kRes, float(SphereIntoPlate::k), float(SphereIntoPlate::kc),
          d.createMaps(SphereIntoPlate::kRes, nullptr, float(SphereIntoPlate::k), float(s.plateGpu->metresPerUv / SphereIntoPlate::kRes))));
      b.balls.push_back(std::make_unique<Surface>(
          s.ballGpu, 256, 0.1f, 0.02f, d.createMaps(256, nullptr, 0.1f, float(s.ballGpu->metresPerUv / 256))));
    }
    return b;
  };
  // Ball i on plate i at x, both sides dented; the fourth hits plate 0 again with ball 0 (a new wave), the fifth
  // ball 1 on plate 2 (surfaces of the first wave, none of the second's: it joins the second).
  auto requests = [&](Bodies& b) {
    std::vector<DeformRequest> rqs;
    const int plate[5] = {0, 1, 2, 0, 2}, ball[5] = {0, 1, 2, 0, 1};
    const double x[5] = {-0.4, 0.0, 0.3, 0.25, -0.2};
    for (int k = 0; k < 5; ++k)
      rqs.push_back(s.ballOn(b.plates[size_t(plate[k])].get(), b.balls[size_t(ball[k])].get(), s.ballGpu.get(),
                             {x[k], 0.1, 0}, 0.01, 0.002));
    return rqs;
  };
  DeformOptions o{64, Path::Gather};
  o.addressRaster = AddressRaster::Compute;
  Deformer one(o), batch(o);
  Bodies a = make(one), b = make(batch);
  std::vector<int> ha;
  for (const DeformRequest& rq : requests(a)) ha.push_back(one.deform(rq));
  const std::vector<int> hb = batch.deform(requests(b));
  CHECK(one.wavesRun() == 5);
  CHECK(batch.wavesRun() == 2);  // {0, 1, 2}, {3, 4}
  REQUIRE(hb.size() == 5);
  int dented = 0;
  for (int i = 0; i < kPlates; ++i)
    for (const auto* pair : {&a.plates, &a.balls}) {
      const auto* other = pair == &a.plates ? &b.plates : &b.balls;
      const gl::Image x = (*pair)[size_t(i)]->downloadHeight(), y = (*other)[size_t(i)]->downloadHeight();
      REQUIRE(x.pixels.size() == y.pixels.size());
      CHECK(std::memcmp(x.pixels.data(), y.pixels.data(), x.pixels.size() * sizeof(float)) == 0);
      for (float v : x.pixels) dented += v < 0.5f;
    }
  CHECK(dented > 1000);
  for (int k = 0; k < 5; ++k)
    for (int side = 0; side < 2; ++side) {
      const SideStats sa = one.stats(ha[size_t(k)], side), sb = batch.stats(hb[size_t(k)], side);
      CHECK(sa.texelsChanged == sb.texelsChanged);
      CHECK(sa.texelsChanged > 0);
      CHECK(sa.maxDent == sb.maxDent);
    }
  // A wave holds what waveMemory allows: here one event at a time.
  o.waveMemory = 1;
  Deformer narrow(o);
  Bodies c = make(narrow);
  narrow.deform(requests(c));
  CHECK(narrow.wavesRun() == 5);
}

TEST_CASE("a wave of more sides than one raster dispatch takes, on meshes of three kinds, gives the one-by-one maps") {
  // 10 events, both sides dented: 20 sides in one wave, so the compute raster runs two dispatches (16 sides a
  // dispatch: their height maps bound side by side) and the bins three (one a mesh: plate, ball, a second ball
  // mesh of another tessellation).
  test::glContext();
  SphereIntoPlate s;
  auto ball2 = std::make_shared<GpuMesh>(sphereMesh(SphereIntoPlate::R, 256, 10));
  constexpr int kEvents = 10;
  struct Bodies {
    std::vector<std::unique_ptr<Surface>> plates, balls;
  };
  auto make = [&](Deformer& d) {
    Bodies b;
    for (int i = 0; i < kEvents; ++i) {
      b.plates.push_back(std::make_unique<Surface>(
          s.plateGpu, 256, float(SphereIntoPlate::k), float(SphereIntoPlate::kc),
          d.createMaps(256, nullptr, float(SphereIntoPlate::k), float(s.plateGpu->metresPerUv / 256))));
      const auto& mesh = i % 3 == 2 ? ball2 : s.ballGpu;
      // Bumpy balls (a height map of their own, not flat): the raster samples each side's other body's map.
      std::vector<float> bumps(128 * 128);
      for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x)
          bumps[size_t(y) * 128 + x] = 0.5f + 0.3f * float(std::sin(0.4 * x + i) * std::cos(0.3 * y));
      gl::Image img(128, 128, 1);
      img.pixels = bumps;
      b.balls.push_back(std::make_unique<Surface>(mesh, 128, 0.1f, 0.02f,
                                                  d.createMaps(128, &img, 0.1f, float(mesh->metresPerUv / 128))));
    }
    return b;
  };
  auto requests = [&](Bodies& b) {
    std::vector<DeformRequest> rqs;
    for (int k = 0; k < kEvents; ++k) {
      rqs.push_back(s.ballOn(b.plates[size_t(k)].get(), b.balls[size_t(k)].get(),
                             k % 3 == 2 ? ball2.get() : s.ballGpu.get(), {-0.5 + 0.1 * k, 0.1, 0}, 0.01, 0.003));
    }
    return rqs;
  };
  DeformOptions o{64, Path::Gather};
  o.addressRaster = AddressRaster::Compute;
  Deformer one(o), batch(o);
  REQUIRE(batch.waveLimit() >= size_t(kEvents));
  Bodies a = make(one), b = make(batch);
  for (const DeformRequest& rq : requests(a)) one.deform(rq);
  batch.deform(requests(b));
  CHECK(batch.wavesRun() == 1);
  int dentedPlates = 0, dentedBalls = 0, differ = 0;
  for (int i = 0; i < kEvents; ++i) {
    const gl::Image pa = a.plates[size_t(i)]->downloadHeight(), pb = b.plates[size_t(i)]->downloadHeight();
    const gl::Image ba = a.balls[size_t(i)]->downloadHeight(), bb = b.balls[size_t(i)]->downloadHeight();
    differ += std::memcmp(pa.pixels.data(), pb.pixels.data(), pa.pixels.size() * sizeof(float)) != 0;
    differ += std::memcmp(ba.pixels.data(), bb.pixels.data(), ba.pixels.size() * sizeof(float)) != 0;
    int plateTexels = 0;
    for (float v : pa.pixels) plateTexels += v < 0.5f;
    dentedPlates += plateTexels > 20;
    int changed = 0;
    for (size_t t = 0; t < bb.pixels.size(); ++t) {
      const int x = int(t % 128), y = int(t / 128);
      changed += bb.pixels[t] < 0.5f + 0.3f * float(std::sin(0.4 * x + i) * std::cos(0.3 * y)) - 1e-6f;
    }
    dentedBalls += changed > 0;
  }
  MESSAGE("plates dented: " << dentedPlates << ", balls dented: " << dentedBalls << " of " << kEvents);
  CHECK(differ == 0);
  CHECK(dentedPlates == kEvents);
  CHECK(dentedBalls == kEvents);
}

TEST_CASE("the address pass's rasteriser: compute on data-centre GPUs, whose fragment stage is narrow") {
  CHECK(resolveAddressRaster(AddressRaster::Auto, "NVIDIA H100 80GB HBM3/PCIe/SSE2") == AddressRaster::Compute);
  CHECK(resolveAddressRaster(AddressRaster::Auto, "NVIDIA H200/PCIe/SSE2") == AddressRaster::Compute);
  CHECK(resolveAddressRaster(AddressRaster::Auto, "NVIDIA A100-SXM4-40GB/PCIe/SSE2") == AddressRaster::Compute);
  CHECK(resolveAddressRaster(AddressRaster::Auto, "NVIDIA A30/PCIe/SSE2") == AddressRaster::Compute);
  CHECK(resolveAddressRaster(AddressRaster::Auto, "NVIDIA RTX A3000 Laptop GPU/PCIe/SSE2") == AddressRaster::Fragment);
  CHECK(resolveAddressRaster(AddressRaster::Auto, "NVIDIA GeForce RTX 4090/PCIe/SSE2") == AddressRaster::Fragment);
  CHECK(resolveAddressRaster(AddressRaster::Auto, "llvmpipe (LLVM 19.1.7, 256 bits)") == AddressRaster::Fragment);
  CHECK(resolveAddressRaster(AddressRaster::Auto, nullptr) == AddressRaster::Fragment);
  CHECK(resolveAddressRaster(AddressRaster::Fragment, "NVIDIA H200/PCIe/SSE2") == AddressRaster::Fragment);
  CHECK(resolveAddressRaster(AddressRaster::Compute, "llvmpipe (LLVM 19.1.7, 256 bits)") == AddressRaster::Compute);
}

TEST_CASE("material asymmetry and the threshold: below Y nothing changes") {
  // Eq. 5/6 decide the depth; a zero depth leaves the map untouched.
  const double hardEps = 0.95, softEps = 0.2, j = 3.0;
  const double hard = percentDeform(0.1, j, yieldThreshold(hardEps));  // Y = 19: nothing
  const double soft = percentDeform(0.1, j, yieldThreshold(softEps));  // Y = 0.25
  CHECK(hard == 0.0);
  CHECK(soft > 0.0);
  test::glContext();
  SphereIntoPlate s;
  Deformer d({256, Path::Gather});
  const gl::Image h = s.run(d, deformDepth(0.05, hard));
  for (float v : h.pixels) REQUIRE(v == 0.5f);
  CHECK(s.lastStats.texelsChanged == 0);
}

TEST_CASE("address maps larger than 256 address texels exactly (the scatter)") {
  // With 8-bit addresses (the paper), a 1024 map could only reach every fourth texel.
  test::glContext();
  SphereIntoPlate s;
  Deformer d({1024, Path::Scatter});
  const gl::Image h = s.run(d, 0.02);
  // Count changed texels along a row through the dent: they must be contiguous.
  int best = 0;
  for (int y = 0; y < h.height; ++y) {
    int run = 0, longest = 0, changed = 0;
    for (int x = 0; x < h.width; ++x) {
      if (h.at(x, y) < 0.5f) {
        ++run;
        ++changed;
        longest = std::max(longest, run);
      } else {
        run = 0;
      }
    }
    if (changed > best) {
      best = changed;
      CHECK(longest == changed);  // no gaps in the widest row
    }
  }
  CHECK(best > 20);
}

TEST_CASE("repeated hits saturate at 0 and clamp") {
  test::glContext();
  SphereIntoPlate s;
  Deformer d({256, Path::Gather});
  auto maps = d.createMaps(SphereIntoPlate::kRes, nullptr, 0.1f, static_cast<float>(s.plateGpu->metresPerUv / 512));
  Surface plate(s.plateGpu, SphereIntoPlate::kRes, 0.1f, 0.02f, maps);
  const DeformRequest rq = s.pressBall(&plate, 0.04);  // 0.4 of the map per hit: the third hit hits bottom
  SideStats last;
  for (int i = 0; i < 3; ++i) last = d.stats(d.deform(rq), 0);
  const gl::Image h = plate.downloadHeight();
  float lowest = 1;
  for (float v : h.pixels) {
    lowest = std::min(lowest, v);
    REQUIRE(v >= 0.0f);
  }
  CHECK(lowest == 0.0f);
  CHECK(last.saturated);
}

namespace {
// A box B with a bump pattern on its map pressed face-first into a flat plate A.
gl::Image pressPatternedBox(Deformer& d, const gl::Image* pattern, double depthA, double depthB,
                                gl::Image* boxAfter = nullptr) {
  const int res = 256;
  const TriangleMesh plateMesh = boxMesh({2, 0.2, 2}, res), boxMesh_ = boxMesh({0.6, 0.6, 0.6}, res);
  auto plateGpu = std::make_shared<GpuMesh>(plateMesh), boxGpu = std::make_shared<GpuMesh>(boxMesh_);
  Surface plate(plateGpu, res, 0.1f, 0.04f, d.createMaps(res, nullptr, 0.1f, float(plateGpu->metresPerUv / res)));
  Surface box(boxGpu, res, 0.1f, 0.04f, d.createMaps(res, pattern, 0.1f, float(boxGpu->metresPerUv / res)));
  DeformRequest rq;
  rq.a = {&plate, plateGpu.get(), glm::dmat4(1)};
  rq.b = {&box, boxGpu.get(), glm::translate(glm::dmat4(1), glm::dvec3(0, 0.1 + 0.3, 0))};
  rq.point = {0, 0.1, 0};
  rq.normal = {0, 1, 0};
  rq.deformA = depthA;
  rq.deformB = depthB;
  d.deform(rq);
  if (boxAfter) *boxAfter = box.downloadHeight();
  return plate.downloadHeight();
}
}  // namespace

TEST_CASE("a bump pattern on the striking face is printed into the other body (figure 7)") {
  test::glContext();
  Deformer d({512, Path::Gather});
  // Raised stripes on the box's map (everywhere, so whichever face strikes carries them).
  gl::Image stripes(256, 256, 1, 0.5f);
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) stripes.at(x, y) = ((x / 8) % 2) ? 0.95f : 0.5f;
  const gl::Image flatPrint = pressPatternedBox(d, nullptr, 0.002, 0);
  const gl::Image stripedPrint = pressPatternedBox(d, &stripes, 0.002, 0);
  // With a flat striker the dent is uniform; with stripes it has two depth levels (stripes press deeper).
  auto levels = [](const gl::Image& h) {
    std::vector<float> dents;
    for (float v : h.pixels)
      if (v < 0.4999f) dents.push_back(0.5f - v);
    std::sort(dents.begin(), dents.end());
    return dents;
  };
  const auto flat = levels(flatPrint), striped = levels(stripedPrint);
  REQUIRE(flat.size() > 100);
  REQUIRE(striped.size() > 100);
  const float flatSpread = flat[flat.size() * 9 / 10] - flat[flat.size() / 10];
  const float stripedSpread = striped[striped.size() * 9 / 10] - striped[striped.size() / 10];
  MESSAGE("dent depth spread (10th-90th percentile, in map units): flat " << flatSpread << ", striped "
                                                                          << stripedSpread);
  CHECK(flatSpread < 0.005f);
  // The stripes stand (0.95 - 0.5) k' = 0.018 m proud: in the plate's map (k = 0.1) that is 0.18.
  CHECK(stripedSpread > 0.1f);
}

TEST_CASE("material asymmetry: a hard sphere dents a soft plate, the plate does not dent the sphere") {
  test::glContext();
  // Clay plate (eps 0.2) and steel ball (eps 0.95) in one collision with |j_eps=1| = 40.
  const double j = 25, kappa = 0.02;
  const double depthPlate = deformDepth(0.05, percentDeform(kappa, j, yieldThreshold(0.2)));
  const double depthBall = deformDepth(0.005, percentDeform(kappa, j, yieldThreshold(0.95)));
  REQUIRE(depthPlate > 0.01);
  REQUIRE(depthBall > 0);
  REQUIRE(depthBall < depthPlate / 10);
  SphereIntoPlate s;
  Deformer d({256, Path::Gather});
  const TriangleMesh ballMesh = sphereMesh(SphereIntoPlate::R, 256);
  auto ballGpu = std::make_shared<GpuMesh>(ballMesh);
  auto plateMaps = d.createMaps(512, nullptr, 0.1f, float(s.plateGpu->metresPerUv / 512));
  Surface plate(s.plateGpu, 512, 0.1f, 0.02f, plateMaps);
  Surface ball(ballGpu, 256, 0.1f, 0.02f, d.createMaps(256, nullptr, 0.1f, float(ballGpu->metresPerUv / 256)));
  DeformRequest rq;
  rq.a = {&plate, s.plateGpu.get(), s.plateModel};
  rq.b = {&ball, ballGpu.get(), s.ballModel};
  rq.point = {0, 0.1, 0};
  rq.normal = {0, 1, 0};
  rq.deformA = depthPlate;
  rq.deformB = depthBall;
  const int h = d.deform(rq);
  const SideStats a = d.stats(h, 0), b = d.stats(h, 1);
  MESSAGE("plate: " << a.texelsChanged << " texels, " << a.maxDent << " m; ball: " << b.texelsChanged << " texels, "
                    << b.maxDent << " m");
  CHECK(a.maxDent == Approx(depthPlate).epsilon(0.05));
  CHECK(b.maxDent < a.maxDent / 10);
  CHECK(a.texelsChanged > 5 * std::max(b.texelsChanged, 1));
}

TEST_CASE("tangent-space correction: multiply shallows and divide deepens a dent on a curved surface") {
  test::glContext();
  // A ball pressed into the side of a cylinder: away from the contact point the
  // cylinder's normal turns away from N_C, so N . N_C < 1 there.
  const TriangleMesh cylMesh = cylinderMesh(0.3, 1.0, 512);
  auto cylGpu = std::make_shared<GpuMesh>(cylMesh);
  SphereIntoPlate s;
  auto run = [&](TangentMode mode) {
    Deformer d({256, Path::Gather, mode, 0.2f});
    Surface cyl(cylGpu, 512, 0.1f, 0.02f, d.createMaps(512, nullptr, 0.1f, float(cylGpu->metresPerUv / 512)));
    DeformRequest rq;
    rq.a = {&cyl, cylGpu.get(), glm::dmat4(1)};
    rq.b = {nullptr, s.ballGpu.get(), glm::translate(glm::dmat4(1), glm::dvec3(0.3 + SphereIntoPlate::R, 0, 0))};
    rq.point = {0.3, 0, 0};
    rq.normal = {1, 0, 0};
    rq.deformA = 0.03;
    d.deform(rq);
    double volume = 0;
    for (float v : cyl.downloadHeight().pixels) volume += 0.5 - v;
    return volume;
  };
  const double none = run(TangentMode::None), mul = run(TangentMode::Multiply), div = run(TangentMode::Divide);
  MESSAGE("summed dent (map units): none " << none << ", multiply " << mul << ", divide " << div);
  REQUIRE(none > 0);
  CHECK(mul < none * 0.997);
  CHECK(div > none * 1.003);
}

TEST_CASE("a map's highest height bounds its bumps' reach: raised bumps dent a ball that clears the flat surface") {
  // The culls take each map's highest height (SurfaceMaps::highest) for how far its bumps reach. A plate whose
  // map stands at 0.9 everywhere (bumps 8 mm up: 0.4 of its 2 cm collision bump depth) under a ball 5 mm above
  // its flat top must dent where the raised surface meets the ball, on both rasterisers; the same ball over a
  // flat map (highest 0.5: the bumps reach nowhere) dents nothing. A crater rim raises heights: highest 1 after.
  test::glContext();
  SphereIntoPlate s;
  constexpr int kRes = 512;
  gl::Image raised(kRes, kRes, 1);
  std::fill(raised.pixels.begin(), raised.pixels.end(), 0.9f);
  for (AddressRaster raster : {AddressRaster::Fragment, AddressRaster::Compute}) {
    DeformOptions o{256, Path::Gather};
    o.addressRaster = raster;
    Deformer d(o);
    auto dent = [&](const gl::Image* initial, float& highest) {
      Surface plate(s.plateGpu, kRes, 0.1f, 0.02f,
                    d.createMaps(kRes, initial, 0.1f, float(s.plateGpu->metresPerUv / kRes)));
      highest = plate.maps().highest;
      DeformRequest rq = s.pressBall(&plate, 0.001);
      rq.b.model = glm::translate(glm::dmat4(1), glm::dvec3(0, 0.1 + 0.005 + SphereIntoPlate::R, 0));  // 5 mm above
      return d.stats(d.deform(rq), 0);
    };
    float highestRaised = 0, highestFlat = 0;
    const SideStats bumpy = dent(&raised, highestRaised), flat = dent(nullptr, highestFlat);
    MESSAGE(std::string(raster == AddressRaster::Compute ? "compute" : "fragment")
            << ": raised map dented " << bumpy.texelsChanged << " texels, " << bumpy.maxDent << " m; flat map "
            << flat.texelsChanged);
    CHECK(highestRaised == 0.9f);
    CHECK(highestFlat == 0.5f);
    CHECK(bumpy.texelsChanged > 40);
    // The raised surface stands 8 mm up, the plate advanced by 1 mm: 4 mm into a ball 5 mm above.
    CHECK(bumpy.maxDent == Approx(0.004).epsilon(0.15));
    CHECK(flat.texelsChanged == 0);
  }
  DeformOptions o{128, Path::Gather};
  o.craterRims = true;
  Deformer d(o);
  Surface plate(s.plateGpu, kRes, 0.1f, 0.02f, d.createMaps(kRes, nullptr, 0.1f, float(s.plateGpu->metresPerUv / kRes)));
  CHECK(plate.maps().highest == 0.5f);
  const DeformRequest rq = s.pressBall(&plate, 0.01);
  REQUIRE(d.stats(d.deform(rq), 0).texelsChanged > 0);
  CHECK(plate.maps().highest == 1.0f);
}

TEST_CASE("lazy maps: bodies share the undeformed map until their first dent") {
  test::glContext();
  SphereIntoPlate s;
  Deformer d({256, Path::Gather});
  auto shared = d.createMaps(512, nullptr, 0.1f, float(s.plateGpu->metresPerUv / 512));
  Surface p1(s.plateGpu, 512, 0.1f, 0.02f, shared), p2(s.plateGpu, 512, 0.1f, 0.02f, shared);
  CHECK(p1.isShared());
  CHECK(p1.height().id() == p2.height().id());
  const DeformRequest rq = s.pressBall(&p1, 0.01);
  d.deform(rq);
  CHECK(p1.height().id() != p2.height().id());  // p1 got its own map at its first dent
  float low1 = 1, low2 = 1;
  for (float v : p1.downloadHeight().pixels) low1 = std::min(low1, v);
  for (float v : p2.downloadHeight().pixels) low2 = std::min(low2, v);
  CHECK(low1 < 0.45f);
  CHECK(low2 == 0.5f);  // the other body's (shared) map is untouched
}

TEST_CASE("crater rims: the volume pushed down rises in a ring around the dent, on every path") {
  test::glContext();
  SphereIntoPlate s;
  auto run = [&](Path path, bool rims) {
    DeformOptions o;
    o.addressMap = 256;
    o.path = path;
    o.craterRims = rims;
    Deformer d(o);
    return s.run(d, 0.02);
  };
  for (Path path : {Path::Gather, Path::Scatter}) {
    const std::string name = pathName(path);
    CAPTURE(name);
    const gl::Image plain = run(path, false), gpu = run(path, true);
    double down = 0, up = 0, plainDown = 0;
    int raised = 0;
    for (size_t i = 0; i < gpu.pixels.size(); ++i) {
      if (gpu.pixels[i] < 0.5f) down += 0.5 - gpu.pixels[i];
      if (gpu.pixels[i] > 0.5f) {
        up += gpu.pixels[i] - 0.5;
        ++raised;
      }
      if (plain.pixels[i] < 0.5f) plainDown += 0.5 - plain.pixels[i];
    }
    MESSAGE(name << ": dent volume " << down << ", rim volume " << up << " over " << raised << " texels");
    CHECK(down == Approx(plainDown).epsilon(1e-6));  // the dent itself is unchanged
    CHECK(raised > 20);
    CHECK(up == Approx(down).epsilon(0.01));  // volume conserved
  }
  const gl::Image scatter = run(Path::Scatter, true), readback = run(Path::Readback, true);
  double diff = 0;
  for (size_t i = 0; i < scatter.pixels.size(); ++i)
    diff = std::max(diff, double(std::abs(scatter.pixels[i] - readback.pixels[i])));
  CHECK(diff <= 1e-5);  // the scatter's GPU and read-back twins agree
}

namespace {
// One deformation of a clay body X (map `res`) by a hard body O, at `address`.
gl::Image pressInto(Path path, int address, const TriangleMesh& xMesh, const glm::dmat4& xModel, int res,
                        const TriangleMesh& oMesh, const glm::dmat4& oModel, glm::dvec3 point, glm::dvec3 normal,
                        double depth) {
  Deformer d({address, path});
  auto xGpu = std::make_shared<GpuMesh>(xMesh);
  auto oGpu = std::make_shared<GpuMesh>(oMesh);
  Surface x(xGpu, res, 0.1f, 0.02f, d.createMaps(res, nullptr, 0.1f, float(xGpu->metresPerUv / res)));
  DeformRequest rq;
  rq.a = {&x, xGpu.get(), xModel};
  rq.b = {nullptr, oGpu.get(), oModel};
  rq.point = point;
  rq.normal = normal;
  rq.deformA = depth;
  d.deform(rq);
  return x.downloadHeight();
}
}  // namespace

TEST_CASE("a long scrape: a 4 m clay body (map 2048) along a steel wall leaves one continuous dent, no holes") {
  // The body's side leans 10 degrees off the wall, so the wall cuts a strip
  // along its whole length: 5 to 6 texels of the map fall in each of the 256
  // address-map pixels across it, where the paper's scatter skips texels.
  test::glContext();
  const int res = 2048;
  const TriangleMesh body = boxMesh({4, 1, 1}, res), wall = boxMesh({8, 2, 0.4}, 256);
  const double lean = glm::radians(10.0);
  const glm::dmat4 bodyModel = glm::rotate(glm::dmat4(1), lean, glm::dvec3(1, 0, 0));
  // The body's far top edge (z = 0.5, y = 0.5 rotated) reaches z_max; the wall starts 1 cm inside it.
  const double zMax = 0.5 * std::cos(lean) + 0.5 * std::sin(lean);
  const glm::dmat4 wallModel = glm::translate(glm::dmat4(1), glm::dvec3(0, 0, zMax - 0.01 + 0.2));
  const gl::Image flat(res, res, 1, 0.5f);
  const auto surface = onSurface(body, res);
  auto run = [&](Path path) {
    return pressInto(path, 256, body, bodyModel, res, wall, wallModel, {0, 0.3, zMax - 0.005}, {0, 0, 1}, 0.004);
  };
  const auto gather = test::dentContinuity(flat, run(Path::Gather), surface);
  const auto scatter = test::dentContinuity(flat, run(Path::Scatter), surface);
  MESSAGE("gather: " << gather.dented << " texels dented, continuity " << gather.continuity << ", holes "
                     << gather.holeFraction() << "; the paper's scatter: " << scatter.dented << " texels, continuity "
                     << scatter.continuity << ", holes " << scatter.holeFraction());
  CHECK(gather.dented > 20000);
  CHECK(gather.continuity >= 0.93);
  CHECK(gather.holeFraction() < 0.01);
  CHECK(scatter.continuity < gather.continuity);  // the gaps the gather closes
}

TEST_CASE("an oblique hit: a steel ball on a 45-degree edge of a clay block, address map 128, dents without stripes") {
  test::glContext();
  const int res = 1024;
  const TriangleMesh block = boxMesh({0.5, 0.5, 0.5}, res), ball = sphereMesh(0.2, 256);
  // The block stands on its edge: rotated 45 degrees about z, its top edge along z at y = 0.5 / sqrt(2).
  const glm::dmat4 blockModel = glm::rotate(glm::dmat4(1), glm::radians(45.0), glm::dvec3(0, 0, 1));
  const double top = 0.25 * std::sqrt(2.0);
  const glm::dmat4 ballModel = glm::translate(glm::dmat4(1), glm::dvec3(0, top + 0.2, 0));
  const gl::Image flat(res, res, 1, 0.5f);
  const auto surface = onSurface(block, res);
  auto run = [&](Path path, int address) {
    return pressInto(path, address, block, blockModel, res, ball, ballModel, {0, top, 0}, {0, 1, 0}, 0.03);
  };
  for (int address : {128, 512}) {
    const auto gather = test::dentContinuity(flat, run(Path::Gather, address), surface);
    const auto scatter = test::dentContinuity(flat, run(Path::Scatter, address), surface);
    MESSAGE("address map " << address << ": gather " << gather.dented << " texels, continuity " << gather.continuity
                           << ", holes " << gather.holeFraction() << "; scatter " << scatter.dented
                           << " texels, continuity " << scatter.continuity << ", holes " << scatter.holeFraction());
    CHECK(gather.dented > 2000);
    CHECK(gather.continuity >= 0.93);
    CHECK(gather.holeFraction() < 0.01);
  }
  // The same dent at either address map: only its shape's accuracy may differ.
  const gl::Image coarse = run(Path::Gather, 128), fine = run(Path::Gather, 512);
  int differ = 0, dented = 0;
  double worst = 0;
  for (size_t i = 0; i < fine.pixels.size(); ++i) {
    dented += fine.pixels[i] < 0.5f;
    differ += (coarse.pixels[i] < 0.5f) != (fine.pixels[i] < 0.5f);
    worst = std::max(worst, double(std::abs(coarse.pixels[i] - fine.pixels[i])) * 0.1);
  }
  MESSAGE("128 vs 512: " << differ << " of " << dented << " texels differ in being dented, depth differs by at most "
                         << worst << " m");
  CHECK(differ <= dented / 50);
  CHECK(worst < 0.002);
}

TEST_CASE("chart levels: a crushed chart's coarse levels stay crushed to its edges; level 0 is unchanged") {
  // A 12 cm box (one uv chart a face, gutters between) whose top's chart is crushed to 0 in every texel whose
  // centre lies on it, the gutters and other faces flat (0.5). Levels made by averaging every texel (GL's) would
  // blend the gutters' 0.5 into the top's edge; over the charts alone each level's texel is the mean of the
  // covered level-0 texels under it, so one over the top's texels and gutter alone reads 0.
  test::glContext();
  const int res = 128;
  const float k = 0.1f;
  const TriangleMesh mesh = boxMesh({0.12, 0.12, 0.12}, res);
  auto gpu = std::make_shared<GpuMesh>(mesh);
  gl::Image map(res, res, 1, 0.5f);
  int crushed = 0;
  for (const glm::uvec3& t : mesh.triangles) {
    if (mesh.normals[t.x].y < 0.9f) continue;
    const glm::dvec2 a = glm::dvec2(mesh.uvs[t.x]) * double(res), b = glm::dvec2(mesh.uvs[t.y]) * double(res),
                     c = glm::dvec2(mesh.uvs[t.z]) * double(res);
    auto side = [](glm::dvec2 p, glm::dvec2 q, glm::dvec2 r) {
      return (q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x);
    };
    for (int y = 0; y < res; ++y)
      for (int x = 0; x < res; ++x) {
        const glm::dvec2 p(x + 0.5, y + 0.5);
        const double s0 = side(a, b, p), s1 = side(b, c, p), s2 = side(c, a, p);
        if ((s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0)) {
          crushed += map.at(x, y) != 0.0f;
          map.at(x, y) = 0.0f;
        }
      }
  }
  REQUIRE(crushed > 100);
  Deformer d({256, Path::Gather});
  Surface box(gpu, res, k, 0.02f, d.createMaps(res, &map, k, float(gpu->metresPerUv / res)));
  const GLuint id = box.height().id();
  auto level = [&](int l) {
    const int w = std::max(1, res >> l);
    std::vector<float> out(static_cast<size_t>(w) * static_cast<size_t>(w));
    glGetTextureImage(id, l, GL_RED, GL_FLOAT, static_cast<GLsizei>(out.size() * sizeof(float)), out.data());
    return out;
  };
  const std::vector<float> before = level(0);
  // GL's levels: the top's edge blends with the gutter.
  const std::shared_ptr<const ChartCover> cover = ChartCover::of(*gpu, res);
  REQUIRE(cover->offsets.size() == 8u);
  std::vector<float> weights(cover->cover.size() / sizeof(float));
  glGetNamedBufferSubData(cover->cover.id(), 0, GLsizeiptr(weights.size() * sizeof(float)), weights.data());
  // Per level, the texels over crushed texels and gutter alone (every covered level-0 texel under them crushed).
  auto overCrushedOnly = [&](int l, const std::vector<float>& h) {
    const int w = std::max(1, res >> l), span = 1 << l;
    double worst = 0;
    int count = 0;
    for (int y = 0; y < w; ++y)
      for (int x = 0; x < w; ++x) {
        bool any = false, all = true;
        for (int j = y * span; j < (y + 1) * span; ++j)
          for (int i = x * span; i < (x + 1) * span; ++i) {
            if (weights[static_cast<size_t>(j) * res + static_cast<size_t>(i)] == 0.0f) continue;
            any = true;
            all = all && before[static_cast<size_t>(j) * res + static_cast<size_t>(i)] == 0.0f;
          }
        if (!any || !all) continue;
        ++count;
        worst = std::max(worst, double(h[static_cast<size_t>(y) * w + static_cast<size_t>(x)]));
      }
    return std::make_pair(count, worst);
  };
  const auto glLevels = overCrushedOnly(2, level(2));
  d.chartLevels(box);
  std::vector<float> after = level(0);
  CHECK(std::memcmp(before.data(), after.data(), before.size() * sizeof(float)) == 0);
  double worst = 0;
  for (int l = 1; l < 8; ++l) {
    const auto [count, high] = overCrushedOnly(l, level(l));
    if (l <= 3) CHECK(count > 0);
    worst = std::max(worst, high);
  }
  // And a covered texel of level 1 is its covered children's weighted mean.
  const std::vector<float> one = level(1);
  double meanError = 0;
  for (int y = 0; y < res / 2; ++y)
    for (int x = 0; x < res / 2; ++x) {
      double sum = 0, weight = 0;
      for (int j = 2 * y; j < 2 * y + 2; ++j)
        for (int i = 2 * x; i < 2 * x + 2; ++i) {
          const double c = weights[static_cast<size_t>(j) * res + static_cast<size_t>(i)];
          sum += c * before[static_cast<size_t>(j) * res + static_cast<size_t>(i)];
          weight += c;
        }
      if (weight > 0)
        meanError = std::max(meanError,
                             std::abs(sum / weight - one[static_cast<size_t>(y) * (res / 2) + static_cast<size_t>(x)]));
    }
  MESSAGE("level 2 over the crushed chart and gutter alone: GL's levels up to "
          << glLevels.second << " (" << glLevels.first << " texels), chart levels up to " << worst);
  CHECK(glLevels.second > 0.1);  // (what the chart levels are for)
  CHECK(worst < 1e-6);
  CHECK(meanError < 1e-6);
}

TEST_CASE("the crease bevel: a crushed face's neighbours follow it to within an edge's length, far ones stay") {
  // A 12 cm box (3 cm quads, one uv chart a face) whose top's map is crushed to the floor (5 cm in, k 0.1) and
  // whose other faces are untouched: drawn by its heights alone, the sides would stand 5 cm proud of the top's
  // edge. The bevel brings every node to within an edge's length of where a neighbour that moved further went.
  test::glContext();
  const int res = 128;
  const float k = 0.1f;
  const TriangleMesh mesh = boxMesh({0.12, 0.12, 0.12}, res);
  auto gpu = std::make_shared<GpuMesh>(mesh);
  REQUIRE(gpu->nodeCount > 0);
  gl::Image map(res, res, 1, 0.5f);
  for (const glm::uvec3& t : mesh.triangles) {  // the top's texels (their centres in its triangles, and a texel around)
    if (mesh.normals[t.x].y < 0.9f) continue;
    const glm::vec2 a = mesh.uvs[t.x] * float(res), b = mesh.uvs[t.y] * float(res), c = mesh.uvs[t.z] * float(res);
    const glm::ivec2 lo = glm::clamp(glm::ivec2(glm::floor(glm::min(a, glm::min(b, c)))) - 1, 0, res - 1);
    const glm::ivec2 hi = glm::clamp(glm::ivec2(glm::ceil(glm::max(a, glm::max(b, c)))) + 1, 0, res - 1);
    for (int y = lo.y; y <= hi.y; ++y)
      for (int x = lo.x; x <= hi.x; ++x) map.at(x, y) = 0.0f;
  }
  Deformer d({256, Path::Gather});
  Surface box(gpu, res, k, 0.02f, d.createMaps(res, &map, k, float(gpu->metresPerUv / res)));
  d.creaseBevel(box);
  CHECK(box.crease() == nullptr);  // a map no commit changed: nothing to make
  box.changed();
  d.creaseBevel(box);
  REQUIRE(box.crease() != nullptr);
  std::vector<GLuint> node(mesh.positions.size());
  std::vector<glm::vec4> moved(gpu->nodeCount);
  glGetNamedBufferSubData(gpu->vertexNodes.id(), 0, GLsizeiptr(node.size() * sizeof(GLuint)), node.data());
  glGetNamedBufferSubData(box.crease()->id(), 0, GLsizeiptr(moved.size() * sizeof(glm::vec4)), moved.data());
  // The gaps past an edge's length between a node and a neighbour that moved further (by more than 0.1 mm: the
  // relaxation's promise), and between neighbours that moved as far in other directions (the top's edge goes in
  // along its averaged normal, the top's middle straight down: a stretch the bevel does not undo, not a wall).
  double worstGap = 0, evenGap = 0, followed = 0, farthest = 0;
  for (const glm::uvec3& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      const glm::vec3 p = mesh.positions[t[e]], q = mesh.positions[t[(e + 1) % 3]];
      const glm::vec3 a(moved[node[t[e]]]), b(moved[node[t[(e + 1) % 3]]]);
      double& worst = std::abs(glm::length(a) - glm::length(b)) > 1e-4f ? worstGap : evenGap;
      worst = std::max(worst, double(glm::distance(a, b) - glm::distance(p, q)));
    }
  for (size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::vec3 p = mesh.positions[v], m(moved[node[v]]);
    if (std::abs(p.x) > 0.059f && std::abs(p.y - 0.03f) < 1e-4f)  // a side's nodes 3 cm below the top's edge
      followed = std::max(followed, double(-p.x / std::abs(p.x) * m.x));
    if (p.y < -0.059f && std::abs(p.x) < 1e-4f && std::abs(p.z) < 1e-4f)  // the bottom's centre, 12 cm away
      farthest = std::max(farthest, double(glm::length(m)));
  }
  MESSAGE("largest gap past an edge's length from a deeper neighbour "
          << worstGap * 1000 << " mm (between neighbours as deep: " << evenGap * 1000
          << " mm); a side's node 3 cm under the top moved " << followed * 1000 << " mm in; the bottom's centre "
          << farthest * 1000 << " mm");
  CHECK(worstGap < 1e-4);
  // (the top's edge went in along its averaged normal by its height read as the renderer reads it there, the top's
  // 5 cm (its chart's levels: Deformer::chartLevels), so the side 3 cm below follows it in by about 1.4 cm)
  CHECK(followed > 0.01);
  CHECK(farthest < 1e-6);
}
