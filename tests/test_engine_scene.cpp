// The scene loader against a corpus of malformed scenes and broken meshes:
// every error names the file, the key path and the reason.
#include <doctest/doctest.h>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include <crumple/engine/assets.h>
#include <crumple/engine/atlas.h>
#include <crumple/engine/mesh_io.h>
#include <crumple/engine/scene.h>
#include <crumple/engine/scene_view.h>

using namespace crumple;
namespace fs = std::filesystem;

namespace {
const char* kGood = R"({
  "format": "crumple-scene/1", "name": "t", "gravity": [0, -9.81, 0], "timestep": 0.004, "duration": 1,
  "materials": {"clay": {"density": 1800, "restitution": 0.2, "friction": 0.8, "kappa": 0.1, "thickness": 0.05}},
  "deformation": {"enabled": true, "address_map": 256, "path": "gather"},
  "bodies": [
    {"name": "plate", "shape": {"type": "box", "size": [2, 0.2, 2]}, "material": "clay", "static": true,
     "position": [0, -0.1, 0], "bump_map": {"resolution": 128}},
    {"name": "ball", "shape": {"type": "sphere", "radius": 0.25}, "material": "clay", "position": [0, 0.6, 0],
     "orientation": {"quat": [1, 0, 0, 0]}, "velocity": [0, -6, 0]}
  ],
  "cameras": [{"name": "main", "position": [2, 1.5, 2], "target": [0, 0, 0], "fov": 45}]
})";

// Replaces the first occurrence of `from` in the good scene.
std::string mutate(const std::string& from, const std::string& to) {
  std::string s = kGood;
  const auto pos = s.find(from);
  REQUIRE(pos != std::string::npos);
  s.replace(pos, from.size(), to);
  return s;
}

