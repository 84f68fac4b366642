// Imported glTF models keep their looks: a box written here through tinygltf, with a checker base-colour texture
// and a metallic-roughness texture, renders at each checker cell as a plain body of that cell's colour, metallic
// and roughness does; scene keys given explicitly replace the file's.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>

// As engine/mesh_gltf.cpp compiles tinygltf (its implementation is linked from there).
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <stb/stb_image.h>
#include <tiny_gltf.h>

#include <crumple/engine/mesh_io.h>
#include <crumple/engine/scene_view.h>
#include <crumple/engine/simulation.h>
#include "gl_fixture.h"
#include <crumple/render/look.h>
#include <crumple/render/renderer.h>

using namespace crumple;
using namespace crumple::gl;
using namespace crumple::render;
namespace fs = std::filesystem;

namespace {

// The checker's four cells (sRGB bytes), cell (i, j) covering u in [i/2, (i+1)/2), v in [j/2, (j+1)/2).
const glm::ivec3 kCell[2][2] = {{{200, 40, 30}, {30, 60, 200}}, {{220, 200, 40}, {40, 170, 90}}};
// Metallic-roughness texture: u < 0.5 a rough dielectric, u >= 0.5 a smoother metal (G roughness, B metallic).
const glm::ivec2 kMr[2] = {{230, 0}, {77, 255}};  // (G, B)

void addBytes(tinygltf::Model& m, const void* data, size_t bytes, int target) {
  auto& buf = m.buffers[0].data;
  while (buf.size() % 4) buf.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buf.size();
  view.byteLength = bytes;
  view.target = target;
  const auto* p = static_cast<const unsigned char*>(data);
  buf.insert(buf.end(), p, p + bytes);
  m.bufferViews.push_back(view);
}
int addAccessor(tinygltf::Model& m, const void* data, size_t count, int type, int componentType, int target) {
  const size_t size = static_cast<size_t>(tinygltf::GetNumComponentsInType(static_cast<uint32_t>(type)) *
                                          tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(componentType)));
  addBytes(m, data, count * size, target);
  tinygltf::Accessor a;
  a.bufferView = static_cast<int>(m.bufferViews.size() - 1);
  a.count = count;
  a.type = type;
  a.componentType = componentType;
  m.accessors.push_back(a);
  return static_cast<int>(m.accessors.size() - 1);
}

