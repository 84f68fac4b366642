// Internal to engine/ (not installed): a view of one JSON value of a scene file at its key path, with typed,
// validated getters whose errors name the file, the key path and the reason (SceneError).
#pragma once
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include <crumple/core/log.h>
#include <crumple/engine/overrides.h>
#include <crumple/engine/scene.h>

namespace crumple::scene_file {

using json = nlohmann::json;

inline const char* typeName(const json& j) {
  switch (j.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::object:
      return "an object";
    case json::value_t::array:
      return "an array";
    case json::value_t::string:
      return "a string";
    case json::value_t::boolean:
      return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
      return "an integer";
    case json::value_t::number_float:
      return "a number";
    default:
      return "something else";
  }
}

inline std::string shortDump(const json& j) {
  // Arrays and objects are counted, never dumped: a value nested 100000 deep would overflow the stack.
  if (j.is_array()) return "an array of " + std::to_string(j.size()) + (j.size() == 1 ? " item" : " items");
  if (j.is_object()) return "an object of " + std::to_string(j.size()) + (j.size() == 1 ? " key" : " keys");
  std::string s = j.dump();
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return s;
}

// A view of one JSON object at a key path, with typed, validated getters.
class Node {
 public:
  Node(const json& j, std::string path, const std::string& file) : j_(j), path_(std::move(path)), file_(file) {}

  [[noreturn]] void fail(const std::string& key, const std::string& why) const {
    throw SceneError(file_, join(key), why);
  }
  std::string join(const std::string& key) const {
    if (key.empty()) return path_;
    if (!key.empty() && key[0] == '[') return path_ + key;
    return path_.empty() ? key : path_ + "." + key;
  }
  bool has(const std::string& key) const { return j_.is_object() && j_.contains(key); }
  const json& raw(const std::string& key) const { return j_.at(key); }

  void requireObject() const {
    if (!j_.is_object()) throw SceneError(file_, path_, std::string("must be an object, got ") + typeName(j_));
  }

  // Warn about keys nobody reads: likely typos.
  void checkKeys(std::initializer_list<const char*> known) const {
    for (auto it = j_.begin(); it != j_.end(); ++it) {
      bool ok = false;
      for (const char* k : known) ok = ok || it.key() == k;
      if (!ok && isOverriddenPath(join(it.key()))) fail(it.key(), "unknown key");  // set by an override
      if (!ok) logWarning(quoteText(file_, 300), ": ", quoteText(join(it.key()), 300), ": unknown key, ignored");
    }
  }

  double number(const std::string& key, double def, double lo, double hi, bool loOpen = false,
                bool hiOpen = false) const {
    if (!has(key)) return def;
    return numberValue(j_.at(key), key, lo, hi, loOpen, hiOpen);
  }
  double requiredNumber(const std::string& key, double lo, double hi, bool loOpen = false) const {
    if (!has(key)) fail(key, "is required");
    return numberValue(j_.at(key), key, lo, hi, loOpen, false);
  }
  double numberValue(const json& v, const std::string& key, double lo, double hi, bool loOpen, bool hiOpen) const {
    if (!v.is_number()) fail(key, std::string("must be a number, got ") + typeName(v) + " " + shortDump(v));
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail(key, "must be finite");
    if ((loOpen ? !(x > lo) : !(x >= lo)) || (hiOpen ? !(x < hi) : !(x <= hi))) {
      std::ostringstream os;
      os << "must be in " << (loOpen ? "(" : "[") << lo << ", " << hi << (hiOpen ? ")" : "]") << ", got " << x;
      fail(key, os.str());
    }
    return x;
  }
  int integer(const std::string& key, int def, int lo, int hi) const {
    if (!has(key)) return def;
    const json& v = j_.at(key);
    if (!v.is_number_integer() && !(v.is_number_float() && std::floor(v.get<double>()) == v.get<double>()))
      fail(key, std::string("must be an integer, got ") + typeName(v) + " " + shortDump(v));
    const double x = v.get<double>();
    if (!(x >= lo && x <= hi)) {
      std::ostringstream os;
      os << "must be in [" << lo << ", " << hi << "], got " << shortDump(v);
      fail(key, os.str());
    }
    return static_cast<int>(x);
  }
  bool boolean(const std::string& key, bool def) const {
    if (!has(key)) return def;
    const json& v = j_.at(key);
    if (!v.is_boolean()) fail(key, std::string("must be true or false, got ") + typeName(v));
    return v.get<bool>();
  }
  std::string string(const std::string& key, const std::string& def) const {
    if (!has(key)) return def;
    const json& v = j_.at(key);
    if (!v.is_string()) fail(key, std::string("must be a string, got ") + typeName(v));
    return v.get<std::string>();
  }
  // A string that must be one of `names` (each with what it stands for); the first name when the key is absent.
  template <typename E>
  E choice(const std::string& key, const std::vector<std::pair<std::string, E>>& names) const {
    const std::string v = string(key, names.front().first);
    std::string list;
    for (size_t i = 0; i < names.size(); ++i) {
      if (names[i].first == v) return names[i].second;
      list += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + ("\"" + names[i].first + "\"");
    }
    fail(key, "must be " + list + ", got '" + quoteText(v) + "'");
  }
  std::string requiredString(const std::string& key) const {
    if (!has(key)) fail(key, "is required");
    return string(key, "");
  }
  glm::dvec3 vec3(const std::string& key, glm::dvec3 def, double limit = 1e6) const {
    if (!has(key)) return def;
    return vec3Value(j_.at(key), key, limit);
  }
  glm::dvec3 vec3Value(const json& v, const std::string& key, double limit) const {
    if (!v.is_array() || v.size() != 3) fail(key, "must be an array of 3 numbers, got " + shortDump(v));
    glm::dvec3 r;
    for (int i = 0; i < 3; ++i)
      r[i] = Node(v, join(key), file_)
                 .numberValue(v[static_cast<size_t>(i)], "[" + std::to_string(i) + "]", -limit, limit, false, false);
    return r;
  }
  Node child(const std::string& key) const {
    Node n(j_.at(key), join(key), file_);
    n.requireObject();
    return n;
  }
  const json& value() const { return j_; }
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

 private:
  const json& j_;
  std::string path_;
  const std::string& file_;
};

}  // namespace crumple::scene_file
