#include <crumple/engine/overrides.h>

#include <cctype>
#include <cstring>
#include <stdexcept>

namespace crumple {

using json = nlohmann::json;

namespace {

// One step of a key path: `.key` / the first key, or `[selector]`.
struct PathStep {
  bool bracket = false;
  bool quoted = false;  // ["name"]: always a name, never an index
  std::string text;
};

bool allDigits(const std::string& s) {
  if (s.empty() || s.size() > 9) return false;
  for (unsigned char c : s)
    if (!std::isdigit(c)) return false;
  return true;
}

// Key paths are short: a scene's deepest key path has a handful of parts. The bounds are checked before anything
// else, and the path is read in one pass: a key of 60000 parts is refused at once, not parsed into 60000 objects.
constexpr size_t kMaxKeyPathBytes = 1024, kMaxKeyPathParts = 64;

std::vector<PathStep> splitPath(const std::string& key, const std::string& file) {
  // A key path too long to name in full is quoted: its start and end, escaped.
  auto fail = [&](const std::string& why) -> void {
    throw SceneError(file, key.size() > kMaxKeyPathBytes ? quoteText(key) : key, "bad key path: " + why);
  };
  if (key.size() > kMaxKeyPathBytes)
    fail("longer than " + std::to_string(kMaxKeyPathBytes) + " characters (" + std::to_string(key.size()) + ")");
  if (!isValidUtf8(key)) fail("not valid UTF-8");
  std::vector<PathStep> steps;
  size_t i = 0;
  auto push = [&](PathStep s) {
    if (steps.size() == kMaxKeyPathParts) fail("more than " + std::to_string(kMaxKeyPathParts) + " parts");
    steps.push_back(std::move(s));
  };
  auto readKey = [&]() {
    const size_t start = i;
    while (i < key.size() && key[i] != '.' && key[i] != '[') ++i;
    if (i == start) fail(start == 0 ? "it starts with '" + std::string(1, key[0]) + "'" : "an empty key at column " +
                                                                                              std::to_string(start + 1));
    push({false, false, key.substr(start, i - start)});
  };
  if (key.empty()) fail("it is empty");
  if (key[0] != '[') readKey();
  while (i < key.size()) {
    if (key[i] == '.') {
      ++i;
      readKey();
    } else if (key[i] == '[') {
      ++i;
      PathStep s;
      s.bracket = true;
      if (i < key.size() && key[i] == '"') {
        // A JSON string: find its closing quote, skipping escapes.
        size_t end = i + 1;
        while (end < key.size() && key[end] != '"') end += key[end] == '\\' ? 2 : 1;
        if (end >= key.size()) fail("an unclosed '\"'");
        try {
          s.text = json::parse(key.substr(i, end + 1 - i)).get<std::string>();
        } catch (const json::exception&) {
          fail("a bad quoted name at column " + std::to_string(i + 1));
        }
        s.quoted = true;
        i = end + 1;
        if (i >= key.size() || key[i] != ']') fail("expected ']' at column " + std::to_string(i + 1));
      } else {
        const size_t end = key.find(']', i);
        if (end == std::string::npos) fail("an unclosed '['");
        s.text = key.substr(i, end - i);
        if (s.text.empty()) fail("empty brackets '[]'");
        i = end;
      }
      ++i;  // past ']'
      push(std::move(s));
      if (i < key.size() && key[i] != '.' && key[i] != '[')
        fail("expected '.' or '[' after ']' at column " + std::to_string(i + 1));
    } else {
      fail("unexpected '" + std::string(1, key[i]) + "' at column " + std::to_string(i + 1));
    }
  }
  return steps;
}

// "bodies" -> "body", "cameras" -> "camera": the word for one element in messages.
std::string singular(const std::string& arrayKey) {
  if (arrayKey.size() > 3 && arrayKey.compare(arrayKey.size() - 3, 3, "ies") == 0)
    return arrayKey.substr(0, arrayKey.size() - 3) + "y";
  if (arrayKey.size() > 1 && arrayKey.back() == 's') return arrayKey.substr(0, arrayKey.size() - 1);
  return "entry";
}

std::string lastKey(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  std::string k = dot == std::string::npos ? path : path.substr(dot + 1);
  const size_t br = k.find('[');
  return br == std::string::npos ? k : k.substr(0, br);
}

std::string listNames(const std::vector<std::string>& names) {
  std::string out;
  for (size_t i = 0; i < names.size() && i < 12; ++i) out += (i ? ", " : "") + quoteText(names[i], 40);
  if (names.size() > 12) out += ", ... (" + std::to_string(names.size()) + " in all)";
  return out.empty() ? "none" : out;
}

const char* kindOf(const json& j) {
  if (j.is_array()) return "an array";
  if (j.is_object()) return "an object";
  if (j.is_string()) return "a string";
  if (j.is_number()) return "a number";
  if (j.is_boolean()) return "a boolean";
  return "null";
}

bool atOrUnder(const std::string& path, const std::string& root) {
  if (path.size() < root.size() || path.compare(0, root.size(), root) != 0) return false;
  return path.size() == root.size() || path[root.size()] == '.' || path[root.size()] == '[';
}

// The paths overrides wrote (their targets and the objects they created on the way), while a scene with
// overrides is parsed on this thread.
thread_local const std::vector<std::string>* tOverridden = nullptr;

struct OverriddenScope {
  explicit OverriddenScope(const std::vector<std::string>* paths) : previous(tOverridden) { tOverridden = paths; }
  ~OverriddenScope() { tOverridden = previous; }
  const std::vector<std::string>* previous;
};

// Applies one override; returns its canonical path and appends it, and every object it created, to `written`.
std::string applyOne(json& root, const Override& o, const std::string& file, std::vector<std::string>& written) {
  const std::string& key = o.first;
  const std::vector<PathStep> steps = splitPath(key, file);
  const json value = overrideValue(file, key, o.second);
  json* cur = &root;
  std::string path;  // canonical so far
  for (size_t s = 0; s < steps.size(); ++s) {
    const PathStep& step = steps[s];
    const bool last = s + 1 == steps.size();
    const std::string where = path.empty() ? "the scene" : path;
    if (cur->is_array()) {
      if (!step.bracket)
        throw SceneError(file, key,
                         where + " is an array: pick an element with [index] or [name], not '." + step.text + "'");
      size_t index = cur->size();
      if (!step.quoted && allDigits(step.text)) {
        index = std::stoul(step.text);
        if (index >= cur->size())
          throw SceneError(file, key,
                           where + " has " + std::to_string(cur->size()) + (cur->size() == 1 ? " entry" : " entries") +
                               ": no [" + step.text + "]" +
                               (cur->empty() ? "" : " (0 to " + std::to_string(cur->size() - 1) + ")"));
      } else {
        // By name: the element whose "name" is the text; joints and cameras without one go by their default
        // names (joint<i>, camera<i>), as the loader names them.
        const std::string arrayKey = lastKey(path);
        const bool defaults = path == "joints" || path == "cameras";
        std::vector<std::string> names;
        for (size_t i = 0; i < cur->size(); ++i) {
          const json& e = (*cur)[i];
          std::string name;
          if (e.is_object() && e.contains("name") && e["name"].is_string())
            name = e["name"].get<std::string>();
          else if (defaults && e.is_object() && !e.contains("name"))
            name = singular(arrayKey) + std::to_string(i);
          else
            continue;
          if (name == step.text && index == cur->size()) index = i;
          names.push_back(name);
        }
        if (index == cur->size())
          throw SceneError(file, key,
                           "no " + singular(arrayKey) + " is named '" + quoteText(step.text) + "' (" +
                               (path.empty() ? std::string("names") : path) + ": " + listNames(names) + ")");
      }
      path += "[" + std::to_string(index) + "]";
      cur = &(*cur)[index];
      continue;
    }
    if (!cur->is_object())
      throw SceneError(file, key,
                       where + " is " + kindOf(*cur) + ", not an object: it has no key '" + quoteText(step.text) + "'");
    const std::string child = path.empty() ? step.text : path + "." + step.text;
    if (!cur->contains(step.text)) {
      // A material is set key by key only when it is defined (a typo would make a new material silently).
      if (path == "materials" && !last) {
        std::vector<std::string> names;
        for (auto it = cur->begin(); it != cur->end(); ++it) names.push_back(it.key());
        throw SceneError(file, key,
                         "no material is named '" + quoteText(step.text) + "' (materials: " + listNames(names) + ")");
      }
      if (path.empty() && step.text == "materials" && !last)
        throw SceneError(file, key, "the scene defines no materials");
      if (!last) {
        (*cur)[step.text] = json::object();
        written.push_back(child);
      }
    }
    path = child;
    cur = &(*cur)[step.text];
  }
  *cur = value;
  written.push_back(path);
  return path;
}

std::vector<std::string> apply(json& root, const Overrides& overrides, const std::string& file,
                               std::vector<std::string>& written) {
  if (!root.is_object()) throw SceneError(file, "", "the top level must be an object to be overridden");
  std::vector<std::string> paths;
  for (const Override& o : overrides) paths.push_back(applyOne(root, o, file, written));
  return paths;
}

}  // namespace

Override parseOverride(const std::string& assignment) {
  // The first '=' outside brackets: a quoted name may hold one (bodies["a=b"].velocity=...).
  int depth = 0;
  bool quoted = false;
  for (size_t i = 0; i < assignment.size(); ++i) {
    const char c = assignment[i];
    if (quoted) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        quoted = false;
    } else if (c == '"' && depth > 0) {
      quoted = true;
    } else if (c == '[') {
      ++depth;
    } else if (c == ']') {
      depth = std::max(0, depth - 1);
    } else if (c == '=' && depth == 0) {
      if (i == 0) throw SceneError("--set", assignment, "the key is empty: expected KEY=VALUE");
      return {assignment.substr(0, i), assignment.substr(i + 1)};
    }
  }
  throw SceneError("--set", assignment, "expected KEY=VALUE (no '=' found)");
}