// A 2 x 0.1 x 2 box, every face mapped over the whole texture (so crumple regenerates its atlas for the dents and
// keeps these uvs for the look), with the checker and metallic-roughness images beside it.
fs::path writeCheckerBox(const fs::path& dir) {
  fs::create_directories(dir);
  const int n = 64;
  Image base(n, n, 3), mr(n, n, 3);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int i = x < n / 2 ? 0 : 1, j = y < n / 2 ? 0 : 1;
      for (int c = 0; c < 3; ++c) base.at(x, y, c) = kCell[i][j][c] / 255.0f;
      mr.at(x, y, 0) = 1.0f;
      mr.at(x, y, 1) = kMr[i].x / 255.0f;
      mr.at(x, y, 2) = kMr[i].y / 255.0f;
    }
  writePng((dir / "checker.png").string(), base, 8);
  writePng((dir / "mr.png").string(), mr, 8);

  std::vector<glm::vec3> pos, nrm;
  std::vector<glm::vec2> uv;
  std::vector<uint32_t> idx;
  const glm::vec3 half(1.0f, 0.05f, 1.0f);
  for (int axis = 0; axis < 3; ++axis)
    for (int sign = -1; sign <= 1; sign += 2) {
      glm::vec3 nn(0);
      nn[axis] = static_cast<float>(sign);
      // u along +x on the top face, v along +z (image rows run towards +z).
      const glm::vec3 a = axis == 1 ? glm::vec3(1, 0, 0) : axis == 0 ? glm::vec3(0, 0, 1) : glm::vec3(1, 0, 0);
      const glm::vec3 b = glm::cross(nn, a) * -1.0f;
      const auto base0 = static_cast<uint32_t>(pos.size());
      for (int k = 0; k < 4; ++k) {
        const float s = (k == 1 || k == 2) ? 1.0f : -1.0f, t = k >= 2 ? 1.0f : -1.0f;
        pos.push_back((nn + a * s + b * t) * half);
        nrm.push_back(nn);
        uv.push_back({0.5f * (s + 1), 0.5f * (t + 1)});
      }
      // Counter-clockwise seen from outside.
      const bool ccw = glm::dot(glm::cross(a, b), nn) > 0;
      if (ccw)
        idx.insert(idx.end(), {base0, base0 + 1, base0 + 2, base0, base0 + 2, base0 + 3});
      else
        idx.insert(idx.end(), {base0, base0 + 2, base0 + 1, base0, base0 + 3, base0 + 2});
    }

  tinygltf::Model m;
  m.asset.version = "2.0";
  m.buffers.emplace_back();
  m.buffers[0].uri = "box.bin";
  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.attributes["POSITION"] = addAccessor(m, pos.data(), pos.size(), TINYGLTF_TYPE_VEC3,
                                            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TARGET_ARRAY_BUFFER);
  m.accessors.back().minValues = {-1, -0.05, -1};
  m.accessors.back().maxValues = {1, 0.05, 1};
  prim.attributes["NORMAL"] = addAccessor(m, nrm.data(), nrm.size(), TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                          TINYGLTF_TARGET_ARRAY_BUFFER);
  prim.attributes["TEXCOORD_0"] = addAccessor(m, uv.data(), uv.size(), TINYGLTF_TYPE_VEC2,
                                              TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TARGET_ARRAY_BUFFER);
  prim.indices = addAccessor(m, idx.data(), idx.size(), TINYGLTF_TYPE_SCALAR, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                             TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  for (const char* file : {"checker.png", "mr.png"}) {
    tinygltf::Image im;
    im.uri = file;
    im.mimeType = "image/png";
    m.images.push_back(im);
    tinygltf::Texture t;
    t.source = static_cast<int>(m.images.size() - 1);
    m.textures.push_back(t);
  }
  tinygltf::Material mat;
  mat.pbrMetallicRoughness.baseColorFactor = {1, 1, 1, 1};
  mat.pbrMetallicRoughness.metallicFactor = 1;
  mat.pbrMetallicRoughness.roughnessFactor = 1;
  mat.pbrMetallicRoughness.baseColorTexture.index = 0;
  mat.pbrMetallicRoughness.metallicRoughnessTexture.index = 1;
  m.materials.push_back(mat);
  prim.material = 0;
  tinygltf::Mesh mesh;
  mesh.primitives.push_back(prim);
  m.meshes.push_back(mesh);
  tinygltf::Node node;
  node.mesh = 0;
  m.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  m.scenes.push_back(scene);
  m.defaultScene = 0;
  tinygltf::TinyGLTF writer;
  REQUIRE(writer.WriteGltfSceneToFile(&m, (dir / "box.gltf").string(), false, false, true, false));
  return dir / "box.gltf";
}

View lookDown() {
  View v;
  v.eye = {0.0f, 2.6f, 1.6f};
  v.target = {0, 0, 0};
  v.fovDegrees = 50;
  return v;
}

// The pixel (x right, y down as read back) where world point p lands.
glm::ivec2 project(const View& v, int w, int h, glm::vec3 p) {
  const glm::mat4 vp = glm::perspective(glm::radians(v.fovDegrees), float(w) / float(h), v.zNear, v.zFar) *
                       glm::lookAt(v.eye, v.target, v.up);
  const glm::vec4 c = vp * glm::vec4(p, 1);
  const glm::vec2 ndc = glm::vec2(c) / c.w;
  return {static_cast<int>((ndc.x * 0.5f + 0.5f) * w), static_cast<int>((0.5f - ndc.y * 0.5f) * h)};
}

float srgbToLinear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

// The colour a plain item must be given so that the shader's pow(c, 2.2) equals the sRGB texture's decode.
glm::vec3 plainColor(glm::ivec3 srgb) {
  glm::vec3 c;
  for (int k = 0; k < 3; ++k) c[k] = std::pow(srgbToLinear(srgb[k] / 255.0f), 1.0f / 2.2f);
  return c;
}

std::string sceneText(const std::string& material) {
  return R"({"materials": {"m": {)" + material + R"(}},
    "bodies": [{"name": "box", "shape": {"type": "mesh", "file": "box.gltf"}, "material": "m", "static": true,
                "position": [0, -0.05, 0]}]})";
}

}  // namespace