std::string errorOf(const std::string& text) {
  try {
    parseScene(text, "bad.json", ".");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("the good scene loads") {
  const Scene s = parseScene(kGood, "good.json", ".");
  CHECK(s.bodies.size() == 2);
  CHECK(s.bodies[0].isStatic);
  CHECK(s.bodies[0].bumpMap.resolution == 128);
  CHECK(s.materials.at("clay").restitution == doctest::Approx(0.2));
  CHECK(s.deformation.options.addressMap == 256);
  CHECK(s.deformation.options.addressRaster == deform::AddressRaster::Auto);
  CHECK(parseScene(mutate("\"path\": \"gather\"", "\"path\": \"gather\", \"address_raster\": \"compute\""), "good.json", ".")
            .deformation.options.addressRaster == deform::AddressRaster::Compute);
  CHECK(s.threads == 1);
  CHECK(parseScene(mutate("\"duration\": 1", "\"duration\": 1, \"threads\": 4"), "good.json", ".").threads == 4);
}

TEST_CASE("a camera's displace key turns displacement on for that camera only") {
  const Scene plain = parseScene(kGood, "good.json", ".");
  REQUIRE(plain.cameras.size() == 1);
  CHECK_FALSE(plain.cameras[0].displace);
  const Scene s = parseScene(mutate("\"fov\": 45", "\"fov\": 45, \"displace\": true"), "good.json", ".");
  REQUIRE(s.cameras.size() == 1);
  CHECK(s.cameras[0].displace);
  CHECK(cameraView(s.cameras[0], nullptr).displace);
}

TEST_CASE("malformed scenes name the key path and the reason") {
  struct Case {
    std::string text, path, reason;
  };
  const std::vector<Case> corpus = {
      {"{\"bodies\": [", "bad.json", "malformed JSON at line 1"},
      {"[1, 2]", "bad.json", "top level must be an object"},
      {mutate("\"format\": \"crumple-scene/1\"", "\"format\": \"crumple-scene/9\""), "format", "unsupported format"},
      {mutate("\"radius\": 0.25", "\"radius\": -1"), "bodies[1].shape.radius", "must be in [0.0001"},
      {mutate("\"size\": [2, 0.2, 2]", "\"size\": [2, 1e-300, 2]"), "bodies[0].shape.size", "smaller than 0.1 mm"},
      {mutate("\"radius\": 0.25", "\"radius\": \"big\""), "bodies[1].shape.radius", "must be a number"},
      {mutate("\"restitution\": 0.2", "\"restitution\": 1.5"), "materials.clay.restitution", "must be in [0, 1]"},
      {mutate("\"restitution\": 0.2", "\"restitution\": -0.1"), "materials.clay.restitution", "must be in [0, 1]"},
      {mutate("\"density\": 1800", "\"density\": 0"), "materials.clay.density", "must be in (0"},
      {mutate("\"timestep\": 0.004", "\"timestep\": 0"), "timestep", "must be in"},
      {mutate("\"timestep\": 0.004", "\"timestep\": -1"), "timestep", "must be in"},
      {mutate("\"duration\": 1", "\"duration\": 1e300"), "duration", "must be in"},
      {mutate("\"duration\": 1", "\"duration\": 1, \"threads\": -1"), "threads", "must be in [0, 256]"},
      {mutate("\"duration\": 1", "\"duration\": 1, \"threads\": 2.5"), "threads", "must be an integer"},
      {mutate("\"address_map\": 256", "\"address_map\": 100000"), "deformation.address_map", "must be in [16, 4096]"},
      {mutate("\"address_map\": 256", "\"address_map\": 256.5"), "deformation.address_map", "must be an integer"},
      {mutate("\"path\": \"gather\"", "\"path\": \"gather\", \"address_raster\": \"gpu\""), "deformation.address_raster",
       "must be \"auto\", \"compute\" or \"fragment\", got 'gpu'"},
      {mutate("\"path\": \"gather\"", "\"path\": \"cpu\""), "deformation.path",
       "must be \"gather\", \"scatter\" or \"readback\""},
      {mutate("\"material\": \"clay\", \"position\": [0, 0.6", "\"material\": \"steel\", \"position\": [0, 0.6"),
       "bodies[1].material", "unknown material 'steel'"},
      {mutate("\"type\": \"sphere\"", "\"type\": \"blob\""), "bodies[1].shape.type", "unknown shape type 'blob'"},
      {mutate("\"name\": \"ball\"", "\"name\": \"plate\""), "bodies[1].name", "duplicate body name 'plate'"},
      {mutate("\"name\": \"ball\"", "\"name\": \"../x\""), "bodies[1].name", "must not contain '/'"},
      {mutate("\"size\": [2, 0.2, 2]", "\"size\": [2, 0.2]"), "bodies[0].shape.size", "array of 3 numbers"},
      {mutate("\"size\": [2, 0.2, 2]", "\"size\": [2, 0, 2]"), "bodies[0].shape.size", "must be positive"},
      {mutate("\"position\": [0, -0.1, 0]", "\"position\": [0, 1e999, 0]"), "bb",
       ""},  // parsed as inf by JSON? see below
      {mutate("\"resolution\": 128", "\"resolution\": 1000000"), "bodies[0].bump_map.resolution",
       "must be in [8, 4096]"},
      {mutate("\"quat\": [1, 0, 0, 0]", "\"quat\": [0, 0, 0, 0]"), "bodies[1].orientation.quat", "must not be zero"},
      {mutate("\"velocity\": [0, -6, 0]", "\"velocity\": [0, null, 0]"), "bodies[1].velocity[1]", "must be a number"},
      {mutate("\"static\": true", "\"static\": \"yes\""), "bodies[0].static", "must be true or false"},
      {mutate("\"fov\": 45", "\"fov\": 180"), "cameras[0].fov", "must be in (0, 180)"},
      {mutate("\"target\": [0, 0, 0]", "\"target\": [2, 1.5, 2]"), "cameras[0].target", "must differ from position"},
      {mutate("\"fov\": 45", "\"fov\": 45, \"follow\": \"bal\""), "cameras[0].follow", "no body is named 'bal'"},
      {mutate("\"fov\": 45", "\"fov\": 45, \"follow_heading\": true"), "cameras[0].follow_heading", "needs \"follow\""},
      {mutate("\"fov\": 45", "\"fov\": 45, \"displace\": \"yes\""), "cameras[0].displace", "must be true or false"},
      {mutate("{\"type\": \"sphere\", \"radius\": 0.25}", "{\"type\": \"mesh\", \"file\": \"nope.glb\"}"),
       "bodies[1].shape.file", "no such file"},
      {mutate("\"bodies\": [", "\"bodies\": 3, \"x\": ["), "bodies", "must be an array"},
      {mutate("\"velocity\": [0, -6, 0]", "\"vehicle\": {\"wheels\": [[1, 0, 1], [1, 0, -1]]}"),
       "bodies[1].vehicle.wheels", "3 to 16 points"},
      {mutate("\"velocity\": [0, -6, 0]",
              "\"vehicle\": {\"wheels\": [[1, 0, 1], [1, 0, -1], [-1, 0, 1]], \"treads\": {\"pitch\": 0}}"),
       "bodies[1].vehicle.treads.pitch", "must be in (0.02"},
      {mutate("\"velocity\": [0, -6, 0]",
              "\"vehicle\": {\"wheels\": [[1, 0, 1], [0, 0, 1], [-1, 0, 1]], \"treads\": {}}"),
       "bodies[1].vehicle.treads", "both sides"},
  };
  for (const Case& c : corpus) {
    if (c.path == "bb") continue;
    CAPTURE(c.text);
    const std::string err = errorOf(c.text);
    CAPTURE(err);
    CHECK(err.find("bad.json") == 0);
    CHECK(err.find(c.path) != std::string::npos);
    CHECK(err.find(c.reason) != std::string::npos);
  }
}

TEST_CASE("joints, kinematic bodies and groups load, and their errors name the key path") {
  const std::string joints = R"("joints": [{"name": "h", "type": "hinge", "a": "plate", "b": "ball", "anchor": [0, 0, 0],
    "axis": [0, 0, 1], "limits": [-45, 30], "motor": {"speed": 90, "max_torque": 5}, "break_impulse": 100},
    {"type": "distance", "b": "ball", "anchor_a": [0, 2, 0], "anchor_b": [0, 0.6, 0], "min": 0, "max": 1.5}],
    "no_collide": [["default", "default"]],
    "cameras")";
  const std::string good = mutate("\"cameras\"", joints);
  const Scene s = parseScene(good, "good.json", ".");
  REQUIRE(s.joints.size() == 2);
  CHECK(s.joints[0].def.type == JointType::Hinge);
  CHECK(s.joints[0].def.lower == doctest::Approx(-0.25 * 3.14159265358979));
  CHECK(s.joints[0].def.motor.enabled);
  CHECK(s.joints[0].def.motor.speed == doctest::Approx(0.5 * 3.14159265358979));
  CHECK(s.joints[0].def.breakImpulse == 100);
  CHECK(s.joints[1].name == "joint1");
  CHECK(s.joints[1].a.empty());
  CHECK(s.joints[1].def.maxLength == 1.5);
  CHECK(s.noCollide.size() == 1);
  auto jointMutate = [&](const std::string& from, const std::string& to) {
    std::string t = good;
    const auto pos = t.find(from);
    REQUIRE(pos != std::string::npos);
    t.replace(pos, from.size(), to);
    return t;
  };
  struct Case {
    std::string text, path, reason;
  };
  const std::vector<Case> corpus = {
      {jointMutate("\"b\": \"ball\", \"anchor\"", "\"b\": \"bal\", \"anchor\""), "joints[0].b", "no body is named 'bal'"},
      {jointMutate("\"axis\": [0, 0, 1]", "\"axis\": [0, 0, 0]"), "joints[0].axis", "must not be zero"},
      {jointMutate("\"limits\": [-45, 30]", "\"limits\": [45, 30]"), "joints[0].limits", "lo is above hi"},
      {jointMutate("\"break_impulse\": 100", "\"break_impulse\": -1"), "joints[0].break_impulse", "must be in [0"},
      {jointMutate("\"type\": \"hinge\"", "\"type\": \"weld\""), "joints[0].type", "unknown joint type 'weld'"},
      {jointMutate("\"max_torque\": 5", "\"max_force\": 5"), "joints[0].motor.max_torque", "is required"},
      {jointMutate("\"min\": 0, \"max\": 1.5", "\"min\": 2, \"max\": 1.5"), "joints[1].min", "is above max"},
      {jointMutate("\"anchor_a\"", "\"anchor\": [0, 0, 0], \"anchor_a\""), "joints[1].anchor", "anchor_a and anchor_b"},
      {jointMutate("\"a\": \"plate\", \"b\": \"ball\"", "\"a\": \"ball\", \"b\": \"ball\""), "joints[0].b",
       "two different bodies"},
      {jointMutate("[[\"default\", \"default\"]]", "[[\"default\", \"debris\"]]"), "no_collide[0][1]",
       "no body is in group 'debris'"},
      {jointMutate("\"velocity\": [0, -6, 0]", "\"velocity\": [0, -6, 0], \"path\": [{\"t\": 0, \"position\": [0, 0, 0]}]"),
       "bodies[1].path", "only a kinematic body"},
      {jointMutate("\"velocity\": [0, -6, 0]",
                   "\"kinematic\": true, \"path\": [{\"t\": 1, \"position\": [0, 0, 0]}, {\"t\": 1, \"position\": [0, 1, 0]}]"),
       "bodies[1].path[1].t", "must increase"},
      {jointMutate("\"static\": true", "\"static\": true, \"kinematic\": true"), "bodies[0].kinematic",
       "both static and kinematic"},
  };
  for (const Case& c : corpus) {
    CAPTURE(c.text);
    const std::string err = errorOf(c.text);
    CAPTURE(err);
    CHECK(err.find("bad.json") == 0);
    CHECK(err.find(c.path) != std::string::npos);
    CHECK(err.find(c.reason) != std::string::npos);
  }
}

TEST_CASE("hostile values make short messages: a 100000-deep array, a 100000-character string, a folder as an image") {
  std::string deep(100000, '[');
  deep += std::string(100000, ']');
  const std::string nested = errorOf(mutate("\"fov\": 45", "\"fov\": " + deep));
  CAPTURE(nested.substr(0, 300));
  CHECK(nested.find("cameras[0].fov") != std::string::npos);
  CHECK(nested.find("an array of 1 item") != std::string::npos);
  CHECK(nested.size() < 1200);
  const std::string longName = errorOf(mutate("\"name\": \"main\"", "\"name\": \"" + std::string(100000, 'x') + "/\""));
  CHECK(longName.find("cameras[0].name") != std::string::npos);
  CHECK(longName.size() < 1200);
  const std::string folder =
      errorOf(mutate("\"resolution\": 128", "\"image\": \"" + fs::temp_directory_path().string() + "\""));
  CHECK(folder.find("bodies[0].bump_map.image") != std::string::npos);
  CHECK(folder.find("is a folder") != std::string::npos);
}

