// OFF and PLY by our own strict readers (OpenMesh's, used before, trusted the file: a binary OFF's face count of
// two billion reserved gigabytes, a face of -3 vertices pushed four billion indices, a PLY property before its
// element crashed it, a corrupted header looped). Errors name the line (text), the byte or the element's record.
#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include <crumple/engine/mesh_io.h>
#include <crumple/engine/mesh_io_detail.h>

namespace crumple {

namespace fs = std::filesystem;

// OFF: a header [ST][C][N]OFF, then (ASCII) lines of counts, vertices ("x y z [normal] [colour] [s t]") and faces
// ("n i0 .. in-1 [colour]"), with '#' comments; or "[ST][N]OFF BINARY" followed by little-endian 32-bit counts,
// vertices (floats) and faces (n, then n indices), as OpenMesh writes it.
namespace {

struct OffLayout {
  bool texcoords = false, colors = false, normals = false;
  int vertexNumbers() const { return 3 + (normals ? 3 : 0) + (texcoords ? 2 : 0); }  // besides colours
};

// Splits a line into whitespace-separated tokens, dropping a '#' comment.
std::vector<std::string> tokens(std::string line) {
  if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
  std::istringstream ls(line);
  std::vector<std::string> out;
  for (std::string t; ls >> t;) out.push_back(t);
  return out;
}

// A whole non-negative count or index: false when `token` is not one (or is over `limit`).
bool wholeNumber(const std::string& token, long long limit, long long& out) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(token.c_str(), &end, 10);
  if (token.empty() || end == token.c_str() || *end != '\0' || errno == ERANGE || v < 0 || v > limit) return false;
  out = v;
  return true;
}

// The mesh that vertices and faces make, each face's corners their own vertices (as OBJ's): OFF and PLY.
class CornerMesh {
 public:
  CornerMesh(const std::string& path, bool vertexUvs) : path_(path), vertexUvs_(vertexUvs) {}
  std::vector<glm::vec3> vertices;
  std::vector<glm::vec2> uvs;  // per vertex, when the file has them
  // Adds a face of vertex indices already checked against the vertex count; cornerUvs (2 per corner, the file's
  // v pointing up) when the face has its own.
  void face(const std::vector<long long>& corners, const std::vector<double>* cornerUvs = nullptr) {
    const auto first = static_cast<unsigned>(out_.positions.size());
    for (size_t k = 0; k < corners.size(); ++k) {
      const auto c = static_cast<size_t>(corners[k]);
      out_.positions.push_back(vertices[c]);
      if (cornerUvs)
        out_.uvs.emplace_back((*cornerUvs)[2 * k], 1.0 - (*cornerUvs)[2 * k + 1]);
      else if (vertexUvs_)
        out_.uvs.push_back(uvs[c]);
      else
        missingUv_ = true;
    }
    for (unsigned i = 1; i + 1 < corners.size(); ++i) out_.triangles.push_back({first, first + i, first + i + 1});
    if (out_.triangles.size() > meshio::kMaxTriangles)
      throw MeshError(path_ + ": more than " + std::to_string(meshio::kMaxTriangles) + " triangles");
  }
  TriangleMesh finish() {
    if (out_.triangles.empty()) throw MeshError(path_ + ": no faces");
    if (missingUv_) out_.uvs.clear();  // texture coordinates only when every corner has them
    out_.computeNormals();
    return std::move(out_);
  }

