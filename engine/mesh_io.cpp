#include "engine/mesh_io.h"

#include "core/log.h"
#include "engine/scene.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <cerrno>
#include <fstream>
#include <set>
#include <sstream>
#include <unordered_set>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <stb/stb_image.h>
#include <tiny_gltf.h>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>

namespace crumple {

namespace fs = std::filesystem;

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

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
    m *= glm::mat4_cast(glm::dquat(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]));
  if (n.scale.size() == 3) m = glm::scale(m, glm::dvec3(n.scale[0], n.scale[1], n.scale[2]));
  return m;
}

void appendPrimitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const glm::dmat4& xf,
                     const std::string& what, TriangleMesh& out, bool& anyUv) {
  const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
  if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
    return;
  auto pos = prim.attributes.find("POSITION");
  if (pos == prim.attributes.end()) throw MeshError(what + ": primitive has no POSITION");
  AccessorReader p(model, pos->second, what + " POSITION");
  if (p.components() != 3) throw MeshError(what + ": POSITION must be VEC3");
  std::unique_ptr<AccessorReader> nrm, uv;
  if (auto it = prim.attributes.find("NORMAL"); it != prim.attributes.end()) {
    nrm = std::make_unique<AccessorReader>(model, it->second, what + " NORMAL");
    if (nrm->components() != 3 || nrm->count() != p.count()) nrm.reset();
  }
  if (auto it = prim.attributes.find("TEXCOORD_0"); it != prim.attributes.end()) {
    uv = std::make_unique<AccessorReader>(model, it->second, what + " TEXCOORD_0");
    if (uv->components() != 2 || uv->count() != p.count())
      throw MeshError(what + ": TEXCOORD_0 must be VEC2 with one per vertex");
  }
  const glm::dmat3 normalXf = glm::transpose(glm::inverse(glm::dmat3(xf)));
  const bool flip = glm::determinant(glm::dmat3(xf)) < 0;
  const auto base = static_cast<uint32_t>(out.positions.size());
  for (size_t i = 0; i < p.count(); ++i) {
    const glm::dvec4 v = xf * glm::dvec4(p.get(i, 0), p.get(i, 1), p.get(i, 2), 1.0);
    const glm::vec3 fv(v);
    if (!finite(fv)) throw MeshError(what + ": vertex " + std::to_string(i) + " is not finite");
    out.positions.push_back(fv);
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
  }
  anyUv = anyUv || uv != nullptr;
  std::vector<uint32_t> idx;
  if (prim.indices >= 0) {
    AccessorReader ir(model, prim.indices, what + " indices");
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

}  // namespace

TriangleMesh loadGltf(const std::string& path) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  // Images are not needed for geometry: skip decoding them.
  loader.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                           void*) { return true; },
                        nullptr);
  const bool binary = lower(fs::path(path).extension().string()) == ".glb";
  {
    // The format's own first bytes, before the whole file is read: binary glTF starts with "glTF", JSON with '{'.
    std::ifstream in(path, std::ios::binary);
    char head[4] = {0, 0, 0, 0};
    in.read(head, 4);
    if (binary && std::string(head, 4) != "glTF") throw MeshError(path + ": not a glTF binary (no 'glTF' magic)");
    if (!binary) {
      in.seekg(0);
      char c = ' ';
      while (in.get(c) && std::isspace(static_cast<unsigned char>(c))) {
      }
      if (c != '{') throw MeshError(path + ": not a glTF file (JSON must start with '{')");
    }
  }
  bool ok = false;
  try {
    ok = binary ? loader.LoadBinaryFromFile(&model, &err, &warn, path)
                : loader.LoadASCIIFromFile(&model, &err, &warn, path);
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
    throw MeshError(path + ": default scene " + std::to_string(sceneIndex) + " does not exist");
  TriangleMesh out;
  bool anyUv = false;
  std::vector<int> onPath;
  size_t visits = 0;
  std::function<void(int, const glm::dmat4&)> visit = [&](int ni, const glm::dmat4& parent) {
    if (ni < 0 || ni >= static_cast<int>(model.nodes.size()))
      throw MeshError(path + ": node " + std::to_string(ni) + " does not exist");
    if (std::find(onPath.begin(), onPath.end(), ni) != onPath.end())
      throw MeshError(path + ": node hierarchy has a cycle through node " + std::to_string(ni));
    if (++visits > 100000) throw MeshError(path + ": node hierarchy too large");
    onPath.push_back(ni);
    const tinygltf::Node& node = model.nodes[static_cast<size_t>(ni)];
    const glm::dmat4 xf = parent * nodeMatrix(node);
    if (node.mesh >= 0) {
      if (node.mesh >= static_cast<int>(model.meshes.size()))
        throw MeshError(path + ": node " + std::to_string(ni) + " uses missing mesh " + std::to_string(node.mesh));
      const auto& mesh = model.meshes[static_cast<size_t>(node.mesh)];
      for (size_t pi = 0; pi < mesh.primitives.size(); ++pi)
        appendPrimitive(model, mesh.primitives[pi], xf,
                        path + ": mesh " + std::to_string(node.mesh) + " primitive " + std::to_string(pi), out, anyUv);
    }
    for (int c : node.children) visit(c, xf);
    onPath.pop_back();
  };
  for (int root : model.scenes[static_cast<size_t>(sceneIndex)].nodes) visit(root, glm::dmat4(1));
  if (out.triangles.empty()) throw MeshError(path + ": the default scene has no triangles");
  // Partial uvs (some primitives without TEXCOORD_0) cannot be trusted: drop them all.
  bool complete = anyUv;
  for (const auto& t : out.uvs) complete = complete && t.x >= 0;
  if (!complete) out.uvs.clear();
  return out;
}