TEST_CASE("numbers too large for a double are rejected, not turned into infinity") {
  const std::string err = errorOf(mutate("\"position\": [0, -0.1, 0]", "\"position\": [0, 1e999, 0]"));
  CHECK(!err.empty());
}

namespace {
fs::path tempFile(const std::string& name, const std::string& content) {
  const fs::path p = fs::temp_directory_path() / ("crumple_tests_" + std::to_string(::getpid())) / name;
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << content;
  return p;
}

// A minimal valid glTF triangle (a tetrahedron) with embedded base64 buffer data.
std::string gltfWith(const std::string& patchFrom = "", const std::string& patchTo = "") {
  // 4 float3 positions (48 bytes) + 12 uint16 indices (24 bytes) = 72 bytes.
  std::vector<unsigned char> bytes;
  const float pos[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const uint16_t idx[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  bytes.insert(bytes.end(), reinterpret_cast<const unsigned char*>(pos),
               reinterpret_cast<const unsigned char*>(pos) + 48);
  bytes.insert(bytes.end(), reinterpret_cast<const unsigned char*>(idx),
               reinterpret_cast<const unsigned char*>(idx) + 24);
  static const char* b64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string enc;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const unsigned v =
        bytes[i] << 16 | (i + 1 < bytes.size() ? bytes[i + 1] << 8 : 0) | (i + 2 < bytes.size() ? bytes[i + 2] : 0);
    enc += b64[v >> 18 & 63];
    enc += b64[v >> 12 & 63];
    enc += i + 1 < bytes.size() ? b64[v >> 6 & 63] : '=';
    enc += i + 2 < bytes.size() ? b64[v & 63] : '=';
  }
  std::string s = R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0, "translation": [0, 1, 0]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "buffers": [{"byteLength": 72, "uri": "data:application/octet-stream;base64,)" +
                  enc + R"("}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 24}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,1]},
                  {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]})";
  if (!patchFrom.empty()) {
    const auto p = s.find(patchFrom);
    REQUIRE(p != std::string::npos);
    s.replace(p, patchFrom.size(), patchTo);
  }
  return s;
}
}  // namespace

TEST_CASE("a valid glTF loads with its node transform applied") {
  const TriangleMesh m = loadMeshFile(tempFile("tet.gltf", gltfWith()).string());
  CHECK(m.triangles.size() == 4);
  CHECK(m.boundsMin().y == doctest::Approx(1.0));
  CHECK(polyhedralMassProperties(m).volume == doctest::Approx(1.0 / 6));
}

TEST_CASE("broken glTF files are MeshErrors with a reason") {
  struct Case {
    std::string from, to, reason;
  };
  const std::vector<Case> corpus = {
      {"\"uri\": \"data:", "\"uri\": \"missing.bin\", \"x\": \"", "missing.bin"},
      {"\"count\": 12", "\"count\": 13", "past the end"},
      {"\"scene\": 0, \"scenes\": [{\"nodes\": [0]}],", "", "no scene"},
      {"\"nodes\": [{\"mesh\": 0,", "\"nodes\": [{\"children\": [0], \"mesh\": 0,", "cycle"},
      {"\"indices\": 1", "\"indices\": 7", "accessor"},
      {"\"asset\"", "\"asset\" ]", "not a valid glTF"},
      {"\"translation\": [0, 1, 0]", "\"scale\": [1e39, 1, 1]", ""},
  };
  for (const Case& c : corpus) {
    CAPTURE(c.from);
    std::string err;
    try {
      loadMeshFile(tempFile("broken.gltf", gltfWith(c.from, c.to)).string());
    } catch (const MeshError& e) {
      err = e.what();
    }
    CAPTURE(err);
    CHECK(!err.empty());
    CHECK(err.find(c.reason) != std::string::npos);
  }
}

TEST_CASE("indices out of range in a glTF are rejected") {
  // Index 9 in a 4-vertex mesh: patch the base64 payload is awkward, so raise count of positions down instead.
  std::string err;
  try {
    loadMeshFile(tempFile("oor.gltf", gltfWith("\"count\": 4, \"type\": \"VEC3\"", "\"count\": 2, \"type\": \"VEC3\""))
                     .string());
  } catch (const MeshError& e) {
    err = e.what();
  }
  CHECK(err.find("out of range") != std::string::npos);
}

TEST_CASE("OBJ, OFF and broken OBJ") {
  const std::string off = "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  const TriangleMesh m = loadMeshFile(tempFile("tet.off", off).string());
  CHECK(m.triangles.size() == 4);
  CHECK(polyhedralMassProperties(m).volume == doctest::Approx(1.0 / 6));
  const std::string obj =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 3/3 2/2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  CHECK(loadMeshFile(tempFile("tet.obj", obj).string()).triangles.size() == 4);
  CHECK_THROWS_AS(loadMeshFile(tempFile("empty.obj", "this is not a mesh\n").string()), MeshError);
  CHECK_THROWS_AS(loadMeshFile(tempFile("tet.xyz", off).string()), MeshError);
  CHECK_THROWS_AS(loadMeshFile(tempFile("inf.off", "OFF\n3 1 0\n0 0 0\ninf 0 0\n0 1 0\n3 0 1 2\n").string()),
                  MeshError);
  CHECK_THROWS_AS(loadMeshFile(tempFile("huge.off", "OFF\n999999999 1 0\n").string()), MeshError);
  // OBJ errors name the line.
  CHECK_THROWS_WITH_AS(loadMeshFile(tempFile("oor.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n").string()),
                       doctest::Contains("line 4: vertex index 99 out of range"), MeshError);
  CHECK_THROWS_WITH_AS(loadMeshFile(tempFile("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").string()),
                       doctest::Contains("line 1"), MeshError);
  CHECK_THROWS_WITH_AS(loadMeshFile(tempFile("vt.obj", "vt 0 0\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/4 2/1 3/1\n").string()),
                       doctest::Contains("texture coordinate index 4"), MeshError);
  // Negative (relative) indices are valid OBJ.
  const TriangleMesh rel = loadMeshFile(
      tempFile("rel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf -4 -2 -3\nf -4 -3 -1\nf -4 -1 -2\nf -3 -2 -1\n")
          .string());
  CHECK(polyhedralMassProperties(rel).volume == doctest::Approx(1.0 / 6));
}

