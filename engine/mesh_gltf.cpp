// glTF 2.0 and GLB through tinygltf: every primitive of the default scene with its node transforms, merged into
// one mesh. The document is checked first (gltf_check.cpp) for what tinygltf lets through silently. Errors name
// the file and the document's key path.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <stb/stb_image.h>
#include <tiny_gltf.h>

#include <crumple/core/log.h>
#include <crumple/engine/mesh_io.h>
#include <crumple/engine/gltf_check.h>
#include <crumple/engine/mesh_io_detail.h>
#include <crumple/render/look.h>

namespace crumple {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// Bounds-checked reads from glTF accessors.
class AccessorReader {
 public:
  AccessorReader(const tinygltf::Model& m, int index, const std::string& what) : what_(what) {
    if (index < 0 || index >= static_cast<int>(m.accessors.size()))
      throw MeshError(what + ": accessor " + std::to_string(index) + " does not exist");
    acc_ = &m.accessors[static_cast<size_t>(index)];
    if (acc_->sparse.isSparse) throw MeshError(what + ": sparse accessors are not supported");
    if (acc_->bufferView < 0 || acc_->bufferView >= static_cast<int>(m.bufferViews.size()))
      throw MeshError(what + ": accessor " + std::to_string(index) + " has no valid bufferView");
    const auto& view = m.bufferViews[static_cast<size_t>(acc_->bufferView)];
    if (view.buffer < 0 || view.buffer >= static_cast<int>(m.buffers.size()))
      throw MeshError(what + ": bufferView " + std::to_string(acc_->bufferView) + " points at a missing buffer");
    const auto& buffer = m.buffers[static_cast<size_t>(view.buffer)];
    components_ = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(acc_->type));
    componentSize_ = tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(acc_->componentType));
    if (components_ <= 0 || componentSize_ <= 0) throw MeshError(what + ": unknown accessor type");
    const size_t elementSize = static_cast<size_t>(components_ * componentSize_);
    stride_ = view.byteStride ? view.byteStride : elementSize;
    if (stride_ < elementSize) throw MeshError(what + ": byteStride smaller than the element");
    const size_t start = view.byteOffset + acc_->byteOffset;
    count_ = acc_->count;
    if (view.byteOffset + view.byteLength > buffer.data.size())
      throw MeshError(what + ": bufferView runs past the end of its buffer (missing or short .bin?)");
    if (count_ > 0 && (acc_->byteOffset + (count_ - 1) * stride_ + elementSize > view.byteLength))
      throw MeshError(what + ": accessor runs past the end of its bufferView");
    data_ = buffer.data.data() + start;
  }
  size_t count() const { return count_; }
  int components() const { return components_; }
  double get(size_t i, int c) const {
    const unsigned char* p = data_ + i * stride_ + static_cast<size_t>(c * componentSize_);
    switch (acc_->componentType) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float f;
        std::memcpy(&f, p, 4);
        return f;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return acc_->normalized ? *p / 255.0 : *p;
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        int8_t v;
        std::memcpy(&v, p, 1);
        return acc_->normalized ? std::max(v / 127.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return acc_->normalized ? v / 65535.0 : v;
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t v;
        std::memcpy(&v, p, 2);
        return acc_->normalized ? std::max(v / 32767.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return v;
      }
      default:
        throw MeshError(what_ + ": unsupported component type");
    }
  }
  uint32_t index(size_t i) const {
    const unsigned char* p = data_ + i * stride_;
    switch (acc_->componentType) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return *p;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return v;
      }
      default:
        throw MeshError(what_ + ": indices must be unsigned byte, short or int");
    }
  }

 private:
  const tinygltf::Accessor* acc_ = nullptr;
  const unsigned char* data_ = nullptr;
  size_t stride_ = 0, count_ = 0;
  int components_ = 0, componentSize_ = 0;
  std::string what_;
};