// OBJ is read here rather than through OpenMesh, whose reader skips what it
// cannot parse (bad indices, unparsable numbers) with a message on stderr and
// goes on: a broken file must be an error naming the line.
TriangleMesh loadObj(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw MeshError(path + ": cannot be opened");
  std::vector<glm::vec3> v;
  std::vector<glm::vec3> vc;  // vertex colours, when the file has them
  std::vector<glm::vec2> vt;
  TriangleMesh out;
  bool anyUv = false, allUv = true;
  std::string line;
  int lineNo = 0;
  auto fail = [&](const std::string& why) { throw MeshError(path + ": line " + std::to_string(lineNo) + ": " + why); };
  auto number = [&](std::istringstream& ls) {
    std::string tok;
    if (!(ls >> tok)) fail("missing coordinate");
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(tok.c_str(), &end);
    if (end == tok.c_str() || *end != '\0') fail("'" + tok + "' is not a number");
    if (!std::isfinite(x) || errno == ERANGE || std::abs(x) > 1e30) fail("coordinate '" + tok + "' is not finite");
    return static_cast<float>(x);
  };
  auto index = [&](const std::string& tok, size_t count, const char* what) -> long {
    char* end = nullptr;
    const long i = std::strtol(tok.c_str(), &end, 10);
    if (end == tok.c_str() || *end != '\0') fail(std::string("bad ") + what + " index '" + tok + "'");
    const long resolved = i < 0 ? static_cast<long>(count) + i : i - 1;
    if (i == 0 || resolved < 0 || resolved >= static_cast<long>(count))
      fail(std::string(what) + " index " + tok + " out of range (" + std::to_string(count) + " defined so far)");
    return resolved;
  };
  // Lines are read with a bound: a 2 GB file of NUL bytes is refused at its first 100000 bytes.
  auto nextLine = [&]() {
    line.clear();
    ++lineNo;
    for (int c; (c = in.get()) != EOF;) {
      if (c == '\n') return true;
      if (c == '\0') fail("binary data (a NUL byte): not an OBJ text file");
      if (line.size() >= 100000) fail("line too long");
      line.push_back(static_cast<char>(c));
    }
    return !line.empty();
  };
  while (nextLine()) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream ls(line);
    std::string tag;
    if (!(ls >> tag)) continue;
    if (tag == "v") {
      const float x = number(ls), y = number(ls), z = number(ls);
      v.emplace_back(x, y, z);
      // A common extension: "v x y z r g b", colours in [0, 1].
      std::string r;
      if (ls >> r) {
        std::istringstream rs(r);
        const float cr = number(rs), cg = number(ls), cb = number(ls);
        if (!(cr >= 0 && cr <= 1 && cg >= 0 && cg <= 1 && cb >= 0 && cb <= 1)) fail("vertex colour outside [0, 1]");
        vc.resize(v.size() - 1, glm::vec3(1));
        vc.emplace_back(cr, cg, cb);
      }
    } else if (tag == "vt") {
      const float a = number(ls);
      std::string rest;
      float b = 0;
      if (ls >> rest) {
        std::istringstream again(rest);
        b = number(again);
      }
      vt.emplace_back(a, 1.0f - b);  // OBJ's v points up the image; ours runs with the rows
    } else if (tag == "f") {
      std::vector<unsigned> corners;
      std::string tok;
      while (ls >> tok) {
        const auto s1 = tok.find('/');
        const long vi = index(tok.substr(0, s1), v.size(), "vertex");
        long ti = -1;
        if (s1 != std::string::npos) {
          const auto s2 = tok.find('/', s1 + 1);
          const std::string t = tok.substr(s1 + 1, s2 == std::string::npos ? std::string::npos : s2 - s1 - 1);
          if (!t.empty()) ti = index(t, vt.size(), "texture coordinate");
        }
        out.positions.push_back(v[static_cast<size_t>(vi)]);
        if (!vc.empty()) {
          out.colors.resize(out.positions.size() - 1, glm::vec3(1));
          out.colors.push_back(static_cast<size_t>(vi) < vc.size() ? vc[static_cast<size_t>(vi)] : glm::vec3(1));
        }
        out.uvs.push_back(ti >= 0 ? vt[static_cast<size_t>(ti)] : glm::vec2(-1));
        anyUv = anyUv || ti >= 0;
        allUv = allUv && ti >= 0;
        corners.push_back(static_cast<unsigned>(out.positions.size() - 1));
      }
      if (corners.size() < 3) fail("a face needs at least 3 vertices");
      for (size_t i = 1; i + 1 < corners.size(); ++i) out.triangles.push_back({corners[0], corners[i], corners[i + 1]});
    }
    // Other statements (vn, o, g, s, usemtl, mtllib, l, p) do not shape the solid.
  }
  if (out.triangles.empty()) throw MeshError(path + ": no faces");
  if (!anyUv || !allUv) out.uvs.clear();
  if (!out.colors.empty()) out.colors.resize(out.positions.size(), glm::vec3(1));
  out.computeNormals();
  return out;
}