TEST_CASE("OBJ without normals: corners of one vertex are shared, smooth surfaces shade smooth, edges stay sharp") {
  // A cube: each corner meets three faces at 90 degrees, so it is split into three vertices with face normals.
  std::string cube;
  for (int i = 0; i < 8; ++i) cube += "v " + std::to_string(i & 1) + " " + std::to_string(i >> 1 & 1) + " " + std::to_string(i >> 2 & 1) + "\n";
  cube += "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
  const TriangleMesh box = loadMeshFile(tempFile("cube.obj", cube).string());
  CHECK(box.triangles.size() == 12);
  CHECK(box.positions.size() == 24);
  for (const glm::vec3& n : box.normals) CHECK(std::max({std::abs(n.x), std::abs(n.y), std::abs(n.z)}) == doctest::Approx(1.0));
  // A sphere of 32 x 16 quads: one vertex per position (poles aside), normals within 3 degrees of the radius.
  std::string ball;
  const int nu = 32, nv = 16;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const double th = M_PI * j / nv, ph = 2 * M_PI * i / nu;
      ball += "v " + std::to_string(std::sin(th) * std::cos(ph)) + " " + std::to_string(std::cos(th)) + " " +
              std::to_string(std::sin(th) * std::sin(ph)) + "\n";
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int a = j * nu + i + 1, b = j * nu + (i + 1) % nu + 1, c = a + nu, d = b + nu;
      if (j > 0) ball += "f " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + "\n";
      if (j < nv - 1) ball += "f " + std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(c) + "\n";
    }
  const TriangleMesh sphere = loadMeshFile(tempFile("ball.obj", ball).string());
  CHECK(sphere.triangles.size() == static_cast<size_t>(2 * nu * (nv - 1)));
  CHECK(sphere.positions.size() <= static_cast<size_t>(nu * (nv - 1) + 2 * nu));  // shared, not 3 per triangle
  double worst = 1;
  for (size_t i = 0; i < sphere.positions.size(); ++i)
    if (std::abs(sphere.positions[i].y) < 0.99f)
      worst = std::min(worst, static_cast<double>(glm::dot(sphere.normals[i], glm::normalize(sphere.positions[i]))));
  CHECK(worst > std::cos(3.0 * M_PI / 180));
}