glm::dmat4 nodeMatrix(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) {
    glm::dmat4 m;
    for (int i = 0; i < 16; ++i) glm::value_ptr(m)[i] = n.matrix[static_cast<size_t>(i)];
    return m;
  }
  glm::dmat4 m(1);
  if (n.translation.size() == 3)
    m = glm::translate(m, glm::dvec3(n.translation[0], n.translation[1], n.translation[2]));
  if (n.rotation.size() == 4)
    m *= glm::mat4_cast(glm::normalize(glm::dquat(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2])));
  if (n.scale.size() == 3) m = glm::scale(m, glm::dvec3(n.scale[0], n.scale[1], n.scale[2]));
  return m;
}

// External buffers (a .gltf's "uri": "x.bin") are read only when they are regular files of at most 1 GiB: not a
// folder, a FIFO or /dev/zero.
bool readBuffer(std::vector<unsigned char>* out, std::string* err, const std::string& file, void*) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec) || fs::file_size(file, ec) > meshio::kMaxFileBytes) {
    if (err) *err += "buffer " + capText(file, 200) + " is not a regular file of at most 1 GiB\n";
    return false;
  }
  std::ifstream in(file, std::ios::binary);
  out->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) {
    if (err) *err += "cannot read " + capText(file, 200) + "\n";
    return false;
  }
  return true;
}

void appendPrimitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const glm::dmat4& xf,
                     const std::string& what, TriangleMesh& out, bool& anyUv, const int* materialId = nullptr) {
  const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
    return;
  auto pos = prim.attributes.find("POSITION");
  if (pos == prim.attributes.end()) throw MeshError(what + ": primitive has no POSITION");
  AccessorReader p(model, pos->second, what + ".attributes.POSITION");
  if (p.components() != 3) throw MeshError(what + ": POSITION must be VEC3");
  std::unique_ptr<AccessorReader> nrm, uv;
  if (auto it = prim.attributes.find("NORMAL"); it != prim.attributes.end()) {
    nrm = std::make_unique<AccessorReader>(model, it->second, what + ".attributes.NORMAL");
    if (nrm->components() != 3 || nrm->count() != p.count()) nrm.reset();
  }
  if (auto it = prim.attributes.find("TEXCOORD_0"); it != prim.attributes.end()) {
    uv = std::make_unique<AccessorReader>(model, it->second, what + ".attributes.TEXCOORD_0");
    if (uv->components() != 2 || uv->count() != p.count())
      throw MeshError(what + ": TEXCOORD_0 must be VEC2 with one per vertex");
  }
  const glm::dmat3 normalXf = glm::transpose(glm::inverse(glm::dmat3(xf)));
  const bool flip = glm::determinant(glm::dmat3(xf)) < 0;
  if (out.positions.size() + p.count() > 3 * meshio::kMaxTriangles)
    throw MeshError(what + ": the default scene makes more than " + std::to_string(3 * meshio::kMaxTriangles) +
                    " vertices");
  const auto base = static_cast<uint32_t>(out.positions.size());
  for (size_t i = 0; i < p.count(); ++i) {
    const glm::dvec4 v = xf * glm::dvec4(p.get(i, 0), p.get(i, 1), p.get(i, 2), 1.0);
    for (int c = 0; c < 3; ++c)
      if (!(std::abs(v[c]) <= meshio::kMaxCoordinate))
        throw MeshError(what + ".attributes.POSITION: vertex " + std::to_string(i) + " (in the scene's frame) " +
                        (std::isfinite(v[c]) ? "is beyond 1e30 in magnitude" : "is not finite"));
    out.positions.push_back(glm::vec3(v));
    glm::vec3 n(0, 1, 0);
    if (nrm) {
      const glm::dvec3 nn = normalXf * glm::dvec3(nrm->get(i, 0), nrm->get(i, 1), nrm->get(i, 2));
      const double len = glm::length(nn);
      if (len > 0 && std::isfinite(len)) n = glm::vec3(nn / len);
    }
    out.normals.push_back(n);
    if (uv) {
      // glTF's v runs down the image; ours runs with the image rows too (row 0 = v 0).
      glm::vec2 t(static_cast<float>(uv->get(i, 0)), static_cast<float>(uv->get(i, 1)));
      if (!std::isfinite(t.x) || !std::isfinite(t.y)) t = glm::vec2(-1);
      out.uvs.push_back(t);
    } else {
      out.uvs.push_back(glm::vec2(-1));  // marks "no uv"
    }
    if (materialId) {
      out.materialUvs.push_back(uv && out.uvs.back().x != -1 ? out.uvs.back() : glm::vec2(0));
      out.materialIds.push_back(*materialId);
    }
  }
  anyUv = anyUv || uv != nullptr;
  std::vector<uint32_t> idx;
  if (prim.indices >= 0) {
    AccessorReader ir(model, prim.indices, what + ".indices");
    idx.reserve(ir.count());
    for (size_t i = 0; i < ir.count(); ++i) {
      const uint32_t k = ir.index(i);
      if (k >= p.count())
        throw MeshError(what + ": index " + std::to_string(k) + " out of range (" + std::to_string(p.count()) +
                        " vertices)");
      idx.push_back(k);
    }
  } else {
    for (uint32_t i = 0; i < p.count(); ++i) idx.push_back(i);
  }
  auto tri = [&](uint32_t a, uint32_t b, uint32_t c) {
    if (a == b || b == c || a == c) return;
    if (out.triangles.size() >= meshio::kMaxTriangles)
      throw MeshError(what + ": the default scene makes more than " + std::to_string(meshio::kMaxTriangles) +
                      " triangles");
    if (flip) std::swap(b, c);
    out.triangles.push_back({base + a, base + b, base + c});
  };
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    if (idx.size() % 3) throw MeshError(what + ": triangle index count is not a multiple of 3");
    for (size_t i = 0; i + 2 < idx.size(); i += 3) tri(idx[i], idx[i + 1], idx[i + 2]);
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t i = 0; i + 2 < idx.size(); ++i)
      i % 2 ? tri(idx[i + 1], idx[i], idx[i + 2]) : tri(idx[i], idx[i + 1], idx[i + 2]);
  } else {
    for (size_t i = 1; i + 1 < idx.size(); ++i) tri(idx[0], idx[i], idx[i + 1]);
  }
}