namespace {
// OFF and PLY headers announce element counts that OpenMesh allocates before
// reading: check them against the file's size first (each vertex takes at
// least 6 bytes as text, 12 as binary; each face at least 4).
void checkDeclaredCounts(const std::string& path, const std::string& ext) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const double bytes = static_cast<double>(fs::file_size(path, ec));
  std::string word;
  double vertices = 0, faces = 0;
  if (ext == ".off") {
    in >> word;
    if (word.size() >= 3 && word.substr(word.size() - 3) == "OFF") {
      std::string line;
      while (in >> word && word[0] == '#') std::getline(in, line);
      try {
        vertices = std::stod(word);
        in >> faces;
      } catch (const std::exception&) {
        return;  // OpenMesh will refuse it
      }
    }
  } else {
    // PLY: the whole header is checked here, strictly: OpenMesh's reader loops or crashes on a corrupted
    // keyword or a missing end_header.
    std::string line;
    bool ended = false;
    auto bad = [&](int n, const std::string& why) {
      throw MeshError(path + ": header line " + std::to_string(n) + ": " + why);
    };
    static const std::set<std::string> kTypes = {"char",  "uchar",  "short",   "ushort", "int",   "uint",
                                                 "float", "double", "int8",    "uint8",  "int16", "uint16",
                                                 "int32", "uint32", "float32", "float64"};
    for (int n = 1; n <= 1000; ++n) {
      if (!std::getline(in, line) || line.size() > 1000) bad(n, "unreadable or too long (a PLY header is text)");
      if (!line.empty() && line.back() == '\r') line.pop_back();
      std::istringstream ls(line);
      std::string tag;
      ls >> tag;
      if (n == 1) {
        if (tag != "ply") bad(n, "a PLY file starts with 'ply'");
        continue;
      }
      if (tag == "end_header") {
        ended = true;
        break;
      }
      if (tag == "comment" || tag == "obj_info") continue;
      if (tag == "format") {
        std::string kind, version;
        ls >> kind >> version;
        if ((kind != "ascii" && kind != "binary_little_endian" && kind != "binary_big_endian") || version != "1.0")
          bad(n, "unknown format '" + capText(line, 60) + "'");
      } else if (tag == "element") {
        std::string kind, countText;
        ls >> kind >> countText;
        char* end = nullptr;
        const double count = std::strtod(countText.c_str(), &end);
        if (kind.empty() || countText.empty() || *end != '\0' || !(count >= 0) || count != std::floor(count))
          bad(n, "an element needs a name and a count, got '" + capText(line, 60) + "'");
        if (kind == "vertex")
          vertices += count;
        else if (kind == "face")
          faces += count;
      } else if (tag == "property") {
        std::string type, a, b, name;
        ls >> type;
        if (type == "list") {
          ls >> a >> b >> name;
          if (!kTypes.count(a) || !kTypes.count(b) || name.empty())
            bad(n, "bad list property '" + capText(line, 60) + "'");
        } else {
          ls >> name;
          if (!kTypes.count(type) || name.empty()) bad(n, "bad property '" + capText(line, 60) + "'");
        }
      } else {
        bad(n, "unknown keyword '" + capText(tag, 40) + "'");
      }
    }
    if (!ended) throw MeshError(path + ": no end_header in the first 1000 lines");
  }
  if (vertices < 0 || faces < 0 || vertices * 6 + faces * 4 > bytes * 2 + 64)
    throw MeshError(path + ": the header announces " + std::to_string(static_cast<long long>(vertices)) +
                    " vertices and " + std::to_string(static_cast<long long>(faces)) + " faces, more than the file's " +
                    std::to_string(static_cast<long long>(bytes)) + " bytes can hold");
}
}  // namespace