TEST_CASE("mesh files that are not what they claim are refused at once: NUL bytes, no glTF magic, over 1 GiB") {
  auto errorOfMesh = [](const fs::path& p) {
    try {
      loadMeshFile(p.string());
    } catch (const MeshError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string nul(1 << 20, '\0');  // 1 MB of NUL bytes
  CHECK(errorOfMesh(tempFile("nul.obj", nul)).find("NUL byte") != std::string::npos);
  CHECK(errorOfMesh(tempFile("nul.glb", nul)).find("no 'glTF' magic") != std::string::npos);
  CHECK(errorOfMesh(tempFile("nul.gltf", nul)).find("not a glTF file") != std::string::npos);
  CHECK(errorOfMesh(tempFile("long.obj", std::string(200000, 'v'))).find("line too long") != std::string::npos);
  // A 2 GB file (sparse: no disk used) is refused by its size before anything is read.
  const fs::path big = tempFile("big.obj", "v 0 0 0\n");
  fs::resize_file(big, std::uintmax_t(2) << 30);
  CHECK(errorOfMesh(big).find("larger than 1 GiB") != std::string::npos);
  fs::remove(big);
  CHECK(errorOfMesh(fs::temp_directory_path()).find("is a folder") != std::string::npos);
}

TEST_CASE("PLY headers are checked strictly: corrupted keywords, no end_header") {
  const std::string good =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  CHECK(loadMeshFile(tempFile("tet.ply", good).string()).triangles.size() == 4);
  auto errorOfPly = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string text = good;
    text.replace(text.find(from), from.size(), to);
    try {
      loadMeshFile(tempFile(name, text).string());
    } catch (const MeshError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(errorOfPly("kw.ply", "element face", "elemXnt face").find("header line 7: unknown keyword") !=
        std::string::npos);
  CHECK(errorOfPly("end.ply", "end_header", "end_hXader").find("header line 9: unknown keyword") != std::string::npos);
  CHECK(errorOfPly("noend.ply", "end_header\n", "").find("header line") != std::string::npos);
  CHECK(errorOfPly("count.ply", "vertex 4", "vertex -4").find("needs a name and a count") != std::string::npos);
  CHECK(errorOfPly("type.ply", "property float x", "property flaot x").find("bad property") != std::string::npos);
}

TEST_CASE("a mesh with a face repeated 200000 times loads at once, its copies dropped") {
  std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  for (int i = 0; i < 200000; ++i) obj += i % 2 ? "f 1 3 2\n" : "f 3 2 1\n";
  const auto t0 = std::chrono::steady_clock::now();
  const TriangleMesh m = loadMeshFile(tempFile("dups.obj", obj).string());
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  CHECK(m.triangles.size() == 4);
  CHECK(polyhedralMassProperties(m).volume == doctest::Approx(1.0 / 6));
  MESSAGE("loaded in " << s << " s");
}

TEST_CASE("OBJ vertex colours ('v x y z r g b') load and survive the automatic atlas") {
  const std::string obj =
      "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 0 0 1 0.5 0.5 0.5\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  const TriangleMesh m = loadMeshFile(tempFile("coloured.obj", obj).string());
  REQUIRE(m.colors.size() == m.positions.size());
  const TriangleMesh atlas = generateAtlas(m, 64);
  REQUIRE(atlas.colors.size() == atlas.positions.size());
  CHECK(checkAtlas(atlas, 64).oneToOne);
  // Every corner keeps the colour of its position.
  for (size_t i = 0; i < atlas.positions.size(); ++i) {
    const glm::vec3 p = atlas.positions[i], c = atlas.colors[i];
    const glm::vec3 expected = p == glm::vec3(1, 0, 0)   ? glm::vec3(0, 1, 0)
                               : p == glm::vec3(0, 1, 0) ? glm::vec3(0, 0, 1)
                               : p == glm::vec3(0, 0, 1) ? glm::vec3(0.5f)
                                                         : glm::vec3(1, 0, 0);
    CHECK(c == expected);
  }
  // Without colours there are none; a colour outside [0, 1] is an error naming the line.
  CHECK(loadMeshFile(tempFile("plain.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").string()).colors.empty());
  try {
    loadMeshFile(tempFile("badcolour.obj", "v 0 0 0 2 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").string());
    FAIL("expected a MeshError");
  } catch (const MeshError& e) {
    CHECK(std::string(e.what()).find("line 1: vertex colour outside [0, 1]") != std::string::npos);
  }
}

namespace {
// Little-endian bytes, as binary OFF, PLY and GLB store them.
std::string le32(uint32_t v) {
  std::string s(4, '\0');
  for (int i = 0; i < 4; ++i) s[static_cast<size_t>(i)] = static_cast<char>(v >> (8 * i) & 0xff);
  return s;
}
std::string f32(float f) {
  uint32_t bits;
  std::memcpy(&bits, &f, 4);
  return le32(bits);
}
// A binary OFF ("OFF BINARY", counts, vertices, faces as OpenMesh writes them) of the unit tetrahedron with
// `faceBytes` as its faces.
std::string binaryOff(int32_t faceCount, const std::string& faceBytes, float far = 1) {
  std::string s = "OFF BINARY\n" + le32(4) + le32(static_cast<uint32_t>(faceCount)) + le32(0);
  const float v[12] = {0, 0, 0, far, 0, 0, 0, 1, 0, 0, 0, 1};
  for (float x : v) s += f32(x);
  return s + faceBytes;
}
std::string offFace(int32_t a, int32_t b, int32_t c) { return le32(3) + le32(a) + le32(b) + le32(c); }
const std::string kTetFaces = offFace(0, 2, 1) + offFace(0, 1, 3) + offFace(0, 3, 2) + offFace(1, 2, 3);

// A GLB of the unit tetrahedron: the JSON chunk of `gltfJson` (buffer 0 is the BIN chunk) and positions scaled.
std::string glbTet(const std::string& patchFrom = "", const std::string& patchTo = "", float scale = 1) {
  std::string bin;
  const float pos[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  for (float p : pos) bin += f32(p * scale);
  const uint16_t idx[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  for (uint16_t i : idx) bin += std::string{static_cast<char>(i & 0xff), static_cast<char>(i >> 8)};
  std::string json = R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
    "nodes": [{"mesh": 0, "translation": [0, 1, 0]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}], "buffers": [{"byteLength": 72}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 24}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
                  {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]})";
  if (!patchFrom.empty()) {
    const auto p = json.find(patchFrom);
    REQUIRE(p != std::string::npos);
    json.replace(p, patchFrom.size(), patchTo);
  }
  while (json.size() % 4) json += ' ';
  const auto total = static_cast<uint32_t>(12 + 8 + json.size() + 8 + bin.size());
  return "glTF" + le32(2) + le32(total) + le32(static_cast<uint32_t>(json.size())) + "JSON" + json +
         le32(static_cast<uint32_t>(bin.size())) + std::string("BIN\0", 4) + bin;
}

std::string meshErrorOf(const fs::path& p) {
  try {
    loadMeshFile(p.string());
  } catch (const MeshError& e) {
    return e.what();
  }
  return "";
}

double peakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

// What crumple-sim says (exit 2) about a scene whose second body is the mesh file `mesh`: the scene is loaded and
// the body's assets built as the simulation builds them.
std::string sceneErrorWithMesh(const fs::path& mesh) {
  std::string text = kGood;
  const std::string ball = R"({"type": "sphere", "radius": 0.25})";
  text.replace(text.find(ball), ball.size(), R"({"type": "mesh", "file": ")" + mesh.filename().string() + "\"}");
  const fs::path scene = mesh.parent_path() / "mesh-scene.json";
  std::ofstream(scene) << text;
  try {
    const Scene s = loadScene(scene.string());
    AssetCache cache(scene.string());
    cache.load(s.bodies[1], "bodies[1]");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("a binary OFF that lies ends at once in a MeshError: an index out of range, a face count, -3 vertices") {
  CHECK(loadMeshFile(tempFile("tet-binary.off", binaryOff(4, kTetFaces)).string()).triangles.size() == 4);
  struct Case {
    const char* name;
    std::string bytes, reason;
  };
  const std::vector<Case> cases = {
      {"oor.off", binaryOff(4, kTetFaces.substr(0, 60) + le32(1000000)),
       "face 3: vertex index 1000000 out of range (4 vertices)"},
      {"lying.off", binaryOff(2000000000, kTetFaces), "the header announces 4 vertices and 2000000000 faces"},
      {"minus3.off", binaryOff(4, le32(static_cast<uint32_t>(-3)) + kTetFaces.substr(4)),
       "face 0 has -3 vertices: a face needs at least 3"},
      {"negative-index.off", binaryOff(4, offFace(0, -1, 2) + kTetFaces.substr(16)), "vertex index -1 out of range"},
      {"short.off", binaryOff(4, kTetFaces.substr(0, 30)), "more than the file's 78 remaining bytes can hold"},
      {"huge-face.off", binaryOff(1, le32(0x7fffffff) + kTetFaces), "more than the rest of the file holds"},
      {"coloured.off", "C" + binaryOff(4, kTetFaces), "COFF BINARY"},
  };
  const double rss0 = peakRssMb();
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const auto t0 = std::chrono::steady_clock::now();
    const std::string err = meshErrorOf(tempFile(c.name, c.bytes));
    CAPTURE(err);
    CHECK(err.find(c.reason) != std::string::npos);
    CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 2);
  }
  // OpenMesh's reader took 5-10 GB on the face count and the -3 vertices.
  CHECK(peakRssMb() - rss0 < 100);
}

TEST_CASE("ASCII OFF: its variants load; a broken one is an error naming the line") {
  const std::string v = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n", f = "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  CHECK(loadMeshFile(tempFile("c.off", "# comment\nOFF 4 4 0\n" + v + "\n" + f).string()).triangles.size() == 4);
  const TriangleMesh st =
      loadMeshFile(tempFile("st.off", "STOFF\n4 4 0\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n0 0 1 0.5 0.5\n" + f).string());
  CHECK(st.uvs.size() == st.positions.size());
  CHECK(loadMeshFile(tempFile("cn.off",
                              "CNOFF\n4 4 0\n0 0 0 0 0 1 1 0 0\n1 0 0 0 0 1 1 0 0 1\n"
                              "0 1 0 0 0 1 255 0 0\n0 0 1 0 0 1 7\n" +
                                  f)
                         .string())
            .triangles.size() == 4);
  CHECK(polyhedralMassProperties(loadMeshFile(tempFile("quad.off",
                                                       "OFF\n5 5 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
                                                       "0.5 0.5 1\n4 3 2 1 0\n3 0 1 4\n3 1 2 4\n"
                                                       "3 2 3 4\n3 3 0 4\n")
                                                  .string()))
            .volume == doctest::Approx(1.0 / 3));
  auto errorOfOff = [&](const char* name, const std::string& text) { return meshErrorOf(tempFile(name, text)); };
  CHECK(errorOfOff("e1.off", "OFF\n4 4 0\n" + v + "2 0 1\n" + f).find("line 7: face 0: a face needs at least 3") !=
        std::string::npos);
  CHECK(errorOfOff("e2.off", "OFF\n4 4 0\n" + v + "3 0 1 4\n" + f).find("line 7: face 0: vertex index '4' out of") !=
        std::string::npos);
  CHECK(errorOfOff("e3.off", "OFF\n4 4 0\n0 0\n1 0 0\n0 1 0\n0 0 1\n" + f)
            .find("line 3: vertex 0: expected 3 numbers, got 2") != std::string::npos);
  CHECK(errorOfOff("e4.off", "OFF\n4 4 0\n" + v + "3 0 2 1\n# " + std::string(40, '-'))
            .find("the file ends before face 1 of 4") != std::string::npos);
  // A header announcing more than the file can hold is refused before anything is read or reserved.
  CHECK(errorOfOff("e9.off", "OFF\n4 4 0\n" + v + "3 0 2 1\n").find("line 2: the header announces 4 vertices") !=
        std::string::npos);
  CHECK(errorOfOff("e5.off", "4OFF\n").find("only 3-dimensional OFF") != std::string::npos);
  CHECK(errorOfOff("e6.off", "PLY\n").find("not an OFF file") != std::string::npos);
  CHECK(errorOfOff("e7.off", "OFF\n-4 4 0\n").find("expected the counts") != std::string::npos);
  CHECK(errorOfOff("e8.off", "OFF\n4 4 0\n" + v + "3 0 2 1 #\n3 0 1 3\n3 0 3 2\n3 1 2 3 9 9 9\n").empty());
}

TEST_CASE("PLY is read by crumple's own reader: ASCII and binary load; a broken body names its element and record") {
  const std::string head =
      "ply\nformat %s 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
  auto withFormat = [&](const std::string& f) {
    std::string h = head;
    h.replace(h.find("%s"), 2, f);
    return h;
  };
  std::string le = withFormat("binary_little_endian"), be = withFormat("binary_big_endian");
  const float v[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  auto reversed = [](std::string s) { return std::string(s.rbegin(), s.rend()); };
  for (float x : v) le += f32(x), be += reversed(f32(x));
  for (const auto& t : faces) {
    le += '\3', be += '\3';
    for (int i : t) le += le32(static_cast<uint32_t>(i)), be += reversed(le32(static_cast<uint32_t>(i)));
  }
  for (const auto& [name, bytes] : {std::pair{"le.ply", le}, std::pair{"be.ply", be}}) {
    const TriangleMesh m = loadMeshFile(tempFile(name, bytes).string());
    CHECK(polyhedralMassProperties(m).volume == doctest::Approx(1.0 / 6));
  }
  // Vertex uvs and other elements (skipped).
  const TriangleMesh uv = loadMeshFile(
      tempFile("uv.ply",
               "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
               "property float s\nproperty float t\nelement face 4\nproperty list uchar uint vertex_index\n"
               "element edge 1\nproperty int vertex1\nproperty list int int stuff\nend_header\n"
               "0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n0 0 1 1 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n0 2 5 6\n")
          .string());
  CHECK(uv.uvs.size() == uv.positions.size());
  const std::string ascii = withFormat("ascii") + "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  auto errorOfPly = [&](const char* name, const std::string& from, const std::string& to, std::string text = "") {
    if (text.empty()) text = ascii;
    text.replace(text.find(from), from.size(), to);
    return meshErrorOf(tempFile(name, text));
  };
  CHECK(errorOfPly("b1.ply", "3 1 2 3", "3 1 2 99").find("element 'face' 3: vertex index 99 out of range") !=
        std::string::npos);
  CHECK(errorOfPly("b2.ply", "3 1 2 3", "2 1 2").find("element 'face' 3: a face needs at least 3 vertices") !=
        std::string::npos);
  CHECK(errorOfPly("b3.ply", "3 1 2 3\n", "4 1 2 3\n").find("element 'face' 3: the file ends in this record") !=
        std::string::npos);
  CHECK(errorOfPly("b4.ply", "0 0 1\n", "0 0 x\n").find("element 'vertex' 3: 'x' is not a number") !=
        std::string::npos);
  CHECK(errorOfPly("b5.ply", "3 1 2 3", "200 1 2 3").find("more than the rest of the file holds") != std::string::npos);
  CHECK(errorOfPly("b6.ply", "element face 4", "element face 4000000").find("more records than") != std::string::npos);
  // Found by fuzzing: a property before any element crashed OpenMesh's reader (in can_u_read).
  CHECK(errorOfPly("b7.ply", "element vertex 4\n", "").find("header line 3: a property before any element") !=
        std::string::npos);
  CHECK(errorOfPly("b8.ply", "property float z\n", "").find("the vertex element has no x, y and z") !=
        std::string::npos);
  // A binary list count of 2^32-1 items is refused before anything is read into it.
  std::string huge = le;
  huge[huge.find("end_header\n") + 11 + 48] = '\xff';
  CHECK(errorOfPly("b9.ply", "x", "x", huge).find("more than the rest of the file holds") != std::string::npos);
}

TEST_CASE("every format refuses coordinates beyond 1e30 (OBJ's limit): OFF's 1e38, GLB's 3e38") {
  const std::string f = "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  CHECK(meshErrorOf(tempFile("big.off", "OFF\n4 4 0\n0 0 0\n1e38 0 0\n0 1 0\n0 0 1\n" + f))
            .find("line 4: vertex 1: '1e38' is beyond 1e30 in magnitude") != std::string::npos);
  CHECK(meshErrorOf(tempFile("big-binary.off", binaryOff(4, kTetFaces, 1e38f)))
            .find("vertex 1: a coordinate is beyond 1e30 in magnitude") != std::string::npos);
  CHECK(meshErrorOf(tempFile("big.obj", "v 0 0 0\nv 1e38 0 0\nv 0 1 0\nf 1 2 3\n"))
            .find("line 2: coordinate '1e38' is beyond 1e30 in magnitude") != std::string::npos);
  CHECK(meshErrorOf(tempFile("big.ply",
                             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                             "end_header\n0 0 0\n2e30 0 0\n0 1 0\n3 0 1 2\n"))
            .find("element 'vertex' 1: a coordinate is beyond 1e30 in magnitude") != std::string::npos);
  CHECK(meshErrorOf(tempFile("big.glb", glbTet("", "", 3e38f)))
            .find("meshes[0].primitives[0].attributes.POSITION: vertex 1 (in the scene's frame) is beyond 1e30") !=
        std::string::npos);
  // Up to the limit they load (the body is then the physics' business).
  CHECK(meshErrorOf(tempFile("far.off", "OFF\n4 4 0\n0 0 0\n1e29 0 0\n0 1 0\n0 0 1\n" + f)).empty());
  CHECK(meshErrorOf(tempFile("tet.glb", glbTet())).empty());
}

TEST_CASE("glTF transforms and offsets tinygltf lets through are refused with their key paths") {
  struct Case {
    std::string from, to, reason;
  };
  const std::vector<Case> cases = {
      {"\"translation\": [0, 1, 0]", "\"rotation\": [0, 0, 0, 0]",
       "nodes[0].rotation: must be a unit quaternion [x, y, z, w], got [0,0,0,0] (length 0)"},
      {"\"translation\": [0, 1, 0]", "\"rotation\": [0, 0, 0, 2]", "(length 2)"},
      {"\"translation\": [0, 1, 0]", "\"scale\": [1e30, 1, 1]", "nodes[0].scale[0]: 1e+30 is outside [1e-6, 1e6]"},
      {"\"translation\": [0, 1, 0]", "\"scale\": [1, 0, 1]", "nodes[0].scale[1]: 0 is outside"},
      {"\"translation\": [0, 1, 0]", "\"scale\": [1, 1]", "nodes[0].scale: must be an array of 3 numbers"},
      {"\"translation\": [0, 1, 0]", "\"translation\": [0, 1e31, 0]", "nodes[0].translation[1]: 1e+31 is beyond"},
      {"\"translation\": [0, 1, 0]", "\"matrix\": [1e30,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]",
       "nodes[0].matrix: the scale of axis 0: 1e+30 is outside"},
      {"\"translation\": [0, 1, 0]", "\"matrix\": [1,0,0,1, 0,1,0,0, 0,0,1,0, 0,0,0,1]", "must be affine"},
      {"\"translation\": [0, 1, 0]", "\"matrix\": [1,0,0,0, 1,0,0,0, 0,0,1,0, 0,0,0,1]", "nodes[0].matrix: is singular"},
      {"\"byteOffset\": 0", "\"byteOffset\": -4",
       "bufferViews[0].byteOffset: must be a whole number from 0 to 2^32, got -4"},
      {"\"count\": 4", "\"count\": -4", "accessors[0].count: must be a whole number"},
      {"\"count\": 4", "\"count\": 4, \"byteOffset\": 1.5", "accessors[0].byteOffset: must be a whole number"},
      {"\"byteLength\": 72", "\"byteLength\": 72, \"extras\": " + std::string(100, '[') + std::string(100, ']'),
       "the JSON nests deeper than 64 levels"},
      {"\"mesh\": 0", "\"mesh\": -1", "nodes[0].mesh: must be a whole number"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.to);
    const std::string glb = meshErrorOf(tempFile("t.glb", glbTet(c.from, c.to)));
    CAPTURE(glb);
    CHECK(glb.find(c.reason) != std::string::npos);
    const std::string gltf = meshErrorOf(tempFile("t.gltf", gltfWith(c.from, c.to)));
    CAPTURE(gltf);
    CHECK(gltf.find(c.reason) != std::string::npos);
  }
  // A unit quaternion off by float rounding loads, normalised; a chain of 300 nodes is refused by its depth.
  CHECK(meshErrorOf(
            tempFile("rot.glb", glbTet("\"translation\": [0, 1, 0]", "\"rotation\": [0, 0.7071068, 0, 0.7071067]")))
            .empty());
  std::string chain = "\"nodes\": [{\"mesh\": 0, \"translation\": [0, 1, 0]}";
  for (int i = 1; i < 300; ++i) chain += ",{\"children\": [" + std::to_string(i - 1) + "]}";
  chain += "]";
  const std::string deep = meshErrorOf(tempFile(
      "deep.glb", glbTet("\"scenes\": [{\"nodes\": [0]}],\n    \"nodes\": [{\"mesh\": 0, \"translation\": [0, 1, 0]}]",
                         "\"scenes\": [{\"nodes\": [299]}],\n    " + chain)));
  CHECK(deep.find("node hierarchy deeper than 256 levels") != std::string::npos);
}

TEST_CASE("a mesh body's broken file is a SceneError naming the scene, the key path and the mesh file") {
  // What crumple-sim prints before it exits with 2, for each kind of hostile mesh file the fuzz corpus keeps.
  const std::vector<std::pair<fs::path, std::string>> cases = {
      {tempFile("oor-body.off", binaryOff(4, kTetFaces.substr(0, 60) + le32(1000000))), "out of range"},
      {tempFile("lying-body.off", binaryOff(2000000000, kTetFaces)), "2000000000 faces"},
      {tempFile("minus3-body.off", binaryOff(4, le32(static_cast<uint32_t>(-3)) + kTetFaces.substr(4))), "-3 vertices"},
      {tempFile("big-body.off", "OFF\n3 1 0\n0 0 0\n1e38 0 0\n0 1 0\n3 0 1 2\n"), "beyond 1e30"},
      {tempFile("big-body.glb", glbTet("", "", 3e38f)), "beyond 1e30"},
      {tempFile("rot-body.glb", glbTet("\"translation\": [0, 1, 0]", "\"rotation\": [0, 0, 0, 0]")),
       "nodes[0].rotation"},
      {tempFile("scale-body.glb", glbTet("\"translation\": [0, 1, 0]", "\"scale\": [1e30, 1, 1]")),
       "nodes[0].scale[0]"},
      {tempFile("offset-body.glb", glbTet("\"byteOffset\": 0", "\"byteOffset\": -4")), "bufferViews[0].byteOffset"},
  };
  for (const auto& [file, reason] : cases) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string err = sceneErrorWithMesh(file);
    CAPTURE(err);
    CHECK(err.find("mesh-scene.json: bodies[1].shape.file: " + file.string() + ": ") != std::string::npos);
    CHECK(err.find(reason) != std::string::npos);
    CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 2);
  }
}