// Images as RGBA8, decoded by stb_image (at most 8192 texels a side); embedded images (data URIs, buffer views) come
// through tinygltf, files beside the glTF are read here (TINYGLTF_NO_EXTERNAL_IMAGE keeps tinygltf from it).
constexpr int kMaxImageSide = 8192;
bool decodeImage(const unsigned char* bytes, size_t size, render::LookImage* out, std::string* why) {
  int w = 0, h = 0, c = 0;
  if (size > (size_t(1) << 30) || !stbi_info_from_memory(bytes, static_cast<int>(size), &w, &h, &c)) {
    *why = "not an image stb_image reads";
    return false;
  }
  if (w <= 0 || h <= 0 || w > kMaxImageSide || h > kMaxImageSide) {
    *why = std::to_string(w) + "x" + std::to_string(h) + " texels (at most " + std::to_string(kMaxImageSide) + " a side)";
    return false;
  }
  unsigned char* px = stbi_load_from_memory(bytes, static_cast<int>(size), &w, &h, &c, 4);
  if (!px) {
    *why = stbi_failure_reason() ? stbi_failure_reason() : "decoding failed";
    return false;
  }
  out->width = w;
  out->height = h;
  out->rgba.assign(px, px + static_cast<size_t>(w) * h * 4);
  stbi_image_free(px);
  return true;
}

bool loadImageData(tinygltf::Image* image, const int index, std::string* err, std::string*, int, int,
                   const unsigned char* bytes, int size, void*) {
  render::LookImage decoded;
  std::string why;
  if (!decodeImage(bytes, static_cast<size_t>(std::max(size, 0)), &decoded, &why)) {
    // A broken texture does not stop the mesh: the material draws without it (warned by readLook).
    (void)err;
    (void)index;
    image->width = image->height = 0;
    return true;
  }
  image->width = decoded.width;
  image->height = decoded.height;
  image->component = 4;
  image->bits = 8;
  image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  image->image = std::move(decoded.rgba);
  return true;
}