TriangleMesh loadWithOpenMesh(const std::string& path) {
  checkDeclaredCounts(path, lower(fs::path(path).extension().string()));
  using Mesh = OpenMesh::PolyMesh_ArrayKernelT<>;
  Mesh mesh;
  mesh.request_vertex_texcoords2D();
  mesh.request_halfedge_texcoords2D();
  mesh.request_vertex_normals();
  OpenMesh::IO::Options opt;
  opt += OpenMesh::IO::Options::VertexTexCoord;
  opt += OpenMesh::IO::Options::FaceTexCoord;
  opt += OpenMesh::IO::Options::VertexNormal;
  bool ok = false;
  try {
    ok = OpenMesh::IO::read_mesh(mesh, path, opt);
  } catch (const std::bad_alloc&) {
    throw MeshError(path + ": the file's element counts are too large to hold");
  } catch (const std::exception& e) {
    throw MeshError(path + ": " + e.what());
  }
  if (!ok) throw MeshError(path + ": OpenMesh could not read the file (malformed or unsupported)");
  const bool faceUv = opt.check(OpenMesh::IO::Options::FaceTexCoord);
  const bool vertexUv = opt.check(OpenMesh::IO::Options::VertexTexCoord);
  TriangleMesh out;
  for (auto f : mesh.faces()) {
    std::vector<unsigned> corner;
    for (auto h : mesh.fh_range(f)) {
      const auto v = mesh.to_vertex_handle(h);
      const auto p = mesh.point(v);
      const glm::vec3 pos(p[0], p[1], p[2]);
      if (!finite(pos)) throw MeshError(path + ": vertex " + std::to_string(v.idx()) + " is not finite");
      out.positions.push_back(pos);
      out.normals.push_back(glm::vec3(0));
      glm::vec2 uv(-1);
      if (faceUv) {
        const auto t = mesh.texcoord2D(h);
        uv = glm::vec2(t[0], 1.0f - t[1]);  // OBJ's v points up the image
      } else if (vertexUv) {
        const auto t = mesh.texcoord2D(v);
        uv = glm::vec2(t[0], 1.0f - t[1]);
      }
      out.uvs.push_back(uv);
      corner.push_back(static_cast<unsigned>(out.positions.size() - 1));
    }
    for (size_t i = 1; i + 1 < corner.size(); ++i) out.triangles.push_back({corner[0], corner[i], corner[i + 1]});
  }
  if (out.triangles.empty()) throw MeshError(path + ": no faces");
  if (!faceUv && !vertexUv) out.uvs.clear();
  out.computeNormals();
  return out;
}