TEST_CASE("every file of the fuzzers' corpora loads or is refused, at once (the regression cases of tests/fuzz)") {
  const fs::path corpus = CRUMPLE_FUZZ_CORPUS;
  REQUIRE(fs::is_directory(corpus));
  int loaded = 0, refused = 0;
  for (const char* format : {"obj", "off", "ply", "gltf", "glb"}) {
    for (const auto& e : fs::directory_iterator(corpus / format)) {
      // The readers choose by extension: a corpus file is read as its folder's format.
      const fs::path copy = tempFile(std::string("corpus.") + format, "");
      fs::copy_file(e.path(), copy, fs::copy_options::overwrite_existing);
      const auto t0 = std::chrono::steady_clock::now();
      const std::string err = meshErrorOf(copy);
      CAPTURE(e.path());
      CAPTURE(err);
      CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 5);
      const std::string name = e.path().filename().string();
      // The valid seeds load (a fuzzer starts from them); the kept hostile files are refused.
      if (name.rfind("tet", 0) == 0 || name == "car.obj" || name == "wbeam.obj" || name == "pyramid.off")
        CHECK(err.empty());
      if ((name.rfind("hostile-", 0) == 0 && name != "hostile-duplicate-faces.obj") || name.rfind("fuzz-", 0) == 0)
        CHECK(!err.empty());
      ++(err.empty() ? loaded : refused);
    }
  }
  for (const auto& e : fs::directory_iterator(corpus / "scene")) {
    std::ifstream in(e.path(), std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto t0 = std::chrono::steady_clock::now();
    try {
      parseScene(text, e.path().filename().string(), CRUMPLE_FUZZ_CORPUS "/../../../scenes");
    } catch (const SceneError&) {
    }
    CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 5);
  }
  MESSAGE(loaded << " mesh files loaded, " << refused << " refused");
  CHECK(loaded >= 15);
  CHECK(refused >= 15);
}