 private:
  std::string path_;
  bool vertexUvs_, missingUv_ = false;
  TriangleMesh out_;
};

// The header's keyword: [ST][C][N]OFF; 4OFF and nOFF (other dimensions) are refused by name.
OffLayout offLayout(const std::string& word, const meshio::LineReader& lines) {
  OffLayout l;
  size_t i = 0;
  if (word.compare(i, 2, "ST") == 0) l.texcoords = true, i += 2;
  if (word.compare(i, 1, "C") == 0) l.colors = true, i += 1;
  if (word.compare(i, 1, "N") == 0) l.normals = true, i += 1;
  if (word.compare(i, 1, "4") == 0 || word.compare(i, 1, "n") == 0)
    lines.fail("'" + meshio::capToken(word) + "': only 3-dimensional OFF is supported");
  if (word.compare(i, std::string::npos, "OFF") != 0)
    lines.fail("not an OFF file: the header must be [ST][C][N]OFF, got '" + meshio::capToken(word) + "'");
  return l;
}

TriangleMesh readAsciiOff(meshio::LineReader& lines, const OffLayout& layout, std::vector<std::string> counts,
                          double bytes, const std::string& path) {
  std::string line;
  // The next line that is not blank or a comment: record i of n (vertices or faces; n < 0: the counts).
  auto content = [&](const char* what, long long i, long long n) {
    while (lines.next(line)) {
      auto t = tokens(line);
      if (!t.empty()) return t;
    }
    lines.fail(std::string("the file ends before ") + what +
               (n < 0 ? "" : " " + std::to_string(i) + " of " + std::to_string(n)));
  };
  if (counts.empty()) counts = content("the vertex and face counts", 0, -1);
  long long nv = 0, nf = 0, ne = 0;
  if (counts.size() < 2 || counts.size() > 3 || !wholeNumber(counts[0], 1LL << 32, nv) ||
      !wholeNumber(counts[1], 1LL << 32, nf) || (counts.size() == 3 && !wholeNumber(counts[2], 1LL << 40, ne)))
    lines.fail("expected the counts 'vertices faces [edges]' (whole numbers), got '" +
               meshio::capToken(counts.size() ? counts[0] : std::string()) + (counts.size() > 1 ? " ..." : "") + "'");
  // Each vertex takes at least 6 bytes ("0 0 0\n"), each face 8 ("3 0 1 2\n"): a lying header is refused now.
  if (double(nv) * 6 + double(nf) * 8 > bytes)
    lines.fail("the header announces " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
               " faces, more than the file's " + std::to_string(static_cast<long long>(bytes)) + " bytes can hold");
  CornerMesh b(path, layout.texcoords);
  b.vertices.reserve(static_cast<size_t>(nv));
  const int numbers = layout.vertexNumbers();
  for (long long i = 0; i < nv; ++i) {
    const auto t = content("vertex", i, nv);
    const int extra = static_cast<int>(t.size()) - numbers;
    // Colours, between the normal and the texture coordinates: an index, RGB or RGBA.
    if (layout.colors ? !(extra == 1 || extra == 3 || extra == 4) : extra != 0)
      lines.fail("vertex " + std::to_string(i) + ": expected " + std::to_string(numbers) + " numbers" +
                 (layout.colors ? " and a colour (1, 3 or 4 numbers)" : "") + ", got " + std::to_string(t.size()));
    double x[3] = {0, 0, 0};
    for (size_t k = 0; k < t.size(); ++k) {
      double v = 0;
      const std::string why = meshio::parseNumber(t[k], meshio::kMaxCoordinate, v);
      if (!why.empty()) lines.fail("vertex " + std::to_string(i) + ": '" + meshio::capToken(t[k]) + "' " + why);
      if (k < 3) x[k] = v;
    }
    b.vertices.emplace_back(x[0], x[1], x[2]);
    if (layout.texcoords) {
      double s = 0, tt = 0;
      meshio::parseNumber(t[t.size() - 2], meshio::kMaxCoordinate, s);
      meshio::parseNumber(t[t.size() - 1], meshio::kMaxCoordinate, tt);
      b.uvs.emplace_back(s, 1.0 - tt);  // OFF's t points up the image; ours runs with the rows
    }
  }
  std::vector<long long> corners;
  for (long long f = 0; f < nf; ++f) {
    const auto t = content("face", f, nf);
    long long n = 0;
    if (!wholeNumber(t[0], 1LL << 32, n) || n < 3)
      lines.fail("face " + std::to_string(f) + ": a face needs at least 3 vertices, got '" + meshio::capToken(t[0]) +
                 "'");
    if (static_cast<long long>(t.size()) < 1 + n)
      lines.fail("face " + std::to_string(f) + ": announces " + std::to_string(n) + " vertices, lists " +
                 std::to_string(t.size() - 1));
    corners.clear();
    for (long long k = 1; k <= n; ++k) {
      long long idx = 0;
      if (!wholeNumber(t[static_cast<size_t>(k)], 1LL << 32, idx) || idx >= nv)
        lines.fail("face " + std::to_string(f) + ": vertex index '" + meshio::capToken(t[static_cast<size_t>(k)]) +
                   "' out of range (" + std::to_string(nv) + " vertices)");
      corners.push_back(idx);
    }
    b.face(corners);  // what follows the indices (a colour) does not shape the solid
  }
  return b.finish();
}

TriangleMesh readBinaryOff(std::istream& in, const OffLayout& layout, const std::string& path) {
  if (layout.colors) throw MeshError(path + ": binary OFF with colours (COFF BINARY) is not supported");
  const std::string rest((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  size_t at = 0;
  auto fail = [&](const std::string& why) {
    throw MeshError(path + ": " + why + " (byte " + std::to_string(at) + " after the header)");
  };
  auto int32 = [&](const char* what) {
    if (rest.size() - at < 4) fail(std::string("the file ends in ") + what);
    const auto* p = reinterpret_cast<const unsigned char*>(rest.data() + at);
    at += 4;
    return static_cast<int32_t>(uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24);
  };
  auto float32 = [&](const char* what) {
    const int32_t bits = int32(what);
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  };
  const int32_t nv = int32("the counts"), nf = int32("the counts");
  int32("the counts");  // edges: unused
  if (nv < 0 || nf < 0)
    fail("the header announces " + std::to_string(nv) + " vertices and " + std::to_string(nf) + " faces");
  // Each vertex takes 12 bytes or more, each face at least 16 (a count and 3 indices).
  const size_t vertexBytes = 4 * static_cast<size_t>(layout.vertexNumbers());
  if (double(nv) * double(vertexBytes) + double(nf) * 16 > double(rest.size() - at))
    fail("the header announces " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
         " faces, more than the file's " + std::to_string(rest.size() - at) + " remaining bytes can hold");
  CornerMesh b(path, layout.texcoords);
  b.vertices.reserve(static_cast<size_t>(nv));
  for (int32_t i = 0; i < nv; ++i) {
    float x[8];
    for (int k = 0; k < layout.vertexNumbers(); ++k) {
      x[k] = float32("a vertex");
      if (k < 3 || (layout.texcoords && k >= layout.vertexNumbers() - 2)) {
        if (!(std::abs(x[k]) <= meshio::kMaxCoordinate))
          fail("vertex " + std::to_string(i) + ": " +
               (std::isfinite(x[k]) ? std::string("a coordinate is beyond 1e30 in magnitude") : "not finite"));
      }
    }
    b.vertices.emplace_back(x[0], x[1], x[2]);
    if (layout.texcoords) b.uvs.emplace_back(x[layout.vertexNumbers() - 2], 1.0f - x[layout.vertexNumbers() - 1]);
  }
  std::vector<long long> corners;
  for (int32_t f = 0; f < nf; ++f) {
    const int32_t n = int32("a face");
    if (n < 3) fail("face " + std::to_string(f) + " has " + std::to_string(n) + " vertices: a face needs at least 3");
    if (static_cast<size_t>(n) > (rest.size() - at) / 4)
      fail("face " + std::to_string(f) + " announces " + std::to_string(n) +
           " vertices, more than the rest of the file holds");
    corners.clear();
    for (int32_t k = 0; k < n; ++k) {
      const int32_t idx = int32("a face");
      if (idx < 0 || idx >= nv)
        fail("face " + std::to_string(f) + ": vertex index " + std::to_string(idx) + " out of range (" +
             std::to_string(nv) + " vertices)");
      corners.push_back(idx);
    }
    b.face(corners);
  }
  return b.finish();
}

}  // namespace

TriangleMesh loadOff(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MeshError(path + ": cannot be opened");
  std::error_code ec;
  const double bytes = static_cast<double>(fs::file_size(path, ec));
  meshio::LineReader lines(in, path, "OFF");
  std::string line;
  std::vector<std::string> head;
  while (head.empty()) {
    if (!lines.next(line)) throw MeshError(path + ": empty: not an OFF file");
    head = tokens(line);
  }
  OffLayout layout = offLayout(head[0], lines);
  head.erase(head.begin());
  if (!head.empty() && head[0] == "BINARY") {
    if (head.size() > 1) lines.fail("nothing may follow 'BINARY' on the header line");
    return readBinaryOff(in, layout, path);
  }
  return readAsciiOff(lines, layout, head, bytes, path);
}

// PLY: a header of elements and their properties, then the elements' records in ASCII or binary (either byte
// order). Read: the element 'vertex' (x, y, z; u/v, s/t or texture_u/texture_v), the element 'face' (a list
// vertex_indices or vertex_index; a list texcoord of 2 numbers per corner); other elements are skipped.
namespace {

enum class PlyFormat { Ascii, LittleEndian, BigEndian };

struct PlyProperty {
  std::string name;
  bool list = false;
  int countSize = 0, size = 0;  // bytes of the list's count, of the value (or of each item)
  bool countFloat = false, isFloat = false, isSigned = false, countSigned = false;
};

struct PlyElement {
  std::string name;
  double count = 0;
  int line = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElement> elements;
  size_t bodyStart = 0;
};

// A type name: its size in bytes, whether it is a float and whether signed; false when unknown.
bool plyType(const std::string& t, int& size, bool& isFloat, bool& isSigned) {
  static const struct {
    const char* name;
    int size;
    bool isFloat, isSigned;
  } kTypes[] = {
      {"char", 1, false, true},  {"int8", 1, false, true},   {"uchar", 1, false, false},  {"uint8", 1, false, false},
      {"short", 2, false, true}, {"int16", 2, false, true},  {"ushort", 2, false, false}, {"uint16", 2, false, false},
      {"int", 4, false, true},   {"int32", 4, false, true},  {"uint", 4, false, false},   {"uint32", 4, false, false},
      {"float", 4, true, true},  {"float32", 4, true, true}, {"double", 8, true, true},   {"float64", 8, true, true}};
  for (const auto& k : kTypes)
    if (t == k.name) {
      size = k.size, isFloat = k.isFloat, isSigned = k.isSigned;
      return true;
    }
  return false;
}

// The header, strictly: a corrupted keyword or a missing end_header is an error naming its line (OpenMesh's reader
// looped printing "unsupported element type", or crashed).
PlyHeader readPlyHeader(const std::string& data, const std::string& path) {
  PlyHeader h;
  auto bad = [&](int n, const std::string& why) {
    throw MeshError(path + ": header line " + std::to_string(n) + ": " + why);
  };
  bool format = false;
  size_t pos = 0;
  for (int n = 1; n <= 1000; ++n) {
    const size_t eol = data.find('\n', pos);
    if (eol == std::string::npos && n > 1 && data.size() - pos <= 1000) bad(n, "the file ends before end_header");
    if (eol == std::string::npos || eol - pos > 1000) bad(n, "unreadable or too long (a PLY header is text)");
    std::string line = data.substr(pos, eol - pos);
    pos = eol + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find('\0') != std::string::npos) bad(n, "binary data (a NUL byte) in the header");
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (n == 1) {
      if (tag != "ply") bad(n, "a PLY file starts with 'ply'");
      continue;
    }
    if (tag == "end_header") {
      if (!format) bad(n, "no 'format' line before end_header");
      h.bodyStart = pos;
      return h;
    }
    if (tag == "comment" || tag == "obj_info") continue;
    if (tag == "format") {
      std::string kind, version;
      ls >> kind >> version;
      if ((kind != "ascii" && kind != "binary_little_endian" && kind != "binary_big_endian") || version != "1.0")
        bad(n, "unknown format '" + capText(line, 60) + "'");
      h.format = kind == "ascii"                  ? PlyFormat::Ascii
                 : kind == "binary_little_endian" ? PlyFormat::LittleEndian
                                                  : PlyFormat::BigEndian;
      format = true;
    } else if (tag == "element") {
      std::string kind, countText, more;
      ls >> kind >> countText >> more;
      char* end = nullptr;
      const double count = std::strtod(countText.c_str(), &end);
      if (kind.empty() || countText.empty() || *end != '\0' || !more.empty() || !(count >= 0) ||
          count != std::floor(count) || count > 4294967296.0)
        bad(n, "an element needs a name and a count, got '" + capText(line, 60) + "'");
      h.elements.push_back({kind, count, n, {}});
    } else if (tag == "property") {
      if (h.elements.empty()) bad(n, "a property before any element");
      PlyProperty p;
      std::string type, more;
      ls >> type;
      if (type == "list") {
        std::string countType, itemType;
        ls >> countType >> itemType >> p.name >> more;
        bool countSigned = false;
        if (!plyType(countType, p.countSize, p.countFloat, countSigned) ||
            !plyType(itemType, p.size, p.isFloat, p.isSigned) || p.name.empty() || !more.empty())
          bad(n, "bad list property '" + capText(line, 60) + "'");
        p.countSigned = countSigned;
        p.list = true;
      } else {
        ls >> p.name >> more;
        if (!plyType(type, p.size, p.isFloat, p.isSigned) || p.name.empty() || !more.empty())
          bad(n, "bad property '" + capText(line, 60) + "'");
      }
      h.elements.back().properties.push_back(p);
    } else {
      bad(n, "unknown keyword '" + capText(tag, 40) + "'");
    }
  }
  throw MeshError(path + ": no end_header in the first 1000 lines");
}

std::string shownNumber(double v) {  // a value of the file, which may be any double (never cast to an integer)
  std::ostringstream os;
  os << v;
  return os.str();
}

// Reads the body's values one at a time, in ASCII or binary; running out is an error naming where.
class PlyBody {
 public:
  PlyBody(const std::string& data, size_t start, PlyFormat format, const std::string& path)
      : data_(data), pos_(start), format_(format), path_(path) {}

  void at(const std::string* element, double record) { element_ = element, record_ = record; }
  [[noreturn]] void fail(const std::string& why) const {
    throw MeshError(path_ + ": element '" + capText(*element_, 40) + "' " +
                    std::to_string(static_cast<long long>(record_)) + ": " + why);
  }
  size_t remaining() const { return data_.size() - pos_; }

  double value(int size, bool isFloat, bool isSigned) {
    if (format_ == PlyFormat::Ascii) {
      while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
      const size_t start = pos_;
      while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
      if (pos_ == start) fail("the file ends in this record");
      if (pos_ - start > 64) fail("a value of " + std::to_string(pos_ - start) + " characters");
      const std::string token = data_.substr(start, pos_ - start);
      double v = 0;
      const std::string why = meshio::parseNumber(token, std::numeric_limits<double>::max(), v);
      if (!why.empty()) fail("'" + meshio::capToken(token) + "' " + why);
      if (!isFloat && v != std::floor(v)) fail("'" + meshio::capToken(token) + "' is not a whole number");
      return v;
    }
    if (remaining() < static_cast<size_t>(size)) fail("the file ends in this record");
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, static_cast<size_t>(size));
    pos_ += static_cast<size_t>(size);
    static_assert(std::endian::native == std::endian::little, "binary PLY is read on little-endian hosts");
    if (format_ == PlyFormat::BigEndian) std::reverse(b, b + size);
    switch (size) {
      case 1:
        return isSigned ? double(static_cast<int8_t>(b[0])) : double(b[0]);
      case 2: {
        uint16_t u;
        std::memcpy(&u, b, 2);
        return isSigned ? double(static_cast<int16_t>(u)) : double(u);
      }
      case 4: {
        uint32_t u;
        std::memcpy(&u, b, 4);
        if (isFloat) {
          float f;
          std::memcpy(&f, b, 4);
          return f;
        }
        return isSigned ? double(static_cast<int32_t>(u)) : double(u);
      }
      default: {
        double d;
        std::memcpy(&d, b, 8);
        return d;
      }
    }
  }

  // A list's length: a whole number no larger than what is left of the file could hold.
  size_t listCount(const PlyProperty& p) {
    const double n = value(p.countSize, p.countFloat, p.countSigned);
    const double itemBytes = format_ == PlyFormat::Ascii ? 2 : p.size;
    if (!(n >= 0) || n != std::floor(n) || n * itemBytes > double(remaining()) + 1)
      fail("a list of " + shownNumber(n) + " items in '" + capText(p.name, 40) +
           "', more than the rest of the file holds");
    return static_cast<size_t>(n);
  }

 private:
  const std::string& data_;
  size_t pos_;
  PlyFormat format_;
  std::string path_;
  const std::string* element_ = nullptr;
  double record_ = 0;
};

int findProperty(const PlyElement& e, std::initializer_list<const char*> names, bool list) {
  for (const char* name : names)
    for (size_t i = 0; i < e.properties.size(); ++i)
      if (e.properties[i].name == name && e.properties[i].list == list) return static_cast<int>(i);
  return -1;
}

}  // namespace