json overrideValue(const std::string& file, const std::string& key, const std::string& value) {
  // A plain word is taken as a string as it is: it must be text, as a scene file's strings are.
  if (!isValidUtf8(value)) throw SceneError(file, key, "the value '" + quoteText(value) + "' is not valid UTF-8");
  try {
    return json::parse(value);
  } catch (const json::exception& e) {
    const size_t first = value.find_first_not_of(" \t\r\n");
    if (first == std::string::npos)
      throw SceneError(file, key, "the value is empty (write \"\" for an empty string)");
    if (std::strchr("[{\"-+.0123456789", value[first]) != nullptr) {
      std::string what = e.what();
      const size_t pos = what.find("] ");
      if (pos != std::string::npos) what = what.substr(pos + 2);
      throw SceneError(file, key, "the value '" + quoteText(value) + "' is not valid JSON: " + what);
    }
    return json(value);  // a plain word: a string
  }
}

std::vector<std::string> applyOverrides(json& root, const Overrides& overrides, const std::string& file) {
  std::vector<std::string> written;
  return apply(root, overrides, file, written);
}

bool isOverriddenPath(const std::string& keyPath) {
  if (!tOverridden) return false;
  for (const std::string& p : *tOverridden)
    if (atOrUnder(keyPath, p)) return true;
  return false;
}

