// The checks of a glTF document before tinygltf reads it (gltf_check.h).
#include <crumple/engine/gltf_check.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include <crumple/core/log.h>
#include <crumple/engine/mesh_io.h>
#include <crumple/engine/mesh_io_detail.h>

namespace crumple::gltf {

using json = nlohmann::json;

namespace {
// The JSON's nesting and its number of values, counted on the text before anything parses it: tinygltf copies
// "extras" recursively, so a document nested 100000 deep would overflow the stack; a flat array of a hundred
// million zeros would take gigabytes as a parsed document (twice: once here, once in tinygltf).
constexpr int kMaxNesting = 64;
constexpr size_t kMaxValues = size_t(1) << 22;
void checkJsonShape(const char* text, size_t size, const std::string& path) {
  int depth = 0;
  size_t values = 0;
  bool inString = false, escaped = false;
  for (size_t i = 0; i < size; ++i) {
    const char c = text[i];
    if (inString) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{' || c == ',') {
      if (c != ',' && ++depth > kMaxNesting)
        throw MeshError(path + ": the JSON nests deeper than " + std::to_string(kMaxNesting) + " levels");
      if (++values > kMaxValues)
        throw MeshError(path + ": the JSON holds more than " + std::to_string(kMaxValues) + " values");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}

std::string shown(const json& v) { return capText(v.dump(), 60); }

// What tinygltf reads without a word: counts, offsets and indices it takes as 0 or -1 when they are negative or
// not integers, transforms of the wrong length it ignores, and transforms that make a body of no size or of 1e30.
class DocumentCheck {
 public:
  DocumentCheck(const json& doc, const std::string& path) : doc_(doc), path_(path) {}

  void run() {
    index(doc_, "", "scene");
    forEach("scenes", [&](const json& s, const std::string& at) { indexArray(s, at, "nodes"); });
    forEach("nodes", [&](const json& n, const std::string& at) { node(n, at); });
    forEach("meshes", [&](const json& m, const std::string& at) {
      if (!m.contains("primitives") || !m["primitives"].is_array()) return;
      for (size_t p = 0; p < m["primitives"].size(); ++p) {
        const json& prim = m["primitives"][p];
        if (!prim.is_object()) continue;
        const std::string pat = at + ".primitives[" + std::to_string(p) + "]";
        index(prim, pat, "indices");
        index(prim, pat, "mode");
        if (prim.contains("attributes") && prim["attributes"].is_object())
          for (const auto& [name, value] : prim["attributes"].items())
            if (!isIndex(value))
              fail(pat + ".attributes." + capText(name, 40), "must be an accessor index, got " + shown(value));
      }
    });
    forEach("accessors", [&](const json& a, const std::string& at) {
      for (const char* k : {"bufferView", "byteOffset", "count", "componentType"}) index(a, at, k);
    });
    forEach("bufferViews", [&](const json& v, const std::string& at) {
      for (const char* k : {"buffer", "byteOffset", "byteLength", "byteStride"}) index(v, at, k);
    });
    forEach("buffers", [&](const json& b, const std::string& at) { index(b, at, "byteLength"); });
  }

 private:
  [[noreturn]] void fail(const std::string& key, const std::string& why) const {
    throw MeshError(path_ + ": " + key + ": " + why);
  }
  static std::string join(const std::string& at, const std::string& key) { return at.empty() ? key : at + "." + key; }

  // A count, offset or index: a whole number in [0, 2^32] (nothing in a file of at most 1 GiB is larger).
  static bool isIndex(const json& v) {
    if (!v.is_number()) return false;
    const double d = v.get<double>();
    return d >= 0 && d <= 4294967296.0 && d == std::floor(d);
  }
  void index(const json& obj, const std::string& at, const char* key) const {
    if (!obj.is_object() || !obj.contains(key)) return;
    const json& v = obj[key];
    if (!isIndex(v)) fail(join(at, key), "must be a whole number from 0 to 2^32, got " + shown(v));
  }
  void indexArray(const json& obj, const std::string& at, const char* key) const {
    if (!obj.is_object() || !obj.contains(key)) return;
    const json& a = obj[key];
    if (!a.is_array()) fail(join(at, key), "must be an array of indices");
    for (size_t i = 0; i < a.size(); ++i)
      if (!isIndex(a[i]))
        fail(join(at, key) + "[" + std::to_string(i) + "]",
             "must be a whole number from 0 to 2^32, got " + shown(a[i]));
  }
  void forEach(const char* key, const std::function<void(const json&, const std::string&)>& f) const {
    if (!doc_.contains(key)) return;
    const json& a = doc_[key];
    if (!a.is_array()) fail(key, "must be an array");
    for (size_t i = 0; i < a.size(); ++i) {
      if (!a[i].is_object()) fail(std::string(key) + "[" + std::to_string(i) + "]", "must be an object");
      f(a[i], std::string(key) + "[" + std::to_string(i) + "]");
    }
  }
  std::vector<double> numbers(const json& n, const std::string& at, const char* key, size_t count) const {
    const json& a = n[key];
    if (!a.is_array() || a.size() != count)
      fail(join(at, key), "must be an array of " + std::to_string(count) + " numbers, got " + shown(a));
    std::vector<double> v;
    for (size_t i = 0; i < count; ++i) {
      if (!a[i].is_number() || !std::isfinite(a[i].get<double>()))
        fail(join(at, key) + "[" + std::to_string(i) + "]", "must be a finite number, got " + shown(a[i]));
      v.push_back(a[i].get<double>());
    }
    return v;
  }
  void scaleWithin(const std::string& key, double s) const {
    if (!(std::abs(s) >= meshio::kMinNodeScale && std::abs(s) <= meshio::kMaxNodeScale)) {
      std::ostringstream os;
      os << s << " is outside [1e-6, 1e6] in magnitude";
      fail(key, os.str());
    }
  }
  void translationWithin(const std::string& key, double t) const {
    if (!(std::abs(t) <= meshio::kMaxCoordinate)) {
      std::ostringstream os;
      os << t << " is beyond 1e30 in magnitude";
      fail(key, os.str());
    }
  }
  void node(const json& n, const std::string& at) {
    index(n, at, "mesh");
    indexArray(n, at, "children");
    if (n.contains("translation")) {
      const auto t = numbers(n, at, "translation", 3);
      for (int i = 0; i < 3; ++i) translationWithin(at + ".translation[" + std::to_string(i) + "]", t[size_t(i)]);
    }
    if (n.contains("rotation")) {
      const auto q = numbers(n, at, "rotation", 4);
      const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (!(std::abs(len - 1) <= 1e-3)) {
        std::ostringstream os;
        os << "must be a unit quaternion [x, y, z, w], got " << shown(n["rotation"]) << " (length " << len << ")";
        fail(at + ".rotation", os.str());
      }
    }
    if (n.contains("scale")) {
      const auto s = numbers(n, at, "scale", 3);
      for (int i = 0; i < 3; ++i) scaleWithin(at + ".scale[" + std::to_string(i) + "]", s[size_t(i)]);
    }
    if (n.contains("matrix")) {
      const auto m = numbers(n, at, "matrix", 16);  // column-major
      if (m[3] != 0 || m[7] != 0 || m[11] != 0 || m[15] != 1)
        fail(at + ".matrix", "must be affine (its last row 0, 0, 0, 1)");
      double lengths = 1;
      for (int c = 0; c < 3; ++c) {
        const double len = std::sqrt(m[size_t(4 * c)] * m[size_t(4 * c)] + m[size_t(4 * c + 1)] * m[size_t(4 * c + 1)] +
                                     m[size_t(4 * c + 2)] * m[size_t(4 * c + 2)]);
        scaleWithin(at + ".matrix: the scale of axis " + std::to_string(c), len);
        lengths *= len;
      }
      // Axes of fine lengths may still lie in a plane: the mesh would be flattened.
      const glm::dmat3 a(m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]);
      if (!(std::abs(glm::determinant(a)) > 1e-6 * lengths)) fail(at + ".matrix", "is singular (flattens the mesh)");
      for (int i = 12; i < 15; ++i) translationWithin(at + ".matrix[" + std::to_string(i) + "]", m[size_t(i)]);
    }
  }

  const json& doc_;
  std::string path_;
};

}  // namespace

void checkDocument(const std::vector<unsigned char>& bytes, bool binary, const std::string& path) {
  const char* text = reinterpret_cast<const char*>(bytes.data());
  size_t size = bytes.size();
  if (binary) {
    // 12-byte header ("glTF", version, length), then the JSON chunk: its length and type, then its bytes.
    if (bytes.size() < 20) return;  // tinygltf says what is short
    uint32_t chunk = 0;
    std::memcpy(&chunk, bytes.data() + 12, 4);
    if (std::memcmp(bytes.data() + 16, "JSON", 4) != 0 || chunk > bytes.size() - 20) return;
    text += 20;
    size = chunk;
  }
  checkJsonShape(text, size, path);
  const json doc = json::parse(text, text + size, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) return;  // tinygltf names the JSON error
  DocumentCheck(doc, path).run();
}


}  // namespace crumple::gltf
