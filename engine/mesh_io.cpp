#include <crumple/engine/mesh_io.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_set>

#include <crumple/core/log.h>
#include <crumple/engine/input_file.h>
#include <crumple/engine/mesh_io_detail.h>

namespace crumple {

namespace fs = std::filesystem;

namespace meshio {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string parseNumber(const std::string& token, double limit, double& out) {
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(token.c_str(), &end);
  if (token.empty() || end == token.c_str() || *end != '\0') return "is not a number";
  if (!std::isfinite(x) || (errno == ERANGE && std::abs(x) > 1)) return "is not finite";
  if (std::abs(x) > limit) {
    std::ostringstream os;
    os << limit;
    std::string shown = os.str();  // 1e30, not 1e+30
    if (const auto plus = shown.find("e+"); plus != std::string::npos) shown.erase(plus + 1, 1);
    return "is beyond " + shown + " in magnitude";
  }
  out = x;
  return "";
}

bool LineReader::next(std::string& line) {
  line.clear();
  ++lineNo_;
  for (int c; (c = in_.get()) != EOF;) {
    if (c == '\n') {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      return true;
    }
    if (c == '\0') fail(std::string("binary data (a NUL byte): not an ") + what_ + " text file");
    if (line.size() >= kMaxLineBytes) fail("line too long");
    line.push_back(static_cast<char>(c));
  }
  return !line.empty();
}

void LineReader::fail(const std::string& why) const {
  throw MeshError(path_ + ": line " + std::to_string(lineNo_) + ": " + why);
}

}  // namespace meshio

using meshio::lower;

// OBJ is read here rather than through OpenMesh, whose reader skips what it
// cannot parse (bad indices, unparsable numbers) with a message on stderr and
// goes on: a broken file must be an error naming the line.
namespace {
// Vertex normals that keep creases: each corner averages (area-weighted) the faces around its vertex that turn
// less than kCreaseDegrees from its own face, and a vertex whose corners get different normals is split (its
// other attributes copied). Smooth bodies shade smooth; a box keeps its edges. A vertex of more than
// kCreaseValence faces (fans, degenerate files) gets their plain average: the test is quadratic in the valence.
void removeDuplicateFaces(TriangleMesh& m, const std::string& path);  // below
constexpr float kCreaseDegrees = 45.0f;
constexpr size_t kCreaseValence = 32;
void creaseNormals(TriangleMesh& m) {
  const size_t nv = m.positions.size(), nt = m.triangles.size();
  auto unit = [](const glm::vec3& n) {
    const float len = glm::length(n);
    return len > 0 ? n / len : glm::vec3(0);
  };
  std::vector<glm::vec3> face(nt), faceUnit(nt);  // area-weighted and unit face normals
  std::vector<std::vector<unsigned>> around(nv);
  for (size_t t = 0; t < nt; ++t) {
    const glm::uvec3 tri = m.triangles[t];
    face[t] = glm::cross(m.positions[tri.y] - m.positions[tri.x], m.positions[tri.z] - m.positions[tri.x]);
    faceUnit[t] = unit(face[t]);
    for (unsigned v : {tri.x, tri.y, tri.z}) around[v].push_back(static_cast<unsigned>(t));
  }
  const float cosCrease = std::cos(glm::radians(kCreaseDegrees));
  TriangleMesh out;
  out.triangles.resize(nt);
  std::vector<std::vector<std::pair<glm::vec3, unsigned>>> made(nv);  // per vertex: normals given, new index
  for (size_t t = 0; t < nt; ++t) {
    const glm::vec3 own = faceUnit[t];
    for (int k = 0; k < 3; ++k) {
      const unsigned v = m.triangles[t][k];
      glm::vec3 sum(0);
      const bool creases = around[v].size() <= kCreaseValence;
      for (unsigned f : around[v])
        if (f == t || !creases || glm::dot(faceUnit[f], own) >= cosCrease) sum += face[f];
      glm::vec3 n = unit(sum);
      if (n == glm::vec3(0)) n = own == glm::vec3(0) ? glm::vec3(0, 1, 0) : own;
      unsigned index = 0;
      bool found = false;
      for (const auto& [given, at] : made[v])
        if (glm::dot(given, n) > 0.99999f) {
          index = at;
          found = true;
          break;
        }
      if (!found) {
        index = static_cast<unsigned>(out.positions.size());
        made[v].emplace_back(n, index);
        out.positions.push_back(m.positions[v]);
        out.normals.push_back(n);
        if (!m.uvs.empty()) out.uvs.push_back(m.uvs[v]);
        if (!m.colors.empty()) out.colors.push_back(m.colors[v]);
      }
      out.triangles[t][k] = index;
    }
  }
  m = std::move(out);
}
}  // namespace

TriangleMesh loadObj(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw MeshError(path + ": cannot be opened");
  std::vector<glm::vec3> v;
  std::vector<glm::vec3> vc;  // vertex colours, when the file has them
  std::vector<glm::vec2> vt;
  TriangleMesh out;
  bool anyUv = false, allUv = true;
  std::map<std::pair<long, long>, unsigned> corner;  // (vertex, texture coordinate) -> vertex of `out`
  std::string line;
  meshio::LineReader lines(in, path, "OBJ");
  auto fail = [&](const std::string& why) { lines.fail(why); };
  auto number = [&](std::istringstream& ls) {
    std::string tok;
    if (!(ls >> tok)) fail("missing coordinate");
    double x = 0;
    const std::string why = meshio::parseNumber(tok, meshio::kMaxCoordinate, x);
    if (!why.empty()) fail((why == "is not a number" ? "'" : "coordinate '") + meshio::capToken(tok) + "' " + why);
    return static_cast<float>(x);
  };
  auto index = [&](const std::string& tok, size_t count, const char* what) -> long {
    char* end = nullptr;
    const long i = std::strtol(tok.c_str(), &end, 10);
    if (end == tok.c_str() || *end != '\0') fail(std::string("bad ") + what + " index '" + meshio::capToken(tok) + "'");
    const long resolved = i < 0 ? static_cast<long>(count) + i : i - 1;
    if (i == 0 || resolved < 0 || resolved >= static_cast<long>(count))
      fail(std::string(what) + " index " + meshio::capToken(tok) + " out of range (" + std::to_string(count) +
           " defined so far)");
    return resolved;
  };
  // Lines are read with a bound: a 2 GB file of NUL bytes is refused at its first 100000 bytes.
  while (lines.next(line)) {
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
        anyUv = anyUv || ti >= 0;
        allUv = allUv && ti >= 0;
        // Corners naming the same vertex and texture coordinate share one vertex (the faces around it are
        // shaded together; creaseNormals splits it again where they meet at an edge).
        const auto [at, added] = corner.try_emplace({vi, ti}, static_cast<unsigned>(out.positions.size()));
        if (added) {
          out.positions.push_back(v[static_cast<size_t>(vi)]);
          if (!vc.empty()) {
            out.colors.resize(out.positions.size() - 1, glm::vec3(1));
            out.colors.push_back(static_cast<size_t>(vi) < vc.size() ? vc[static_cast<size_t>(vi)] : glm::vec3(1));
          }
          out.uvs.push_back(ti >= 0 ? vt[static_cast<size_t>(ti)] : glm::vec2(-1));
        }
        corners.push_back(at->second);
      }
      if (corners.size() < 3) fail("a face needs at least 3 vertices");
      for (size_t i = 1; i + 1 < corners.size(); ++i) out.triangles.push_back({corners[0], corners[i], corners[i + 1]});
      if (out.triangles.size() > meshio::kMaxTriangles)
        fail("more than " + std::to_string(meshio::kMaxTriangles) + " triangles");
    }
    // Other statements (vn, o, g, s, usemtl, mtllib, l, p) do not shape the solid.
  }
  if (out.triangles.empty()) throw MeshError(path + ": no faces");
  if (!anyUv || !allUv) out.uvs.clear();
  if (!out.colors.empty()) out.colors.resize(out.positions.size(), glm::vec3(1));
  removeDuplicateFaces(out, path);  // before the normals: a face listed a million times is a vertex of a million faces
  creaseNormals(out);
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

TriangleMesh loadMeshFile(const std::string& path, render::Look* look) {
  // Only a regular file, of at most 1 GiB, before any is read: not a FIFO (whose open waits for a writer) or a
  // device (/dev/zero reads forever). The largest mesh crumple reads: a body's mesh is drawn and deformed every
  // step; gigabytes of it are a mistake, not a model.
  if (const std::string why = inputFileProblem(path, meshio::kMaxFileBytes, "mesh file"); !why.empty())
    throw MeshError(path + ": " + why);
  const std::string ext = lower(fs::path(path).extension().string());
  TriangleMesh m;
  if (ext == ".gltf" || ext == ".glb")
    m = loadGltf(path, look);
  else if (ext == ".obj")
    m = loadObj(path);
  else if (ext == ".off")
    m = loadOff(path);
  else if (ext == ".ply")
    m = loadPly(path);
  else
    throw MeshError(path + ": unknown mesh format '" + ext + "' (expected .gltf, .glb, .obj, .off or .ply)");
  removeDuplicateFaces(m, path);
  if (m.normals.size() != m.positions.size()) m.computeNormals();
  return m;
}

}  // namespace crumple