// The file's materials (those its primitives use) and their images, in glTF's metallic-roughness model.
// Returns, per glTF material index, the index in `look` (or -1 when unused).
std::vector<int> readLook(const tinygltf::Model& model, const std::string& path, render::Look& look) {
  const fs::path baseDir = fs::path(path).parent_path();
  std::vector<int> imageIndex(model.images.size(), -2);  // -2 not yet read, -1 unreadable
  auto image = [&](const tinygltf::TextureInfo& info, const std::string& what) -> int {
    {
      if (info.index < 0) return -1;
      if (info.texCoord != 0) {
        logWarning(path, ": ", what, " uses TEXCOORD_", info.texCoord, ": only TEXCOORD_0 is read; drawn without it");
        return -1;
      }
      if (info.index >= static_cast<int>(model.textures.size())) return -1;
      const int src = model.textures[static_cast<size_t>(info.index)].source;
      if (src < 0 || src >= static_cast<int>(model.images.size())) return -1;
      int& slot = imageIndex[static_cast<size_t>(src)];
      if (slot != -2) return slot;
      const tinygltf::Image& im = model.images[static_cast<size_t>(src)];
      render::LookImage out;
      std::string why;
      if (!im.image.empty() && im.width > 0 && im.component == 4) {
        out.width = im.width;
        out.height = im.height;
        out.rgba = im.image;
      } else if (!im.uri.empty() && im.bufferView < 0 && im.uri.rfind("data:", 0) != 0) {
        const fs::path file = baseDir / im.uri;
        std::error_code ec;
        if (!fs::is_regular_file(file, ec) || fs::file_size(file, ec) > (size_t(256) << 20)) {
          why = file.string() + " is not a regular file of at most 256 MiB";
        } else {
          std::ifstream in(file, std::ios::binary);
          const std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
          if (decodeImage(bytes.data(), bytes.size(), &out, &why)) why.clear();
          else why = file.string() + ": " + why;
        }
      } else {
        why = "could not be decoded";
      }
      if (out.width == 0) {
        logWarning(path, ": images[", src, "] (", what, "): ", why.empty() ? "could not be decoded" : why,
                   ": drawn without it");
        return slot = -1;
      }
      look.images.push_back(std::move(out));
      return slot = static_cast<int>(look.images.size()) - 1;
    }
  };
  std::vector<int> index(model.materials.size(), -1);
  for (const auto& mesh : model.meshes)
    for (const auto& prim : mesh.primitives) {
      const int mi = prim.material;
      if (mi < 0 || mi >= static_cast<int>(model.materials.size()) || index[static_cast<size_t>(mi)] >= 0) continue;
      const tinygltf::Material& g = model.materials[static_cast<size_t>(mi)];
      const std::string what = "materials[" + std::to_string(mi) + "]";
      const auto& pbr = g.pbrMetallicRoughness;
      render::LookMaterial m;
      for (int c = 0; c < 4 && c < static_cast<int>(pbr.baseColorFactor.size()); ++c)
        m.baseColor[c] = static_cast<float>(std::clamp(pbr.baseColorFactor[static_cast<size_t>(c)], 0.0, 1.0));
      m.metallic = static_cast<float>(std::clamp(pbr.metallicFactor, 0.0, 1.0));
      m.roughness = static_cast<float>(std::clamp(pbr.roughnessFactor, 0.0, 1.0));
      for (int c = 0; c < 3 && c < static_cast<int>(g.emissiveFactor.size()); ++c)
        m.emissive[c] = static_cast<float>(std::clamp(g.emissiveFactor[static_cast<size_t>(c)], 0.0, 1e3));
      m.normalScale = std::isfinite(g.normalTexture.scale) ? static_cast<float>(g.normalTexture.scale) : 1.0f;
      m.occlusionStrength = static_cast<float>(std::clamp(g.occlusionTexture.strength, 0.0, 1.0));
      m.baseColorImage = image(pbr.baseColorTexture, what + ".baseColorTexture");
      m.metallicRoughnessImage = image(pbr.metallicRoughnessTexture, what + ".metallicRoughnessTexture");
      tinygltf::TextureInfo normal, occlusion;
      normal.index = g.normalTexture.index;
      normal.texCoord = g.normalTexture.texCoord;
      occlusion.index = g.occlusionTexture.index;
      occlusion.texCoord = g.occlusionTexture.texCoord;
      m.normalImage = image(normal, what + ".normalTexture");
      m.occlusionImage = image(occlusion, what + ".occlusionTexture");
      m.emissiveImage = image(g.emissiveTexture, what + ".emissiveTexture");
      index[static_cast<size_t>(mi)] = static_cast<int>(look.materials.size());
      look.materials.push_back(m);
    }
  if (look.materials.size() > static_cast<size_t>(render::kMaxLookMaterials))
    logWarning(path, ": ", look.materials.size(), " materials; the renderer draws the first ",
               render::kMaxLookMaterials, " and the rest as the last of them");
  return index;
}

}  // namespace