Scene parseScene(const std::string& text, const std::string& file, const std::string& baseDir,
                 const Overrides& overrides) {
  if (overrides.empty()) return parseScene(text, file, baseDir);
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception&) {
    parseScene(text, file, baseDir);  // throws the loader's message for malformed JSON
    throw std::logic_error("parseScene accepted text that json::parse refused");
  }
  if (!root.is_object()) {
    parseScene(text, file, baseDir);
    throw std::logic_error("parseScene accepted a top level that is not an object");
  }
  std::vector<std::string> written;
  const std::vector<std::string> paths = apply(root, overrides, file, written);
  OverriddenScope scope(&written);
  try {
    return parseScene(root.dump(), file, baseDir);
  } catch (const SceneError& e) {
    // Say which override set the value at fault (the last one to touch it): the error is at or under what it
    // set, or at an object it created on the way (an unknown key).
    for (size_t i = overrides.size(); i-- > 0;) {
      if (e.keyPath.empty()) break;
      if (atOrUnder(e.keyPath, paths[i]) || (atOrUnder(paths[i], e.keyPath) && isOverriddenPath(e.keyPath)))
        throw SceneError(e.file, e.keyPath, e.reason + " (set by the override " + overrides[i].first + ")");
    }
    throw;
  }
}

}  // namespace crumple