namespace {
// A face listed again (the same three corner positions, in any order) adds no surface: it is dropped, with a
// warning. A million copies of one face made the atlas quadratic (every copy shares every edge).
void removeDuplicateFaces(TriangleMesh& m, const std::string& path) {
  struct Key {
    std::array<float, 9> v;
    bool operator==(const Key& o) const { return v == o.v; }
  };
  struct Hash {
    size_t operator()(const Key& k) const {
      size_t h = 1469598103934665603ull;
      for (float f : k.v) {
        uint32_t bits;
        std::memcpy(&bits, &f, sizeof bits);
        h = (h ^ bits) * 1099511628211ull;
      }
      return h;
    }
  };
  std::unordered_set<Key, Hash> seen;
  seen.reserve(m.triangles.size());
  std::vector<glm::uvec3> kept;
  kept.reserve(m.triangles.size());
  for (const glm::uvec3& t : m.triangles) {
    std::array<glm::vec3, 3> p = {m.positions[t.x], m.positions[t.y], m.positions[t.z]};
    std::sort(p.begin(), p.end(), [](const glm::vec3& a, const glm::vec3& b) {
      return a.x != b.x ? a.x < b.x : a.y != b.y ? a.y < b.y : a.z < b.z;
    });
    Key k{{p[0].x, p[0].y, p[0].z, p[1].x, p[1].y, p[1].z, p[2].x, p[2].y, p[2].z}};
    if (seen.insert(k).second) kept.push_back(t);
  }
  if (kept.size() == m.triangles.size()) return;
  logWarning(path, ": dropped ", m.triangles.size() - kept.size(), " duplicate faces");
  m.triangles = std::move(kept);
}
}  // namespace

TriangleMesh loadMeshFile(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw MeshError(path + ": is a folder, not a mesh file");
  if (!fs::is_regular_file(path, ec)) throw MeshError(path + ": no such file");
  // The largest mesh crumple reads: larger files are refused before any is read (a body's mesh is drawn and
  // deformed every step; gigabytes of it are a mistake, not a model).
  constexpr std::uintmax_t kMaxBytes = std::uintmax_t(1) << 30;
  if (fs::file_size(path, ec) > kMaxBytes) throw MeshError(path + ": larger than 1 GiB: refusing to load it");
  const std::string ext = lower(fs::path(path).extension().string());
  TriangleMesh m;
  if (ext == ".gltf" || ext == ".glb")
    m = loadGltf(path);
  else if (ext == ".obj")
    m = loadObj(path);
  else if (ext == ".off" || ext == ".ply")
    m = loadWithOpenMesh(path);
  else
    throw MeshError(path + ": unknown mesh format '" + ext + "' (expected .gltf, .glb, .obj, .off or .ply)");
  removeDuplicateFaces(m, path);
  if (m.normals.size() != m.positions.size()) m.computeNormals();
  return m;
}

}  // namespace crumple