namespace {
// The file's bytes, after its size and its format's first bytes are checked (before the whole file is read:
// binary glTF starts with "glTF", version 2 and the file's length; JSON with '{').
std::vector<unsigned char> readGltfBytes(const std::string& path, bool binary) {
  std::error_code ec;
  if (fs::file_size(path, ec) > meshio::kMaxFileBytes)
    throw MeshError(path + ": larger than 1 GiB: refusing to load it");
  {
    std::ifstream in(path, std::ios::binary);
    char head[4] = {0, 0, 0, 0};
    in.read(head, 4);
    if (binary && std::string(head, 4) != "glTF") throw MeshError(path + ": not a glTF binary (no 'glTF' magic)");
    if (binary) {
      // Version 2 and a length that is the file's, before the whole file is read.
      unsigned char words[8] = {};
      in.read(reinterpret_cast<char*>(words), 8);
      const uint32_t version = words[0] | words[1] << 8 | words[2] << 16 | uint32_t(words[3]) << 24;
      const uint32_t length = words[4] | words[5] << 8 | words[6] << 16 | uint32_t(words[7]) << 24;
      if (version != 2) throw MeshError(path + ": a glTF binary of version " + std::to_string(version) + ", not 2");
      if (length != fs::file_size(path, ec))
        throw MeshError(path + ": the glTF binary's header gives its length as " + std::to_string(length) +
                        " bytes, the file has " + std::to_string(fs::file_size(path, ec)));
    }
    if (!binary) {
      in.clear();
      in.seekg(0);
      char c = ' ';
      while (in.get(c) && std::isspace(static_cast<unsigned char>(c))) {
      }
      if (c != '{') throw MeshError(path + ": not a glTF file (JSON must start with '{')");
    }
  }
  std::vector<unsigned char> bytes;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw MeshError(path + ": cannot be opened");
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return bytes;
}

// Every primitive of the scene's nodes, each with its node's transform, appended to `out` (the hierarchy walked
// recursively, its depth bounded: a chain of 100000 nodes overflowed the stack; cycles refused).
void appendScene(const tinygltf::Model& model, int sceneIndex, const std::string& path,
                 const std::vector<int>& lookIndex, bool withLook, TriangleMesh& out, bool& anyUv) {
  std::vector<int> onPath;
  size_t visits = 0;
  constexpr size_t kMaxDepth = 256;
  std::function<void(int, const glm::dmat4&)> visit = [&](int ni, const glm::dmat4& parent) {
    const std::string at = path + ": nodes[" + std::to_string(ni) + "]";
    if (ni < 0 || ni >= static_cast<int>(model.nodes.size())) throw MeshError(at + ": node does not exist");
    if (std::find(onPath.begin(), onPath.end(), ni) != onPath.end())
      throw MeshError(at + ": node hierarchy has a cycle through this node");
    if (onPath.size() >= kMaxDepth)
      throw MeshError(at + ": node hierarchy deeper than " + std::to_string(kMaxDepth) + " levels");
    if (++visits > 100000) throw MeshError(at + ": node hierarchy too large (over 100000 visits)");
    onPath.push_back(ni);
    const tinygltf::Node& node = model.nodes[static_cast<size_t>(ni)];
    const glm::dmat4 xf = parent * nodeMatrix(node);
    if (node.mesh >= 0) {
      if (node.mesh >= static_cast<int>(model.meshes.size()))
        throw MeshError(at + ".mesh: uses missing mesh " + std::to_string(node.mesh));
      const auto& mesh = model.meshes[static_cast<size_t>(node.mesh)];
      for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
        const int mi = mesh.primitives[pi].material;
        const int lookId = mi >= 0 && mi < static_cast<int>(lookIndex.size()) ? lookIndex[static_cast<size_t>(mi)] : -1;
        appendPrimitive(model, mesh.primitives[pi], xf,
                        path + ": meshes[" + std::to_string(node.mesh) + "].primitives[" + std::to_string(pi) + "]",
                        out, anyUv, withLook ? &lookId : nullptr);
      }
    }
    for (int c : node.children) visit(c, xf);
    onPath.pop_back();
  };
  for (int root : model.scenes[static_cast<size_t>(sceneIndex)].nodes) visit(root, glm::dmat4(1));
}

}  // namespace