TriangleMesh loadPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MeshError(path + ": cannot be opened");
  // The header first (it ends within 1000 lines of 1000 characters), the body only when the header holds.
  std::string data(1001 * 1001, '\0');
  in.read(data.data(), static_cast<std::streamsize>(data.size()));
  data.resize(static_cast<size_t>(in.gcount()));
  const PlyHeader h = readPlyHeader(data, path);
  data.append(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  // Each record takes at least a byte per value in binary (2 in ASCII: the value and a separator): counts the
  // file cannot hold are refused before anything is reserved.
  double least = 0;
  for (const PlyElement& e : h.elements) {
    double bytes = 0;
    for (const PlyProperty& p : e.properties) bytes += h.format == PlyFormat::Ascii ? 2 : p.list ? p.countSize : p.size;
    least += e.count * bytes;
  }
  if (least > double(data.size() - h.bodyStart) + 1)
    throw MeshError(path + ": the header announces more records than the file's " + std::to_string(data.size()) +
                    " bytes can hold");
  PlyBody body(data, h.bodyStart, h.format, path);
  bool haveVertices = false;
  int x = -1, y = -1, z = -1, u = -1, v = -1;
  for (const PlyElement& e : h.elements) {
    if (e.name == "vertex") {
      x = findProperty(e, {"x"}, false), y = findProperty(e, {"y"}, false), z = findProperty(e, {"z"}, false);
      if (x < 0 || y < 0 || z < 0)
        throw MeshError(path + ": header line " + std::to_string(e.line) + ": the vertex element has no x, y and z");
      u = findProperty(e, {"u", "s", "texture_u", "texture_s"}, false);
      v = findProperty(e, {"v", "t", "texture_v", "texture_t"}, false);
      if (u < 0 || v < 0) u = v = -1;
      break;
    }
  }
  CornerMesh mesh(path, u >= 0);
  std::vector<double> values;
  std::vector<long long> corners;
  std::vector<double> cornerUvs;
  for (const PlyElement& e : h.elements) {
    const bool isVertex = e.name == "vertex" && !haveVertices;
    const bool isFace = e.name == "face";
    int indices = -1, texcoord = -1;
    if (isFace) {
      if (!haveVertices)
        throw MeshError(path + ": header line " + std::to_string(e.line) + ": faces before the vertex element");
      indices = findProperty(e, {"vertex_indices", "vertex_index"}, true);
      if (indices < 0)
        throw MeshError(path + ": header line " + std::to_string(e.line) +
                        ": the face element has no list vertex_indices");
      texcoord = findProperty(e, {"texcoord"}, true);
    }
    if (e.properties.empty()) continue;  // records of nothing: nothing to read
    if (isVertex) mesh.vertices.reserve(static_cast<size_t>(e.count));
    for (double r = 0; r < e.count; ++r) {
      body.at(&e.name, r);
      values.assign(e.properties.size(), 0);
      corners.clear();
      cornerUvs.clear();
      for (size_t pi = 0; pi < e.properties.size(); ++pi) {
        const PlyProperty& p = e.properties[pi];
        if (!p.list) {
          values[pi] = body.value(p.size, p.isFloat, p.isSigned);
          continue;
        }
        const size_t n = body.listCount(p);
        for (size_t k = 0; k < n; ++k) {
          const double item = body.value(p.size, p.isFloat, p.isSigned);
          if (static_cast<int>(pi) == indices) {
            if (!(item >= 0 && item < double(mesh.vertices.size())))
              body.fail("vertex index " + shownNumber(item) + " out of range (" + std::to_string(mesh.vertices.size()) +
                        " vertices)");
            corners.push_back(static_cast<long long>(item));
          } else if (static_cast<int>(pi) == texcoord) {
            cornerUvs.push_back(item);
          }
        }
      }
      if (isVertex) {
        glm::vec3 pos;
        const int axes[3] = {x, y, z};
        for (int c = 0; c < 3; ++c) {
          const double q = values[static_cast<size_t>(axes[c])];
          if (!(std::abs(q) <= meshio::kMaxCoordinate))
            body.fail(std::isfinite(q) ? "a coordinate is beyond 1e30 in magnitude" : "a coordinate is not finite");
          pos[c] = static_cast<float>(q);
        }
        mesh.vertices.push_back(pos);
        if (u >= 0) {
          const double s = values[static_cast<size_t>(u)], t = values[static_cast<size_t>(v)];
          if (!(std::abs(s) <= meshio::kMaxCoordinate && std::abs(t) <= meshio::kMaxCoordinate))
            body.fail("a texture coordinate is not finite or beyond 1e30");
          mesh.uvs.emplace_back(s, 1.0 - t);  // PLY's v points up the image; ours runs with the rows
        }
      } else if (isFace) {
        if (corners.size() < 3) body.fail("a face needs at least 3 vertices, got " + std::to_string(corners.size()));
        bool uvOk = cornerUvs.size() == 2 * corners.size();
        for (double t : cornerUvs) uvOk = uvOk && std::abs(t) <= meshio::kMaxCoordinate;
        mesh.face(corners, uvOk ? &cornerUvs : nullptr);
      }
    }
    if (isVertex) haveVertices = true;
  }
  if (!haveVertices) throw MeshError(path + ": no vertex element");
  return mesh.finish();
}

}  // namespace crumple