TEST_CASE("a glTF's materials and images are read with the mesh") {
  const fs::path file = writeCheckerBox(fs::temp_directory_path() / "crumple-looks-read");
  Look look;
  const TriangleMesh mesh = loadMeshFile(file.string(), &look);
  REQUIRE(look.materials.size() == 1);
  REQUIRE(look.images.size() == 2);
  CHECK(look.materials[0].baseColorImage == 0);
  CHECK(look.materials[0].metallicRoughnessImage == 1);
  CHECK(look.materials[0].normalImage == -1);
  CHECK(look.images[0].width == 64);
  // Texel (40, 10): cell (1, 0).
  const size_t at = (10 * 64 + 40) * 4;
  CHECK(int(look.images[0].rgba[at]) == kCell[1][0].x);
  CHECK(int(look.images[0].rgba[at + 2]) == kCell[1][0].z);
  CHECK(int(look.images[1].rgba[at + 1]) == kMr[1].x);
  REQUIRE(mesh.materialUvs.size() == mesh.positions.size());
  REQUIRE(mesh.materialIds.size() == mesh.positions.size());
  for (int id : mesh.materialIds) CHECK(id == 0);
  // Without a look asked for, nothing of it is read.
  const TriangleMesh plain = loadMeshFile(file.string());
  CHECK(plain.materialUvs.empty());
}

TEST_CASE("an imported glTF renders with its own base colour and metallic-roughness textures") {
  test::glContext();
  const fs::path dir = fs::temp_directory_path() / "crumple-looks-render";
  writeCheckerBox(dir);
  const int w = 240, h = 180;
  Renderer r(w, h);
  const View view = lookDown();

  auto render = [&](const std::string& material, auto&& edit) {
    Simulation sim(parseScene(sceneText(material), "looks.json", dir.string()), true);
    std::vector<RenderItem> items = renderItems(sim);
    REQUIRE(items.size() == 1);
    edit(items[0]);
    r.draw(items, view);
    return r.readPixels();
  };
  const Image looked = render("", [](RenderItem& it) { REQUIRE(it.look != nullptr); });
  r.savePng((dir / "looked.png").string());

  int checked = 0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      // Cell centre on the top face: u = (i + 0.5) / 2 along x from -1, v along z from -1.
      const glm::vec3 centre(-1.0f + (i + 0.5f), 0.0f, -1.0f + (j + 0.5f));
      const glm::ivec2 px = project(view, w, h, centre);
      REQUIRE(px.x > 5);
      REQUIRE(px.x < w - 5);
      REQUIRE(px.y > 5);
      REQUIRE(px.y < h - 5);
      const Image plain = render("", [&](RenderItem& it) {
        it.look = nullptr;
        it.color = plainColor(kCell[i][j]);
        it.roughness = kMr[i].x / 255.0f;
        it.metallic = kMr[i].y / 255.0f;
      });
      float worst = 0;
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(looked.at(px.x, px.y, c) - plain.at(px.x, px.y, c)));
      MESSAGE("cell (" << i << ", " << j << ") at pixel (" << px.x << ", " << px.y << "): rgb " << looked.at(px.x, px.y, 0) * 255
                       << " " << looked.at(px.x, px.y, 1) * 255 << " " << looked.at(px.x, px.y, 2) * 255
                       << ", off from the plain body by " << worst * 255 << "/255");
      CHECK(worst <= 3.0f / 255.0f);
      // And it is that cell's colour, not another's: the dominant channel matches.
      const glm::ivec3 want = kCell[i][j];
      const int wantMax = want.x >= want.y && want.x >= want.z ? 0 : want.y >= want.z ? 1 : 2;
      int gotMax = 0;
      for (int c = 1; c < 3; ++c)
        if (looked.at(px.x, px.y, c) > looked.at(px.x, px.y, gotMax)) gotMax = c;
      if (!(want.x == 220 && want.y == 200)) CHECK(gotMax == wantMax);  // yellow: red and green both high
      ++checked;
    }
  CHECK(checked == 4);

  // The scene's explicit colour and roughness replace the file's; its metallic (not given) still comes from the file.
  const Image overridden = render(R"("color": [0.2, 0.6, 0.9], "roughness": 0.5)", [](RenderItem&) {});
  for (int i = 0; i < 2; ++i) {
    const glm::ivec2 px = project(view, w, h, {-1.0f + (i + 0.5f), 0.0f, -0.5f});
    const Image plain = render(R"("color": [0.2, 0.6, 0.9], "roughness": 0.5)", [&](RenderItem& it) {
      it.look = nullptr;
      it.metallic = kMr[i].y / 255.0f;
    });
    float worst = 0;
    for (int c = 0; c < 3; ++c)
      worst = std::max(worst, std::abs(overridden.at(px.x, px.y, c) - plain.at(px.x, px.y, c)));
    MESSAGE("scene colour over the file's, half " << i << ": off by " << worst * 255 << "/255");
    CHECK(worst <= 3.0f / 255.0f);
  }
}