TriangleMesh loadGltf(const std::string& path, render::Look* look) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  // Images are not needed for geometry: decoded only when the look is asked for.
  if (look)
    loader.SetImageLoader(&loadImageData, nullptr);
  else
    loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*,
                             int, void*) { return true; },
                          nullptr);
  loader.SetFsCallbacks(
      {&tinygltf::FileExists, &tinygltf::ExpandFilePath, &readBuffer, &tinygltf::WriteWholeFile, nullptr});
  const bool binary = meshio::lower(fs::path(path).extension().string()) == ".glb";
  const std::vector<unsigned char> bytes = readGltfBytes(path, binary);
  gltf::checkDocument(bytes, binary, path);
  std::string baseDir = fs::path(path).parent_path().string();
  if (baseDir.empty()) baseDir = ".";
  bool ok = false;
  try {
    ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), static_cast<unsigned>(bytes.size()),
                                              baseDir)
                : loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(bytes.data()),
                                             static_cast<unsigned>(bytes.size()), baseDir);
  } catch (const std::exception& e) {
    throw MeshError(path + ": " + e.what());
  }
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    throw MeshError(path + ": not a valid glTF" + std::string(binary ? " binary" : "") +
                    " file: " + (err.empty() ? "unknown error" : err));
  }
  if (model.scenes.empty()) throw MeshError(path + ": the file has no scene");
  const int sceneIndex = model.defaultScene >= 0 ? model.defaultScene : 0;
  if (sceneIndex >= static_cast<int>(model.scenes.size()))
    throw MeshError(path + ": scene: default scene " + std::to_string(sceneIndex) + " does not exist");
  TriangleMesh out;
  bool anyUv = false;
  std::vector<int> lookIndex;
  if (look) {
    *look = render::Look();
    lookIndex = readLook(model, path, *look);
  }
  appendScene(model, sceneIndex, path, lookIndex, look != nullptr, out, anyUv);
  if (out.triangles.empty()) throw MeshError(path + ": the default scene has no triangles");
  // Partial uvs (some primitives without TEXCOORD_0) cannot be trusted: drop them all.
  bool complete = anyUv;
  for (const auto& t : out.uvs) complete = complete && t.x >= 0;
  if (!complete) out.uvs.clear();
  if (look && look->empty()) {
    out.materialUvs.clear();
    out.materialIds.clear();
  }
  return out;
}

}  // namespace crumple
