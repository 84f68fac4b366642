// A scene as read from a scene file (docs/scene-format.md), validated.
// Units: SI; angles in the file are degrees, here radians/quaternions.
#pragma once
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <crumple/deform/options.h>
#include <crumple/physics/joint.h>
#include <crumple/physics/vehicle.h>

namespace crumple {

// `text` kept to at most `limit` bytes: its start and end, with what was left out counted between. The cuts fall
// between UTF-8 sequences, never inside one.
inline std::string capText(const std::string& text, size_t limit) {
  if (text.size() <= limit) return text;
  auto continuation = [&](size_t i) { return i < text.size() && (static_cast<unsigned char>(text[i]) & 0xC0) == 0x80; };
  size_t head = limit / 2, tail = text.size() - limit / 2;
  while (head > 0 && continuation(head)) --head;
  while (tail < text.size() && continuation(tail)) ++tail;
  return text.substr(0, head) + "...(" + std::to_string(tail - head) + " characters)..." + text.substr(tail);
}

// Whether `text` is well-formed UTF-8 (no overlong forms, surrogates, or code points beyond U+10FFFF).
bool isValidUtf8(const std::string& text);
// `text` with every byte that is not part of well-formed UTF-8 written as \xNN: safe to print and to hand to
// Python, the rest unchanged.
std::string escapeInvalidUtf8(const std::string& text);
// `text` as a message quotes it: control characters and bytes that are not UTF-8 escaped (\n, \xNN), and at most
// `limit` characters (its start and end, what was left out counted between).
std::string quoteText(const std::string& text, size_t limit = 60);

// The longest name crumple takes (a scene, a body, a camera, a joint, a material, a collision group), in bytes.
constexpr size_t kMaxNameBytes = 128;
// Why `name` cannot name an output file or folder (the scene's out/<name>, a body's heightmaps/<name>.png, a
// camera's frames/<name>_<frame>.png): empty, longer than kMaxNameBytes, not UTF-8, '/', '\\' or a control
// character in it, or '.' or '..'. "" when it can.
std::string fileNameProblem(const std::string& name);

// Bad input: names the file, the key path and what is wrong. Apps exit with 2. Each part is capped
// (a 100000-character path or an echoed value must not make a 100 KB message) and bytes that are not UTF-8 are
// escaped in the message.
struct SceneError : std::runtime_error {
  SceneError(const std::string& file, const std::string& keyPath, const std::string& what)
      : std::runtime_error(capText(escapeInvalidUtf8(file), 300) + ": " +
                           (keyPath.empty() ? "" : capText(escapeInvalidUtf8(keyPath), 300) + ": ") +
                           capText(escapeInvalidUtf8(what), 600)),
        file(file),
        keyPath(keyPath),
        reason(what) {}
  std::string file, keyPath, reason;
};

struct Material {
  std::string name;
  double density = 1000;
  double restitution = 0.5;  // the paper's epsilon
  double friction = 0.5;
  double kappa = 0.1;       // the paper's kappa (m/s per unit impulse above Y)
  double thickness = 0.05;  // the paper's t (m)
  glm::vec3 color{0.7f, 0.7f, 0.7f};  // sRGB base colour
  float metallic = 0.0f;               // glTF metallic-roughness: 0 dielectric, 1 metal
  float roughness = 0.6f;              // perceptual roughness, 0 mirror .. 1 matte
  // Which of the three the scene gave: those replace a glTF mesh's own (docs/scene-format.md).
  bool hasColor = false, hasMetallic = false, hasRoughness = false;
  // A procedural surface drawn over the colour and roughness (render::SurfaceTexture): none, asphalt,
  // concrete or clay, its features textureScale times their natural size.
  std::string texture = "none";
  float textureScale = 1.0f;
};

struct DeformationSettings {
  bool enabled = true;
  double impulseFloor = 0.0;
  double bumpDepth = 0.1;          // k (m)
  double bumpDepthCollide = 0.02;  // k' (m)
  deform::DeformOptions options;   // address map, update path, tangent correction, crater rims
  bool lazyMaps = true;
  double contactInterval = 0.05;
  bool normalMappedNormals = false;  // contact normals from the normal maps (figure 10)
  bool feelDents = true;  // contacts on the dented surfaces (false: dents are visual only, as in the paper)
};

struct ShapeDesc {
  std::string type;  // box, sphere, capsule, cylinder, mesh
  glm::dvec3 size{1};
  double radius = 0.5;
  double height = 1.0;
  std::string file;  // mesh: absolute or resolved path
  glm::dvec3 scale{1};
};

struct BumpMapDesc {
  bool present = false;
  int resolution = 256;
  std::string image;  // resolved path, empty when none
  std::optional<double> bumpDepth, bumpDepthCollide;
};

struct VehicleInput {
  double time = 0;
  double throttle = 0, steer = 0, brake = 0;  // throttle, brake in [0,1]; steer in [-1,1]
  bool handbrake = false;
};

struct VehicleDesc {
  bool present = false;
  VehicleParams params;      // wheels (attachment points, body frame), suspension, engine, brakes, grip
  double wheelWidth = 0.25;  // for drawing and for wheel prints in contact-deformable ground
  std::vector<VehicleInput> script;
  // Tracks instead of tyres (a tank): on each side of the body (z < 0, z > 0) a
  // belt around that side's wheels, carrying grousers (cross bars) every `pitch`
  // metres, `grouserHeight` deep. The belt is what contact-deformable ground feels:
  // it prints the grouser pattern (figure 8 of the paper) instead of wheel prints.
  bool treads = false;
  double treadPitch = 0.3;
  double grouserHeight = 0.05;
};

// A kinematic body's keyframe: the shape frame's pose at time t (linear in
// position, slerped in orientation; held after the last key).
struct PathKey {
  double time = 0;
  glm::dvec3 position{0};
  glm::dquat orientation{1, 0, 0, 0};
};

struct BodyDesc {
  std::string name;
  ShapeDesc shape;
  std::string material;
  bool isStatic = false;
  glm::dvec3 position{0};
  glm::dquat orientation{1, 0, 0, 0};
  glm::dvec3 velocity{0};
  glm::dvec3 angularVelocity{0};
  std::optional<double> mass;
  BumpMapDesc bumpMap;
  bool contactDeformation = false;
  std::optional<bool> feelDents;  // this body's dents felt by contacts (unset: the deformation's default)
  VehicleDesc vehicle;
  bool kinematic = false;      // moved by its velocities or its path, never pushed
  std::vector<PathKey> path;   // kinematic: keyframes (empty: its velocities)
  std::string group = "default";
};

// A joint (physics/joint.h) between two bodies named in the scene; `a` empty is
// the static world. `def` is the joint as the World takes it (angles in
// radians; its body indices a and b are filled in from the names when the
// simulation is built).
struct JointDesc {
  std::string name;
  std::string a, b;
  JointDef def;
};

struct CameraDesc {
  std::string name;
  glm::dvec3 position{4, 3, 4};
  glm::dvec3 target{0};
  glm::dvec3 up{0, 1, 0};
  double fov = 45;  // degrees, vertical
  // A camera that follows a body: position and target are then offsets from
  // its centre of mass, in world axes, or (heading) in axes turned with the
  // body's heading about up (x: the body's x projected on the ground).
  std::string follow;
  bool followHeading = false;
  bool displace = false;  // silhouettes that show dents: drawn with displacement (render::View::displace)
};

// Whether `up` is zero or along the view from position to target (no picture can be made from it); position and
// target must differ.
inline bool upAlongView(const glm::dvec3& position, const glm::dvec3& target, const glm::dvec3& up) {
  return glm::length(glm::cross(glm::normalize(target - position), up)) < 1e-6;
}

struct Scene {
  std::string file;  // where it came from ("<built-in>" for defaults)
  std::string name;
  glm::dvec3 gravity{0, -9.81, 0};
  double timestep = 1.0 / 240;
  double duration = 2.0;
  int threads = 1;  // the physics step's threads (WorldSettings::threads; 0: the hardware's)
  std::map<std::string, Material> materials;
  DeformationSettings deformation;
  std::vector<BodyDesc> bodies;
  std::vector<JointDesc> joints;
  std::vector<std::pair<std::string, std::string>> noCollide;  // pairs of groups that pass through each other
  std::vector<CameraDesc> cameras;
};

// Parses and validates. Throws SceneError for every problem, naming the key path.
Scene loadScene(const std::string& path);
// The same with overrides (KEY path, VALUE as JSON text) applied to the document before it is checked
// (engine/overrides.h): a path that does not exist is a SceneError naming it.
Scene loadScene(const std::string& path, const std::vector<std::pair<std::string, std::string>>& overrides);
Scene parseScene(const std::string& jsonText, const std::string& fileName, const std::string& baseDir);

// Euler degrees [x, y, z]: rotate about x, then y, then z (extrinsic), q = qz qy qx.
glm::dquat eulerDegreesToQuat(const glm::dvec3& degrees);

}  // namespace crumple