TEST_CASE("a GLB whose header lies about its length, or a glTF of millions of JSON values, is refused before parsing") {
  std::string glb = glbTet();
  glb[8] = static_cast<char>(glb[8] + 4);  // the length field
  CHECK(meshErrorOf(tempFile("length.glb", glb)).find("header gives its length as") != std::string::npos);
  // 5 million zeros in "extras": a parsed document of hundreds of megabytes, twice.
  std::string zeros(10000000, '0');
  for (size_t i = 1; i < zeros.size(); i += 2) zeros[i] = ',';
  zeros.back() = '0';
  const auto t0 = std::chrono::steady_clock::now();
  CHECK(meshErrorOf(
            tempFile("values.gltf", gltfWith("\"byteLength\": 72", "\"byteLength\": 72, \"extras\": [" + zeros + "]")))
            .find("more than 4194304 values") != std::string::npos);
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 2);
}

TEST_CASE(
    "a scene's name names its output folder: a path, '..', a control character or over 128 characters is refused") {
  // The name makes crumple-sim's default output folder out/<name>: "../../escaped" would write outside out/.
  for (const std::string& bad : {std::string("../../escaped"), std::string(".."), std::string("."), std::string("a/b"),
                                 std::string("a\\\\b"), std::string("a\\tb"), std::string(129, 'x'), std::string("")}) {
    CAPTURE(bad);
    const std::string err = errorOf(mutate("\"name\": \"t\"", "\"name\": \"" + bad + "\""));
    CAPTURE(err);
    CHECK(err.find("bad.json: name: ") == 0);
    CHECK(err.size() < 300);
  }
  CHECK(errorOf(mutate("\"name\": \"t\"", "\"name\": \"../../escaped\"")) ==
        "bad.json: name: must not contain '/', '\\' or control characters (it names output files)");
  CHECK(errorOf(mutate("\"name\": \"t\"", "\"name\": \"" + std::string(129, 'x') + "\"")) ==
        "bad.json: name: longer than 128 characters");
  // Without "name" the file's name is the scene's: "...json" would be "..", a file name of bytes that are not
  // UTF-8 would be a name summary.json cannot hold.
  const std::string unnamed = mutate("\"name\": \"t\", ", "");
  for (const std::string& file : {std::string("dir/...json"), std::string("dir/caf\xe9.json")}) {
    CAPTURE(file);
    try {
      parseScene(unnamed, file, ".");
      FAIL("no error");
    } catch (const SceneError& e) {
      CAPTURE(e.what());
      CHECK(e.keyPath == "name");
      CHECK(std::string(e.what()).find("give the scene a \"name\"") != std::string::npos);
      CHECK(isValidUtf8(e.what()));
    }
  }
  // Names that are fine: spaces, dots inside, UTF-8, 128 characters.
  CHECK(parseScene(mutate("\"name\": \"t\"", "\"name\": \"run 2 (v1.5)\""), "x.json", ".").name == "run 2 (v1.5)");
  CHECK(parseScene(mutate("\"name\": \"t\"", "\"name\": \"d\xc3\xa9j\xc3\xa0\""), "x.json", ".").name ==
        "d\xc3\xa9j\xc3\xa0");
  CHECK(
      parseScene(mutate("\"name\": \"t\"", "\"name\": \"" + std::string(128, 'x') + "\""), "x.json", ".").name.size() ==
      128);
  CHECK(parseScene(unnamed, "dir/my-run.json", ".").name == "my-run");
}

