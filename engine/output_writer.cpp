#include <crumple/engine/output_writer.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <unistd.h>

#include <crumple/core/log.h>
#include <crumple/engine/gltf_export.h>
#include <crumple/gl/image.h>

namespace crumple {

namespace fs = std::filesystem;

namespace {

// The first line of a small text file ("" when it cannot be read).
std::string firstLine(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

std::string bootId() { return firstLine("/proc/sys/kernel/random/boot_id"); }

std::string hostName() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "";
  return buf;
}

// A process's start time (clock ticks after boot, /proc/<pid>/stat's 22nd field); "" when there is no such process.
std::string processStartTime(long pid) {
  const std::string stat = firstLine("/proc/" + std::to_string(pid) + "/stat");
  // After the command name in parentheses (which may hold spaces and parentheses itself): field 3 on.
  const size_t close = stat.rfind(')');
  if (close == std::string::npos) return "";
  std::istringstream fields(stat.substr(close + 1));
  std::string field;
  for (int i = 3; i <= 22; ++i)
    if (!(fields >> field)) return "";
  return field;
}

// The owner a staging folder's marker records: this process.
nlohmann::json ownerRecord() {
  const long pid = static_cast<long>(::getpid());
  return {{"pid", pid}, {"start_time", processStartTime(pid)}, {"boot_id", bootId()}, {"host", hostName()}};
}

// Whether the process that an owner record names is gone for sure: the machine has booted since, or no process of
// that id started at that time runs now. Unknown (another machine, an unreadable record, no /proc): not gone.
bool ownerGone(const nlohmann::json& owner) {
  if (!owner.is_object() || !owner.contains("pid") || !owner["pid"].is_number_integer() ||
      !owner.contains("start_time") || !owner["start_time"].is_string() || !owner.contains("boot_id") ||
      !owner["boot_id"].is_string() || !owner.contains("host") || !owner["host"].is_string())
    return false;
  const std::string boot = bootId(), host = hostName();
  if (boot.empty() || host.empty() || owner["host"].get<std::string>() != host) return false;
  if (owner["boot_id"].get<std::string>() != boot) return true;
  const long pid = owner["pid"].get<long>();
  if (pid <= 0) return false;
  std::error_code ec;
  if (!fs::exists("/proc/self/stat", ec)) return false;  // no /proc: cannot tell
  const std::string started = processStartTime(pid);
  return started.empty() || started != owner["start_time"].get<std::string>();
}

// Whether `name` is `base`.partial-<digits>-<digits>, a staging folder's name.
bool isStagingName(const std::string& name, const std::string& base) {
  const std::string prefix = base + ".partial-";
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return false;
  int dashes = 0;
  bool digit = false;
  for (size_t i = prefix.size(); i < name.size(); ++i) {
    if (name[i] == '-') {
      if (!digit || ++dashes > 1) return false;
      digit = false;
    } else if (name[i] >= '0' && name[i] <= '9') {
      digit = true;
    } else {
      return false;
    }
  }
  return dashes == 1 && digit;
}

// A marker written whole or not at all (to a name of its own, then renamed over): a run that reads it, or a run
// killed while writing it, never meets half of one.
void writeMarker(const fs::path& folder, const nlohmann::json& marker, const std::string& where) {
  const fs::path path = folder / OutputWriter::kMarker, part = folder / (std::string(OutputWriter::kMarker) + ".part");
  {
    std::ofstream out(part);
    out << marker.dump(1) << "\n";
    out.close();
    if (!out) throw std::runtime_error(where + ": cannot write " + OutputWriter::kMarker);
  }
  std::error_code ec;
  fs::rename(part, path, ec);
  if (ec) throw std::runtime_error(where + ": cannot write " + OutputWriter::kMarker + ": " + ec.message());
}

}  // namespace

OutputWriter::OutputWriter(const std::string& dir) : given_(dir) {
  if (dir.empty()) throw SceneError(dir, "", "the output folder's path is empty");
  if (dir.find('\0') != std::string::npos) throw SceneError(dir, "", "the output folder's path holds a NUL byte");
  std::error_code ec;
  dir_ = fs::absolute(dir, ec).lexically_normal().string();
  if (ec) throw SceneError(dir, "", "cannot make the path absolute: " + ec.message());
  while (dir_.size() > 1 && dir_.back() == '/') dir_.pop_back();
  if (fs::path(dir_).filename().empty() || dir_ == "/")
    throw SceneError(dir, "", "is not a folder that can be written");
  if (fs::exists(dir_, ec)) {
    if (!fs::is_directory(dir_, ec)) throw SceneError(dir, "", "output path exists and is not a folder");
    if (!fs::is_empty(dir_, ec)) checkReplaceable(dir);
  }
}

void OutputWriter::begin() {
  if (begun_) return;
  std::error_code ec;
  const fs::path parent = fs::path(dir_).parent_path();
  fs::create_directories(parent, ec);
  if (ec) throw SceneError(given_, "", "cannot create the parent folder: " + ec.message());
  removeStaleStaging();
  std::random_device rd;
  staging_ = dir_ + ".partial-" + std::to_string(::getpid()) + "-" + std::to_string(rd() % 100000);
  fs::create_directories(staging_, ec);
  if (ec) throw SceneError(given_, "", "cannot create a folder next to it: " + ec.message());
  begun_ = true;
  // Its marker names its owner from the start, so that a later run can tell it was left behind.
  writeMarker(staging_, {{"format", "crumple-output/1"}, {"files", nlohmann::json::array()}, {"owner", ownerRecord()}},
              staging_);
}

void OutputWriter::removeStaleStaging() const {
  const fs::path parent = fs::path(dir_).parent_path();
  const std::string base = fs::path(dir_).filename().string();
  std::error_code ec;
  std::vector<fs::path> stale;
  for (auto it = fs::directory_iterator(parent, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const fs::path p = it->path();
    if (!isStagingName(p.filename().string(), base)) continue;
    std::error_code sec;
    // A real folder (not a link to one) holding a regular marker file.
    if (!fs::is_directory(fs::symlink_status(p, sec)) || !fs::is_regular_file(fs::symlink_status(p / kMarker, sec)))
      continue;
    if (fs::file_size(p / kMarker, sec) > (1u << 20) || sec) continue;
    try {
      std::ifstream in(p / kMarker);
      const nlohmann::json marker = nlohmann::json::parse(in);
      if (marker.is_object() && marker.contains("format") && marker["format"] == "crumple-output/1" &&
          marker.contains("owner") && ownerGone(marker["owner"]))
        stale.push_back(p);
    } catch (const std::exception&) {
      continue;  // not a marker crumple wrote: not touched
    }
  }
  for (const fs::path& p : stale) {
    std::error_code rec;
    fs::remove_all(p, rec);
    if (rec)
      logWarning(p.string(), ": cannot remove this staging folder of a run that did not end: ", rec.message());
    else
      logInfo("removed ", p.string(), ", the staging folder of a run that did not end");
  }
}

void OutputWriter::checkReplaceable(const std::string& dir) const {
  const fs::path root(dir_);
  std::ifstream in(root / kMarker);
  if (!in)
    throw SceneError(dir, "",
                     "output folder exists, is not empty and was not written by crumple (no " + std::string(kMarker) +
                         "): refusing to replace it; choose another --out or empty it");
  std::set<std::string> ours;
  try {
    const nlohmann::json marker = nlohmann::json::parse(in);
    for (const auto& f : marker.at("files")) ours.insert(f.get<std::string>());
  } catch (const std::exception& e) {
    throw SceneError(dir, kMarker, std::string("unreadable (") + e.what() + "): refusing to replace the folder");
  }
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(root, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    if (it->is_directory(ec)) continue;
    const std::string rel = fs::relative(it->path(), root, ec).generic_string();
    if (rel != kMarker && !ours.count(rel))
      throw SceneError(
          dir, "",
          "holds '" + rel + "', which crumple did not write: refusing to replace the folder (move it away first)");
  }
  if (ec) throw SceneError(dir, "", "cannot list the folder: " + ec.message());
}

void OutputWriter::abandon() {
  if (committed_ || staging_.empty()) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
  staging_.clear();
}

OutputWriter::~OutputWriter() { abandon(); }

namespace {

using json = nlohmann::ordered_json;

json vec(const glm::dvec3& v) { return {v.x, v.y, v.z}; }

json bodiesArray(const Simulation& sim) {
  json bodies = json::array();
  for (const auto& b : sim.bodies()) {
    const RigidBody& rb = sim.world().body(b.index);
    json jb;
    jb["name"] = b.name;
    jb["position"] = vec(rb.origin());
    jb["orientation"] = {rb.q.w, rb.q.x, rb.q.y, rb.q.z};
    jb["linear_velocity"] = vec(rb.v);
    jb["angular_velocity"] = vec(rb.w);
    jb["center_of_mass"] = vec(rb.x);
    if (!rb.isStatic) jb["mass"] = rb.mass;  // (a static body has none: no key)
    jb["static"] = rb.isStatic;
    if (rb.kinematic) jb["kinematic"] = true;
    jb["asleep"] = rb.asleep;
    bodies.push_back(jb);
  }
  return bodies;
}

}  // namespace

// Every number in `j` finite, or std::runtime_error naming `what` (a NaN would be written as null: never).
const json& finiteNumbers(const json& j, const std::string& what) {
  if (j.is_number_float() && !std::isfinite(j.get<double>()))
    throw std::runtime_error(what + ": a number that is not finite; nothing written");
  if (j.is_structured())
    for (const auto& item : j) finiteNumbers(item, what);
  return j;
}

std::string bodiesJson(const Simulation& sim) { return finiteNumbers(bodiesArray(sim), "bodies").dump(); }

std::vector<std::string> eventLines(Simulation& sim) {
  sim.resolveEventStats();
  std::vector<std::string> lines;
  const std::vector<JointBreakRecord>& breaks = sim.jointBreaks();
  size_t nextBreak = 0;
  auto addBreaks = [&](double until) {
    for (; nextBreak < breaks.size() && breaks[nextBreak].time <= until; ++nextBreak) {
      json line;
      line["t"] = breaks[nextBreak].time;
      line["type"] = "joint_break";
      line["joint"] = breaks[nextBreak].joint;
      line["impulse"] = breaks[nextBreak].impulse;
      lines.push_back(finiteNumbers(line, "events.jsonl").dump());
    }
  };
  for (const EventRecord& r : sim.events()) {
    const auto& e = r.event;
    addBreaks(std::nextafter(e.time, -1.0));
    json line;
    line["t"] = e.time;
    line["type"] = "collision";
    const std::string* names[2] = {nullptr, nullptr};
    for (const auto& b : sim.bodies()) {
      if (b.index == e.a) names[0] = &b.name;
      if (b.index == e.b) names[1] = &b.name;
    }
    line["a"] = *names[0];
    line["b"] = *names[1];
    line["point"] = vec(e.point);
    line["normal"] = vec(e.normal);
    line["penetration"] = e.penetration;
    line["impulse_elastic"] = e.elasticImpulse;
    line["impulse"] = e.impulse;
    for (int s = 0; s < 2; ++s) {
      const SideDecision& d = r.side[s];
      json side;
      if (std::isfinite(d.threshold)) side["threshold"] = d.threshold;  // (none where eps = 1: never dents)
      side["percent_deform"] = d.percentDeform;
      side["deform_depth"] = d.deformDepth;
      side["deformed"] = d.deformed;
      side["texels_changed"] = d.stats.texelsChanged;
      side["max_dent"] = d.stats.maxDent;
      side["saturated"] = d.stats.saturated;
      line[s == 0 ? "a_side" : "b_side"] = side;
    }
    lines.push_back(finiteNumbers(line, "events.jsonl").dump());
  }
  addBreaks(std::numeric_limits<double>::infinity());
  return lines;
}

std::string summaryJson(Simulation& sim, const std::map<std::string, std::string>& extra) {
  sim.resolveEventStats();
  long deformedSides = 0;
  for (const EventRecord& r : sim.events()) deformedSides += r.side[0].deformed + r.side[1].deformed;
  json s;
  s["scene"] = sim.scene().name;
  s["scene_file"] = escapeInvalidUtf8(sim.scene().file);  // a path: bytes, not always UTF-8
  s["steps"] = sim.steps();
  s["time"] = sim.world().time();
  s["bodies"] = bodiesArray(sim);
  if (!sim.scene().joints.empty()) {
    json joints = json::array();
    for (size_t i = 0; i < sim.scene().joints.size() && i < sim.joints().size(); ++i) {
      const JointDesc& d = sim.scene().joints[i];
      const JointState st = sim.world().jointState(sim.joints()[i]);
      json jj;
      jj["name"] = d.name;
      jj["type"] = jointTypeName(d.def.type);
      jj["broken"] = st.broken;
      jj["peak_impulse"] = i < sim.jointPeaks().size() ? sim.jointPeaks()[i] : 0.0;
      if (d.def.type == JointType::Hinge) jj["angle"] = st.angle * 180.0 / 3.14159265358979323846;
      if (d.def.type == JointType::Slider) jj["offset"] = st.offset;
      if (d.def.type == JointType::Distance) jj["distance"] = st.offset;
      joints.push_back(jj);
    }
    s["joints"] = joints;
    s["joint_breaks"] = sim.jointBreaks().size();
  }
  s["collisions"] = sim.events().size();
  s["deformations"] = sim.timings().deformations;
  s["deformed_sides"] = deformedSides;
  s["contact_deformations"] = sim.timings().contactDeformations;
  sim.gpuTimes(true);  // (the GPU's times of every deformation and frame so far: waits for the last ones)
  const Timings& t = sim.timings();
  json tj;
  tj["physics_ms"] = t.physicsMs;
  tj["physics_ms_per_step"] = t.steps ? t.physicsMs / static_cast<double>(t.steps) : 0.0;
  tj["dent_read_ms"] = t.dentReadMs;
  tj["dent_wait_ms"] = t.dentWaitMs;
  tj["dent_reads"] = t.dentReads;
  tj["dent_texels"] = t.dentTexels;
  tj["dent_full_reads"] = t.dentFullReads;
  tj["deform_ms"] = t.deformMs;
  tj["deform_ms_per_deformation"] = t.deformations ? t.deformMs / static_cast<double>(t.deformations) : 0.0;
  tj["render_ms"] = t.renderMs;
  tj["render_ms_per_frame"] = t.frames ? t.renderMs / static_cast<double>(t.frames) : 0.0;
  tj["deform_gpu_ms"] = t.deformGpuMs;
  tj["deform_gpu_ms_per_deformation"] = t.deformations ? t.deformGpuMs / static_cast<double>(t.deformations) : 0.0;
  tj["render_gpu_ms"] = t.renderGpuMs;
  tj["render_gpu_ms_per_frame"] = t.frames ? t.renderGpuMs / static_cast<double>(t.frames) : 0.0;
  tj["frames"] = t.frames;
  // The process's peak resident memory so far (Linux), for soak checks: it must not grow with the steps.
  {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
      if (line.rfind("VmHWM:", 0) == 0) tj["peak_rss_mb"] = std::stod(line.substr(6)) / 1024.0;
  }
  s["timings"] = tj;
  for (const auto& [k, v] : extra) s[k] = v;
  return finiteNumbers(s, "summary.json").dump(2);
}

void OutputWriter::write(Simulation& sim, const std::map<std::string, std::string>& extra) {
  begin();
  const fs::path root(staging_);
  fs::create_directories(root / "heightmaps");
  fs::create_directories(root / "normalmaps");
  {
    std::ofstream ev(root / "events.jsonl");
    for (const std::string& line : eventLines(sim)) ev << line << "\n";
    if (!ev) throw std::runtime_error("writing events.jsonl failed");
  }
  // Maps. Bodies that were never dented share their maps (lazy maps): encode each once, copy the files.
  std::map<GLuint, std::string> written;
  for (const auto& b : sim.bodies()) {
    if (!b.surface) continue;
    const fs::path heightPath = root / "heightmaps" / (b.name + ".png"),
                   normalPath = root / "normalmaps" / (b.name + ".png");
    if (auto it = written.find(b.surface->height().id()); it != written.end()) {
      fs::copy_file(root / "heightmaps" / it->second, heightPath);
      fs::copy_file(root / "normalmaps" / it->second, normalPath);
      continue;
    }
    written[b.surface->height().id()] = b.name + ".png";
    const gl::Image h = b.surface->downloadHeight();
    gl::writePng(heightPath.string(), h, 16);
    const int n = b.surface->resolution();
    std::vector<unsigned char> rgba(static_cast<size_t>(n) * n * 4);
    b.surface->normal().download(GL_RGBA, GL_UNSIGNED_BYTE, rgba.data(), rgba.size());
    gl::Image nm(n, n, 3);
    for (size_t i = 0; i < static_cast<size_t>(n) * n; ++i)
      for (int c = 0; c < 3; ++c)
        nm.pixels[i * 3 + static_cast<size_t>(c)] = rgba[i * 4 + static_cast<size_t>(c)] / 255.0f;
    gl::writePng(normalPath.string(), nm, 8);
  }
  if (exportGltf_) writeGltfExport(sim, (root / "export").string(), root.string(), animation_);
  std::ofstream f(root / "summary.json");
  f << summaryJson(sim, extra) << "\n";
  if (!f) throw std::runtime_error("writing summary.json failed");
}

void OutputWriter::commit() {
  if (!begun_ || staging_.empty()) throw std::logic_error("OutputWriter::commit before write");
  std::error_code ec;
  if (fs::exists(dir_, ec) && !fs::is_empty(dir_, ec)) checkReplaceable(dir_);  // again: a file may have come since
  // The marker: every file this run wrote, so that the next run replaces only what crumple wrote.
  {
    nlohmann::json files = nlohmann::json::array();
    const fs::path root(staging_);
    for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator(); ++it)
      if (!it->is_directory() && it->path() != root / kMarker)
        files.push_back(fs::relative(it->path(), root).generic_string());
    std::sort(files.begin(), files.end());
    // Without its owner now: the folder is an output, not a staging folder.
    writeMarker(root, {{"format", "crumple-output/1"}, {"files", files}}, staging_);
  }
  if (fs::exists(dir_, ec)) {
    const std::string old = staging_ + ".old";
    fs::rename(dir_, old, ec);
    if (ec) throw std::runtime_error(dir_ + ": cannot replace the previous output: " + ec.message());
    fs::rename(staging_, dir_, ec);
    if (ec) {
      fs::rename(old, dir_);
      throw std::runtime_error(dir_ + ": cannot move the new output into place: " + ec.message());
    }
    fs::remove_all(old, ec);
  } else {
    fs::rename(staging_, dir_, ec);
    if (ec) throw std::runtime_error(dir_ + ": cannot move the output into place: " + ec.message());
  }
  committed_ = true;
}

}  // namespace crumple
