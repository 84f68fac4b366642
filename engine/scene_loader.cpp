// Scene-file loading: every check names the file, the key path and the reason.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include <crumple/engine/input_file.h>
#include <crumple/engine/overrides.h>
#include <crumple/engine/scene.h>
#include <crumple/core/log.h>
#include <crumple/engine/scene_node.h>

namespace crumple {

namespace fs = std::filesystem;
using json = nlohmann::json;

glm::dquat eulerDegreesToQuat(const glm::dvec3& d) {
  const glm::dvec3 r = glm::radians(d);
  const glm::dquat qx = glm::angleAxis(r.x, glm::dvec3(1, 0, 0));
  const glm::dquat qy = glm::angleAxis(r.y, glm::dvec3(0, 1, 0));
  const glm::dquat qz = glm::angleAxis(r.z, glm::dvec3(0, 0, 1));
  return glm::normalize(qz * qy * qx);
}

namespace {

using scene_file::Node;
using scene_file::shortDump;
using scene_file::typeName;

std::string lineColumn(const std::string& text, size_t byte) {
  size_t line = 1, col = 1;
  for (size_t i = 0; i < byte && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(col);
}

std::string resolvePath(const std::string& baseDir, const std::string& p) {
  fs::path path(p);
  if (path.is_relative()) path = fs::path(baseDir) / path;
  return path.lexically_normal().string();
}

Material parseMaterial(const Node& n, const std::string& name) {
  n.requireObject();
  n.checkKeys({"density", "restitution", "friction", "kappa", "thickness", "color", "metallic", "roughness", "texture",
               "texture_scale"});
  Material m;
  m.name = name;
  m.density = n.number("density", m.density, 0, 1e6, true);
  m.restitution = n.number("restitution", m.restitution, 0, 1);
  m.friction = n.number("friction", m.friction, 0, 100);
  m.kappa = n.number("kappa", m.kappa, 0, 1e6);
  m.thickness = n.number("thickness", m.thickness, 0, 1e3, true);
  if (n.has("color")) {
    const glm::dvec3 c = n.vec3("color", glm::dvec3(m.color));
    for (int i = 0; i < 3; ++i)
      if (c[i] < 0 || c[i] > 1) n.fail("color", "components must be in [0, 1]");
    m.color = glm::vec3(c);
  }
  m.hasColor = n.has("color");
  m.hasMetallic = n.has("metallic");
  m.hasRoughness = n.has("roughness");
  m.metallic = static_cast<float>(n.number("metallic", m.metallic, 0, 1));
  m.roughness = static_cast<float>(n.number("roughness", m.roughness, 0, 1));
  m.texture = n.string("texture", m.texture);
  if (m.texture != "none" && m.texture != "asphalt" && m.texture != "concrete" && m.texture != "clay")
    n.fail("texture", "unknown texture '" + quoteText(m.texture) + "' (expected asphalt, concrete, clay or none)");
  m.textureScale = static_cast<float>(n.number("texture_scale", m.textureScale, 0.01, 100));
  return m;
}

// The longest file name a scene gives (a mesh, an image), in bytes: Linux's PATH_MAX.
constexpr size_t kMaxPathBytes = 4096;

// A name that does not name files (a joint, a material, a collision group): at most kMaxNameBytes, not empty.
std::string nameProblem(const std::string& name) {
  if (name.empty()) return "must not be empty";
  if (name.size() > kMaxNameBytes) return "longer than " + std::to_string(kMaxNameBytes) + " characters";
  return "";
}

// Shapes thinner than this are rejected: their mass properties and atlases degenerate.
constexpr double kMinSize = 1e-4;  // m

ShapeDesc parseShape(const Node& n, const std::string& baseDir) {
  n.requireObject();
  ShapeDesc s;
  s.type = n.requiredString("type");
  if (s.type == "box") {
    n.checkKeys({"type", "size"});
    if (!n.has("size")) n.fail("size", "is required for a box");
    s.size = n.vec3("size", s.size);
    for (int i = 0; i < 3; ++i)
      if (!(s.size[i] > 0)) n.fail("size", "must be positive in every component");
    if (std::max({s.size.x, s.size.y, s.size.z}) > 1e4) n.fail("size", "larger than 10 km");
    if (std::min({s.size.x, s.size.y, s.size.z}) < kMinSize) n.fail("size", "smaller than 0.1 mm in some component");
  } else if (s.type == "sphere") {
    n.checkKeys({"type", "radius"});
    s.radius = n.requiredNumber("radius", kMinSize, 1e4);
  } else if (s.type == "capsule" || s.type == "cylinder") {
    n.checkKeys({"type", "radius", "height"});
    s.radius = n.requiredNumber("radius", kMinSize, 1e4);
    s.height = n.requiredNumber("height", s.type == "cylinder" ? kMinSize : 0.0, 1e4);
  } else if (s.type == "mesh") {
    n.checkKeys({"type", "file", "scale"});
    const std::string f = n.requiredString("file");
    if (f.empty()) n.fail("file", "must not be empty");
    if (f.size() > kMaxPathBytes) n.fail("file", "longer than " + std::to_string(kMaxPathBytes) + " characters");
    s.file = resolvePath(baseDir, f);
    if (const std::string why = inputFileProblem(s.file, kMaxMeshFileBytes, "mesh file"); !why.empty())
      n.fail("file", s.file + ": " + why);
    if (n.has("scale")) {
      const json& v = n.raw("scale");
      if (v.is_number()) {
        const double k = n.number("scale", 1, 1e-4, 1e4);
        s.scale = glm::dvec3(k);
      } else {
        s.scale = n.vec3("scale", s.scale);
        for (int i = 0; i < 3; ++i)
          if (!(s.scale[i] >= 1e-4 && s.scale[i] <= 1e4))
            n.fail("scale", "must be in [0.0001, 10000] in every component");
      }
    }
  } else {
    n.fail("type", "unknown shape type '" + quoteText(s.type) + "' (expected box, sphere, capsule, cylinder or mesh)");
  }
  return s;
}

VehicleDesc parseVehicle(const Node& n) {
  n.requireObject();
  n.checkKeys({"wheels", "wheel_radius", "wheel_width", "suspension_rest", "suspension_stiffness", "suspension_damping",
               "engine_force", "brake_force", "max_steer", "tyre_grip", "script", "treads"});
  VehicleDesc v;
  v.present = true;
  if (!n.has("wheels")) n.fail("wheels", "is required (wheel attachment points in the body frame)");
  const json& w = n.raw("wheels");
  if (!w.is_array() || w.size() < 3 || w.size() > 16) n.fail("wheels", "must be an array of 3 to 16 points");
  for (size_t i = 0; i < w.size(); ++i)
    v.params.wheels.push_back(n.vec3Value(w[i], "wheels[" + std::to_string(i) + "]", 1e3));
  v.params.wheelRadius = n.number("wheel_radius", v.params.wheelRadius, 0, 10, true);
  v.wheelWidth = n.number("wheel_width", v.wheelWidth, 0, 10, true);
  v.params.suspensionRest = n.number("suspension_rest", v.params.suspensionRest, 0, 10, true);
  v.params.stiffness = n.number("suspension_stiffness", v.params.stiffness, 0, 1e9, true);
  v.params.damping = n.number("suspension_damping", v.params.damping, 0, 1e9);
  v.params.engineForce = n.number("engine_force", v.params.engineForce, 0, 1e9);
  v.params.brakeForce = n.number("brake_force", v.params.brakeForce, 0, 1e9);
  v.params.maxSteer = glm::radians(n.number("max_steer", glm::degrees(v.params.maxSteer), 0, 89));
  v.params.grip = n.number("tyre_grip", v.params.grip, 0, 100);
  if (n.has("treads")) {
    Node t(n.raw("treads"), n.join("treads"), n.file());
    t.requireObject();
    t.checkKeys({"pitch", "grouser_height"});
    v.treads = true;
    v.treadPitch = t.number("pitch", v.treadPitch, 0.02, 10, true);
    v.grouserHeight = t.number("grouser_height", v.grouserHeight, 0.001, 1, true);
    bool left = false, right = false;
    for (const glm::dvec3& p : v.params.wheels) (p.z < 0 ? right : left) = true;
    if (!left || !right) n.fail("treads", "need wheels on both sides of the body (z < 0 and z > 0)");
  }
  if (n.has("script")) {
    const json& s = n.raw("script");
    if (!s.is_array()) n.fail("script", "must be an array of timed inputs");
    double last = -1;
    for (size_t i = 0; i < s.size(); ++i) {
      Node e(s[i], n.join("script[" + std::to_string(i) + "]"), n.file());
      e.requireObject();
      e.checkKeys({"t", "throttle", "steer", "brake", "handbrake"});
      VehicleInput in;
      in.time = e.requiredNumber("t", 0, 1e6);
      if (in.time < last) e.fail("t", "script times must not decrease");
      last = in.time;
      in.throttle = e.number("throttle", 0, -1, 1);
      in.steer = e.number("steer", 0, -1, 1);
      in.brake = e.number("brake", 0, 0, 1);
      in.handbrake = e.boolean("handbrake", false);
      v.script.push_back(in);
    }
  }
  return v;
}

// Euler degrees [x, y, z] or {"quat": [w, x, y, z]} at n's key.
glm::dquat parseOrientation(const Node& n, const std::string& key) {
    const json& o = n.raw(key);
    if (o.is_array()) {
      return eulerDegreesToQuat(n.vec3(key, glm::dvec3(0), 1e5));
    } else if (o.is_object()) {
      Node on = n.child(key);
      on.checkKeys({"quat"});
      if (!on.has("quat")) on.fail("quat", "is required ([w, x, y, z])");
      const json& q = on.raw("quat");
      if (!q.is_array() || q.size() != 4) on.fail("quat", "must be [w, x, y, z]");
      double c[4];
      for (int i = 0; i < 4; ++i)
        c[i] = on.numberValue(q[static_cast<size_t>(i)], "quat[" + std::to_string(i) + "]", -1e6, 1e6, false, false);
      const glm::dquat r(c[0], c[1], c[2], c[3]);  // glm's constructor takes w first
      const double len = std::sqrt(r.w * r.w + r.x * r.x + r.y * r.y + r.z * r.z);
      if (!(len > 1e-9)) on.fail("quat", "must not be zero");
      return glm::normalize(r);
    } else {
      n.fail(key, "must be Euler degrees [x, y, z] or {\"quat\": [w, x, y, z]}");
    }
}

BodyDesc parseBody(const Node& n, const Scene& scene, const std::string& baseDir) {
  n.requireObject();
  n.checkKeys({"name", "shape", "material", "static", "position", "orientation", "velocity", "angular_velocity", "mass",
               "bump_map", "vehicle", "contact_deformation", "feel_dents", "kinematic", "path", "group"});
  BodyDesc b;
  b.name = n.requiredString("name");
  if (const std::string why = fileNameProblem(b.name); !why.empty()) n.fail("name", why);
  if (!n.has("shape")) n.fail("shape", "is required");
  b.shape = parseShape(n.child("shape"), baseDir);
  b.material = n.requiredString("material");
  if (!scene.materials.count(b.material)) {
    std::string known;
    for (const auto& [k, v] : scene.materials) known += (known.empty() ? "" : ", ") + quoteText(k, 40);
    n.fail("material",
           "unknown material '" + quoteText(b.material) + "' (defined: " + (known.empty() ? "none" : known) + ")");
  }
  b.isStatic = n.boolean("static", false);
  b.position = n.vec3("position", b.position);
  if (n.has("orientation")) b.orientation = parseOrientation(n, "orientation");
  b.velocity = n.vec3("velocity", b.velocity, 1e4);
  b.angularVelocity = n.vec3("angular_velocity", b.angularVelocity, 1e4);
  if (n.has("mass")) b.mass = n.number("mass", 1, 0, 1e9, true);
  if (n.has("bump_map")) {
    Node bm = n.child("bump_map");
    bm.checkKeys({"resolution", "image", "bump_depth", "bump_depth_collide"});
    b.bumpMap.present = true;
    b.bumpMap.resolution = bm.integer("resolution", b.bumpMap.resolution, 8, 4096);
    if (bm.has("image")) {
      const std::string img = bm.string("image", "");
      if (img.empty()) bm.fail("image", "must not be empty");
      if (img.size() > kMaxPathBytes) bm.fail("image", "longer than " + std::to_string(kMaxPathBytes) + " characters");
      b.bumpMap.image = resolvePath(baseDir, img);
      if (const std::string why = inputFileProblem(b.bumpMap.image, kMaxImageFileBytes, "image file"); !why.empty())
        bm.fail("image", b.bumpMap.image + ": " + why);
    }
    if (bm.has("bump_depth")) b.bumpMap.bumpDepth = bm.number("bump_depth", 0.1, 0, 10, true);
    if (bm.has("bump_depth_collide")) b.bumpMap.bumpDepthCollide = bm.number("bump_depth_collide", 0.02, 0, 10);
  }
  b.contactDeformation = n.boolean("contact_deformation", false);
  if (n.has("feel_dents")) b.feelDents = n.boolean("feel_dents", true);
  if (n.has("vehicle")) {
    b.vehicle = parseVehicle(n.child("vehicle"));
    if (b.isStatic) n.fail("vehicle", "a static body cannot be a vehicle");
  }
  b.kinematic = n.boolean("kinematic", false);
  if (b.kinematic && b.isStatic) n.fail("kinematic", "a body cannot be both static and kinematic");
  if (b.kinematic && b.vehicle.present) n.fail("kinematic", "a vehicle cannot be kinematic");
  if (n.has("path")) {
    if (!b.kinematic) n.fail("path", "only a kinematic body follows a path (add \"kinematic\": true)");
    const json& p = n.raw("path");
    if (!p.is_array() || p.empty()) n.fail("path", "must be a non-empty array of keyframes");
    if (p.size() > 1000000) n.fail("path", "more than 10^6 keyframes");
    double last = -1;
    for (size_t i = 0; i < p.size(); ++i) {
      Node k(p[i], n.join("path[" + std::to_string(i) + "]"), n.file());
      k.requireObject();
      k.checkKeys({"t", "position", "orientation"});
      PathKey key;
      key.time = k.requiredNumber("t", 0, 1e6);
      if (key.time <= last) k.fail("t", "keyframe times must increase");
      last = key.time;
      if (!k.has("position")) k.fail("position", "is required");
      key.position = k.vec3("position", key.position);
      key.orientation = k.has("orientation") ? parseOrientation(k, "orientation") : b.orientation;
      b.path.push_back(key);
    }
  }
  b.group = n.string("group", b.group);
  if (const std::string why = nameProblem(b.group); !why.empty()) n.fail("group", why);
  return b;
}

JointDesc parseJoint(const Node& n, size_t index, const std::set<std::string>& bodies) {
  n.requireObject();
  n.checkKeys({"name", "type", "a", "b", "anchor", "anchor_a", "anchor_b", "axis", "limits", "motor", "break_impulse",
               "collide_connected", "length", "min", "max"});
  JointDesc j;
  j.name = n.string("name", "joint" + std::to_string(index));
  if (const std::string why = nameProblem(j.name); !why.empty()) n.fail("name", why);
  const std::string type = n.requiredString("type");
  if (type == "ball")
    j.def.type = JointType::Ball;
  else if (type == "hinge")
    j.def.type = JointType::Hinge;
  else if (type == "slider")
    j.def.type = JointType::Slider;
  else if (type == "fixed")
    j.def.type = JointType::Fixed;
  else if (type == "distance")
    j.def.type = JointType::Distance;
  else
    n.fail("type", "unknown joint type '" + quoteText(type) + "' (expected ball, hinge, slider, fixed or distance)");
  auto bodyName = [&](const char* key, bool optional) {
    if (!n.has(key) || (optional && n.raw(key).is_null())) {
      if (!optional) n.fail(key, "is required (a body name)");
      return std::string();
    }
    const std::string name = n.string(key, "");
    if (!bodies.count(name)) n.fail(key, "no body is named '" + quoteText(name) + "'");
    return name;
  };
  j.a = bodyName("a", true);
  j.b = bodyName("b", false);
  if (j.a == j.b) n.fail("b", "a joint needs two different bodies");
  const bool axial = j.def.type == JointType::Hinge || j.def.type == JointType::Slider;
  if (j.def.type == JointType::Distance) {
    if (n.has("anchor")) n.fail("anchor", "a distance joint takes anchor_a and anchor_b");
    if (!n.has("anchor_a")) n.fail("anchor_a", "is required for a distance joint");
    if (!n.has("anchor_b")) n.fail("anchor_b", "is required for a distance joint");
    j.def.anchorA = n.vec3("anchor_a", j.def.anchorA);
    j.def.anchorB = n.vec3("anchor_b", j.def.anchorB);
    if (n.has("length") && (n.has("min") || n.has("max"))) n.fail("length", "give either length or min and max");
    if (n.has("length")) j.def.length = n.number("length", 0, 0, 1e6);
    if (n.has("min") || n.has("max")) {
      if (!n.has("max")) n.fail("max", "is required with min");
      j.def.minLength = n.number("min", 0, 0, 1e6);
      j.def.maxLength = n.number("max", 0, 0, 1e6);
      if (j.def.minLength > j.def.maxLength) n.fail("min", "is above max");
    }
  } else {
    for (const char* k : {"anchor_a", "anchor_b", "length", "min", "max"})
      if (n.has(k)) n.fail(k, "only for distance joints");
    if (!n.has("anchor")) n.fail("anchor", "is required (a world point at the start)");
    j.def.anchor = n.vec3("anchor", j.def.anchor);
  }
  if (axial) {
    if (!n.has("axis")) n.fail("axis", "is required for a " + type + " joint");
    j.def.axis = n.vec3("axis", j.def.axis);
    if (!(glm::length(j.def.axis) > 1e-9)) n.fail("axis", "must not be zero");
  } else if (n.has("axis")) {
    n.fail("axis", "only for hinge and slider joints");
  }
  const bool hinge = j.def.type == JointType::Hinge;
  if (n.has("limits")) {
    if (!axial) n.fail("limits", "only for hinge and slider joints");
    const json& l = n.raw("limits");
    if (!l.is_array() || l.size() != 2) n.fail("limits", "must be [lo, hi]");
    const double bound = hinge ? 360 : 1e6;
    const double lo = n.numberValue(l[0], "limits[0]", -bound, bound, false, false);
    const double hi = n.numberValue(l[1], "limits[1]", -bound, bound, false, false);
    if (lo > hi) n.fail("limits", "lo is above hi");
    j.def.limited = true;
    j.def.lower = hinge ? glm::radians(lo) : lo;
    j.def.upper = hinge ? glm::radians(hi) : hi;
  }
  if (n.has("motor")) {
    if (!axial) n.fail("motor", "only for hinge and slider joints");
    Node m = n.child("motor");
    const char* effort = hinge ? "max_torque" : "max_force";
    m.checkKeys({"speed", effort});
    j.def.motor.enabled = true;
    const double speed = m.requiredNumber("speed", -1e6, 1e6);
    j.def.motor.speed = hinge ? glm::radians(speed) : speed;
    j.def.motor.maxForce = m.requiredNumber(effort, 0, 1e12);
  }
  if (n.has("break_impulse")) j.def.breakImpulse = n.number("break_impulse", 0, 0, 1e15);
  j.def.collideConnected = n.boolean("collide_connected", false);
  return j;
}

// The text as JSON (a malformed file: where and why).
json parseJson(const std::string& text, const std::string& file) {
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    std::string what = e.what();
    const auto pos = what.find("syntax error");
    throw SceneError(file, "",
                     "malformed JSON at " + lineColumn(text, e.byte ? e.byte - 1 : 0) + ": " +
                         (pos != std::string::npos ? what.substr(pos) : what));
  } catch (const json::exception& e) {
    std::string what = e.what();
    const auto pos = what.find("] ");
    throw SceneError(file, "", "malformed JSON: " + (pos != std::string::npos ? what.substr(pos + 2) : what));
  }
}

// The top level's own values: format, name, gravity, timestep, duration, threads.
void parseTop(const Node& n, Scene& s) {
  if (n.has("format")) {
    const std::string f = n.string("format", "");
    if (f != "crumple-scene/1")
      n.fail("format", "unsupported format '" + quoteText(f) + "' (expected crumple-scene/1)");
  }
  s.name = n.string("name", fs::path(s.file).stem().string());
  // It names the default output folder, out/<name>: a name such as "../x" would write outside out/.
  if (const std::string why = fileNameProblem(s.name); !why.empty())
    n.fail("name", n.has("name")
                       ? why
                       : "the file name's '" + quoteText(s.name) + "', the scene's name without a \"name\", " + why +
                             " (give the scene a \"name\")");
  s.gravity = n.vec3("gravity", s.gravity, 1e3);
  s.timestep = n.number("timestep", s.timestep, 1e-5, 0.1, false);
  if (n.has("timestep") && !(n.raw("timestep").get<double>() > 0)) n.fail("timestep", "must be positive");
  s.duration = n.number("duration", s.duration, 0, 1e5, true);
  if (s.duration / s.timestep > 1e8) n.fail("duration", "more than 10^8 steps");
  s.threads = n.integer("threads", s.threads, 0, 256);
}

// "materials": each by its name.
void parseMaterials(const Node& n, Scene& s) {
  if (!n.has("materials")) return;
  Node mats = n.child("materials");
  for (auto it = mats.value().begin(); it != mats.value().end(); ++it) {
    if (it.key().empty()) mats.fail("", "a material name must not be empty");
    if (const std::string why = nameProblem(it.key()); !why.empty())
      mats.fail("", "the material name '" + quoteText(it.key()) + "' is " + why);
    s.materials[it.key()] = parseMaterial(Node(it.value(), mats.join(it.key()), s.file), it.key());
  }
}

// "deformation": when collisions dent and how.
void parseDeformation(const Node& n, DeformationSettings& ds) {
  if (!n.has("deformation")) return;
  Node d = n.child("deformation");
  d.checkKeys({"enabled", "impulse_floor", "bump_depth", "bump_depth_collide", "address_map", "path",
               "address_raster", "tangent_correction", "tangent_floor", "crater_rims", "lazy_maps", "contact_interval",
               "normal_mapped_normals", "feel_dents"});
  ds.enabled = d.boolean("enabled", ds.enabled);
  ds.impulseFloor = d.number("impulse_floor", ds.impulseFloor, 0, 1e12);
  ds.bumpDepth = d.number("bump_depth", ds.bumpDepth, 0, 10, true);
  ds.bumpDepthCollide = d.number("bump_depth_collide", ds.bumpDepthCollide, 0, 10);
  auto& o = ds.options;
  o.addressMap = d.integer("address_map", o.addressMap, 16, 4096);
  const std::string path = d.string("path", "gather");
  if (path == "gather" || path == "gpu")
    o.path = deform::Path::Gather;  // "gpu": its name before the scatter had a GPU twin
  else if (path == "scatter")
    o.path = deform::Path::Scatter;
  else if (path == "readback")
    o.path = deform::Path::Readback;
  else
    d.fail("path", "must be \"gather\", \"scatter\" or \"readback\", got '" + quoteText(path) + "'");
  o.addressRaster = d.choice<deform::AddressRaster>("address_raster", {{"auto", deform::AddressRaster::Auto},
                                                                       {"compute", deform::AddressRaster::Compute},
                                                                       {"fragment", deform::AddressRaster::Fragment}});
  o.tangent = d.choice<deform::TangentMode>("tangent_correction", {{"none", deform::TangentMode::None},
                                                                   {"multiply", deform::TangentMode::Multiply},
                                                                   {"divide", deform::TangentMode::Divide}});
  o.tangentFloor = static_cast<float>(d.number("tangent_floor", o.tangentFloor, 0, 1, true));
  o.craterRims = d.boolean("crater_rims", o.craterRims);
  ds.lazyMaps = d.boolean("lazy_maps", ds.lazyMaps);
  ds.contactInterval = d.number("contact_interval", ds.contactInterval, 0, 10);
  ds.normalMappedNormals = d.boolean("normal_mapped_normals", ds.normalMappedNormals);
  ds.feelDents = d.boolean("feel_dents", ds.feelDents);
}

// "bodies" (required, names unique, at most 64 collision groups); returns their names.
std::set<std::string> parseBodies(const Node& n, Scene& s, const std::string& baseDir) {
  if (!n.has("bodies")) n.fail("bodies", "is required");
  const json& bodies = n.raw("bodies");
  if (!bodies.is_array()) n.fail("bodies", std::string("must be an array, got ") + typeName(bodies));
  if (bodies.size() > 100000) n.fail("bodies", "more than 100000 bodies");
  std::set<std::string> names;
  for (size_t i = 0; i < bodies.size(); ++i) {
    const std::string path = "bodies[" + std::to_string(i) + "]";
    BodyDesc b = parseBody(Node(bodies[i], path, s.file), s, baseDir);
    if (!names.insert(b.name).second)
      throw SceneError(s.file, path + ".name", "duplicate body name '" + quoteText(b.name) + "'");
    s.bodies.push_back(std::move(b));
  }
  std::set<std::string> groups;
  for (const BodyDesc& b : s.bodies) groups.insert(b.group);
  if (groups.size() > 64) {
    for (size_t i = 0; i < s.bodies.size(); ++i)
      if (std::distance(groups.begin(), groups.find(s.bodies[i].group)) >= 64)
        throw SceneError(s.file, "bodies[" + std::to_string(i) + "].group", "more than 64 collision groups");
  }
  return names;
}

// "joints" between the named bodies (names unique).
void parseJoints(const Node& n, Scene& s, const std::set<std::string>& names) {
  if (!n.has("joints")) return;
  const json& js = n.raw("joints");
  if (!js.is_array()) n.fail("joints", std::string("must be an array, got ") + typeName(js));
  if (js.size() > 100000) n.fail("joints", "more than 100000 joints");
  std::set<std::string> jointNames;
  for (size_t i = 0; i < js.size(); ++i) {
    const std::string path = "joints[" + std::to_string(i) + "]";
    JointDesc j = parseJoint(Node(js[i], path, s.file), i, names);
    if (!jointNames.insert(j.name).second)
      throw SceneError(s.file, path + ".name", "duplicate joint name '" + quoteText(j.name) + "'");
    s.joints.push_back(std::move(j));
  }
}

// "no_collide": pairs of the bodies' collision groups.
void parseNoCollide(const Node& n, Scene& s) {
  if (!n.has("no_collide")) return;
  std::set<std::string> groups;
  for (const BodyDesc& b : s.bodies) groups.insert(b.group);
  const json& nc = n.raw("no_collide");
  if (!nc.is_array()) n.fail("no_collide", "must be an array of [group, group] pairs");
  for (size_t i = 0; i < nc.size(); ++i) {
    const std::string path = "no_collide[" + std::to_string(i) + "]";
    if (!nc[i].is_array() || nc[i].size() != 2 || !nc[i][0].is_string() || !nc[i][1].is_string())
      throw SceneError(s.file, path, "must be a pair of group names [\"a\", \"b\"]");
    for (size_t k = 0; k < 2; ++k)
      if (!groups.count(nc[i][k].get<std::string>()))
        throw SceneError(s.file, path + "[" + std::to_string(k) + "]",
                         "no body is in group '" + quoteText(nc[i][k].get<std::string>()) + "'");
    s.noCollide.push_back({nc[i][0].get<std::string>(), nc[i][1].get<std::string>()});
  }
}

// "cameras" (names unique; "follow" a named body).
void parseCameras(const Node& n, Scene& s, const std::set<std::string>& names) {
  if (!n.has("cameras")) return;
  const json& cams = n.raw("cameras");
  if (!cams.is_array()) n.fail("cameras", "must be an array");
  std::set<std::string> camNames;
  for (size_t i = 0; i < cams.size(); ++i) {
    Node c(cams[i], "cameras[" + std::to_string(i) + "]", s.file);
    c.requireObject();
    c.checkKeys({"name", "position", "target", "up", "fov", "follow", "follow_heading", "displace"});
    CameraDesc cd;
    cd.name = c.string("name", "camera" + std::to_string(i));
    if (const std::string why = fileNameProblem(cd.name); !why.empty()) c.fail("name", why);
    if (!camNames.insert(cd.name).second) c.fail("name", "duplicate camera name '" + quoteText(cd.name) + "'");
    cd.position = c.vec3("position", cd.position);
    cd.target = c.vec3("target", cd.target);
    cd.up = c.vec3("up", cd.up);
    cd.fov = c.number("fov", cd.fov, 0, 180, true, true);
    cd.follow = c.string("follow", "");
    if (c.has("follow") && !names.count(cd.follow)) c.fail("follow", "no body is named '" + quoteText(cd.follow) + "'");
    cd.followHeading = c.boolean("follow_heading", false);
    if (c.has("follow_heading") && cd.follow.empty()) c.fail("follow_heading", "needs \"follow\"");
    cd.displace = c.boolean("displace", false);
    if (glm::length(cd.target - cd.position) < 1e-9) c.fail("target", "must differ from position");
    if (upAlongView(cd.position, cd.target, cd.up)) c.fail("up", "must not be parallel to the view direction");
    s.cameras.push_back(cd);
  }
}
}  // namespace

Scene parseScene(const std::string& text, const std::string& file, const std::string& baseDir) {
  const json root = parseJson(text, file);
  Node n(root, "", file);
  if (!root.is_object())
    throw SceneError(file, "", std::string("the top level must be an object, got ") + typeName(root));
  n.checkKeys({"format", "name", "gravity", "timestep", "duration", "threads", "materials", "deformation", "bodies",
               "joints", "no_collide", "cameras"});
  Scene s;
  s.file = file;
  parseTop(n, s);
  parseMaterials(n, s);
  parseDeformation(n, s.deformation);
  const std::set<std::string> names = parseBodies(n, s, baseDir);
  parseJoints(n, s, names);
  parseNoCollide(n, s);
  parseCameras(n, s, names);
  return s;
}

Scene loadScene(const std::string& path) { return loadScene(path, {}); }

Scene loadScene(const std::string& path, const std::vector<std::pair<std::string, std::string>>& overrides) {
  std::string text;
  try {
    text = readInputFile(path, kMaxSceneFileBytes, "scene file");
  } catch (const InputFileError& e) {
    throw SceneError(path, "", e.what());
  }
  std::error_code ec;
  const std::string base = fs::absolute(path, ec).parent_path().string();
  return parseScene(text, path, base, overrides);
}

}  // namespace crumple