TEST_CASE("camera, joint, material and group names over 128 characters are bad input with a short message") {
  const std::string longName(5000, 'c');
  const std::string camera = errorOf(mutate("\"name\": \"main\"", "\"name\": \"" + longName + "\""));
  CHECK(camera == "bad.json: cameras[0].name: longer than 128 characters");
  CHECK(errorOf(mutate("\"name\": \"main\"", "\"name\": \"..\"")) ==
        "bad.json: cameras[0].name: must not be '.' or '..'");
  const std::string material = errorOf(mutate("\"clay\": {", "\"" + longName + "\": {}, \"clay\": {"));
  CAPTURE(material);
  CHECK(material.find("bad.json: materials: the material name 'cccc") == 0);
  CHECK(material.find("longer than 128 characters") != std::string::npos);
  CHECK(material.size() < 200);
  const std::string group =
      errorOf(mutate("\"velocity\": [0, -6, 0]", "\"velocity\": [0, -6, 0], \"group\": \"" + longName + "\""));
  CHECK(group == "bad.json: bodies[1].group: longer than 128 characters");
  const std::string joint = errorOf(mutate("\"cameras\"", "\"joints\": [{\"name\": \"" + longName +
                                                              "\", \"type\": \"ball\", \"b\": \"ball\", "
                                                              "\"anchor\": [0, 1, 0]}], \"cameras\""));
  CHECK(joint == "bad.json: joints[0].name: longer than 128 characters");
  // A name echoed in a message is quoted: at most 60 characters, escaped.
  const std::string unknown = errorOf(mutate("\"material\": \"clay\", \"position\": [0, 0.6",
                                             "\"material\": \"" + longName + "\\n\", \"position\": [0, 0.6"));
  CAPTURE(unknown);
  CHECK(unknown.find("bodies[1].material: unknown material 'ccccc") != std::string::npos);
  CHECK(unknown.find("...(4941 characters)...") != std::string::npos);
  CHECK(unknown.find("cc\\n' (defined: clay)") != std::string::npos);
  CHECK(unknown.size() < 200);
}

TEST_CASE(
    "messages stay UTF-8: quoted text escapes control characters and bytes that are not UTF-8, caps cut between "
    "characters") {
  CHECK(isValidUtf8(""));
  CHECK(isValidUtf8("plain ascii"));
  CHECK(isValidUtf8("d\xc3\xa9j\xc3\xa0 \xe2\x82\xac \xf0\x9f\x98\x80"));
  CHECK_FALSE(isValidUtf8("a\xff"));
  CHECK_FALSE(isValidUtf8("\xc3"));              // cut short
  CHECK_FALSE(isValidUtf8("\xc0\xaf"));          // overlong '/'
  CHECK_FALSE(isValidUtf8("\xed\xa0\x80"));      // a surrogate
  CHECK_FALSE(isValidUtf8("\xf4\x90\x80\x80"));  // beyond U+10FFFF
  CHECK(quoteText("a\xff"
                  "b\n\x01") == "a\\xFFb\\n\\x01");
  CHECK(quoteText("d\xc3\xa9j\xc3\xa0") == "d\xc3\xa9j\xc3\xa0");
  const std::string quoted = quoteText(std::string(5000, 'x'));
  CHECK(quoted == std::string(30, 'x') + "...(4940 characters)..." + std::string(30, 'x'));
  CHECK(escapeInvalidUtf8("ok \xc3\xa9 \xfe") == "ok \xc3\xa9 \\xFE");
  // 200 two-byte characters capped at 102 bytes (51 each side): the cuts do not split one.
  std::string accents;
  for (int i = 0; i < 200; ++i) accents += "\xc3\xa9";
  CHECK(isValidUtf8(capText(accents, 102)));
  const SceneError e("f\xff.json", "k", "bad \xfe");
  CHECK(std::string(e.what()) == "f\\xFF.json: k: bad \\xFE");
}

namespace {
// The message of what loadScene throws for `path` ("" when it loads).
std::string loadError(const fs::path& path) {
  try {
    loadScene(path.string());
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE(
    "only regular files of a bounded size are read as scenes, meshes and images: a FIFO, /dev/zero, a folder or a "
    "file over the bound is refused before it is read") {
  const fs::path dir = tempFile("x", "").parent_path();
  const fs::path fifo = dir / "scene-fifo.json";
  fs::remove(fifo);
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  // A FIFO's open waits for a writer: should the loader open it, this opens and closes a writer end after
  // 3 s, and the loader reads an empty file instead of the refusal.
  std::atomic<bool> done{false};
  std::thread unblock([&] {
    for (int i = 0; i < 300 && !done; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    if (done) return;
    const int fd = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);
    if (fd >= 0) ::close(fd);
  });
  const auto t0 = std::chrono::steady_clock::now();
  const std::string fifoError = loadError(fifo);
  done = true;
  unblock.join();
  CHECK(fifoError == fifo.string() + ": is a FIFO (named pipe), not a regular file: refusing to read it");
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 1);
  CHECK(loadError("/dev/zero") == "/dev/zero: is a character device, not a regular file: refusing to read it");
  CHECK(loadError(dir) == dir.string() + ": is a folder, not a scene file");
  CHECK(loadError(dir / "nope.json") == (dir / "nope.json").string() + ": no such file");
  // Over 64 MiB (sparse: no disk used): refused by its size.
  const fs::path big = tempFile("big-scene.json", "{}");
  fs::resize_file(big, (std::uintmax_t(64) << 20) + 1);
  CHECK(loadError(big).find(big.string() + ": is larger than 64 MiB (67108865 bytes)") == 0);
  fs::remove(big);
  // The same for a mesh: a FIFO as a body's mesh is named for what it is, by the loader and by loadMeshFile.
  const fs::path meshFifo = dir / "mesh-fifo.obj";
  fs::remove(meshFifo);
  REQUIRE(::mkfifo(meshFifo.c_str(), 0600) == 0);
  const std::string meshError = sceneErrorWithMesh(meshFifo);
  CAPTURE(meshError);
  CHECK(meshError.find("bodies[1].shape.file: " + meshFifo.string() + ": is a FIFO (named pipe)") != std::string::npos);
  CHECK(meshErrorOf(meshFifo) ==
        meshFifo.string() + ": is a FIFO (named pipe), not a regular file: refusing to read it");
  CHECK(meshErrorOf("/dev/zero").find("is a character device") != std::string::npos);
  // And a bump map's image.
  const std::string image = errorOf(mutate("\"resolution\": 128", "\"image\": \"/dev/zero\""));
  CHECK(image ==
        "bad.json: bodies[0].bump_map.image: /dev/zero: is a character device, not a regular file: refusing "
        "to read it");
  fs::remove(fifo);
  fs::remove(meshFifo);
}
