#include <crumple/engine/gltf_export.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <tuple>

// The implementation is compiled once, in the mesh loader, with these settings: keep them the same here.
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include <crumple/engine/surface_bake.h>
#include <crumple/gl/image.h>

namespace crumple {

namespace fs = std::filesystem;

namespace {

// glTF's colour factors and COLOR_0 are linear; crumple's colours are sRGB.
double srgbToLinear(double c) {
  c = std::clamp(c, 0.0, 1.0);
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// A relative path as a URI reference: unreserved characters and '/' kept, the rest percent-encoded.
std::string uriOf(const std::string& path) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : path) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~' || c == '/') {
      out += static_cast<char>(c);
    } else {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

// Appends raw data to the buffer as one bufferView (4-byte aligned); returns the view's index.
int addView(tinygltf::Model& m, const void* data, size_t bytes, int target) {
  std::vector<unsigned char>& buf = m.buffers[0].data;
  while (buf.size() % 4) buf.push_back(0);
  tinygltf::BufferView v;
  v.buffer = 0;
  v.byteOffset = buf.size();
  v.byteLength = bytes;
  v.target = target;
  const auto* p = static_cast<const unsigned char*>(data);
  buf.insert(buf.end(), p, p + bytes);
  m.bufferViews.push_back(v);
  return static_cast<int>(m.bufferViews.size() - 1);
}

int addAccessor(tinygltf::Model& m, int view, int componentType, int type, size_t count) {
  tinygltf::Accessor a;
  a.bufferView = view;
  a.componentType = componentType;
  a.type = type;
  a.count = count;
  m.accessors.push_back(a);
  return static_cast<int>(m.accessors.size() - 1);
}

// The accessors of one render mesh (shared by every body that uses the same mesh).
struct MeshAccessors {
  int position = -1, normal = -1, tangent = -1, uv = -1, color = -1, indices = -1;
};

// Per vertex, glTF's TANGENT (xyz, w) from crumple's own tangent frame: the renderer shades with each triangle's
// dP/du and dP/dv (from screen-space derivatives), so a vertex takes the sum of its triangles' dP/du made normal
// to its normal, and w says on which side dP/dv lies. glTF's bitangent is cross(N, T) w and points up the image
// (decreasing v), the exported normal map's green being crumple's inverted: w = -1 where that cross product
// points along dP/dv.
std::vector<glm::vec4> tangents(const TriangleMesh& mesh, const std::vector<glm::vec3>& normals) {
  const size_t n = mesh.positions.size();
  std::vector<glm::dvec3> du(n, glm::dvec3(0)), dv(n, glm::dvec3(0));
  for (const glm::uvec3& t : mesh.triangles) {
    UvFrame frame;
    if (!uvFrame(mesh, t, frame)) continue;
    // dP/du and dP/dv, each weighted by the triangle's uv area: small slivers count little.
    const double area = std::abs(frame.det);
    for (unsigned v : {t.x, t.y, t.z}) {
      du[v] += frame.dPdu * area;
      dv[v] += frame.dPdv * area;
    }
  }
  std::vector<glm::vec4> out(n);
  for (size_t i = 0; i < n; ++i) {
    const glm::dvec3 nn(normals[i]);
    glm::dvec3 t = du[i] - nn * glm::dot(nn, du[i]);
    if (!(glm::length(t) > 1e-12)) {  // no uv gradient here: any direction normal to the normal
      t = glm::cross(nn, std::abs(nn.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0));
    }
    t = glm::normalize(t);
    const double w = glm::dot(glm::cross(nn, t), dv[i]) > 0 ? -1.0 : 1.0;
    out[i] = glm::vec4(glm::vec3(t), static_cast<float>(w));
  }
  return out;
}

MeshAccessors addMesh(tinygltf::Model& m, const TriangleMesh& mesh) {
  MeshAccessors r;
  const size_t n = mesh.positions.size();
  r.position = addAccessor(m, addView(m, mesh.positions.data(), n * sizeof(glm::vec3), TINYGLTF_TARGET_ARRAY_BUFFER),
                           TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  glm::vec3 lo = mesh.positions.empty() ? glm::vec3(0) : mesh.positions[0], hi = lo;
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  m.accessors[static_cast<size_t>(r.position)].minValues = {lo.x, lo.y, lo.z};
  m.accessors[static_cast<size_t>(r.position)].maxValues = {hi.x, hi.y, hi.z};
  if (mesh.normals.size() == n) {
    std::vector<glm::vec3> normals(n);
    for (size_t i = 0; i < n; ++i) {
      const float len = glm::length(mesh.normals[i]);
      normals[i] = len > 0 ? mesh.normals[i] / len : glm::vec3(0, 1, 0);  // glTF asks for unit normals
    }
    r.normal = addAccessor(m, addView(m, normals.data(), n * sizeof(glm::vec3), TINYGLTF_TARGET_ARRAY_BUFFER),
                           TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  }
  // crumple's (u, v) is glTF's: v = 0 at the image's first row (docs/maps.md), so no flip.
  if (mesh.uvs.size() == n)
    r.uv = addAccessor(m, addView(m, mesh.uvs.data(), n * sizeof(glm::vec2), TINYGLTF_TARGET_ARRAY_BUFFER),
                       TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, n);
  if (mesh.colors.size() == n) {
    std::vector<glm::vec3> linear(n);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) linear[i][c] = static_cast<float>(srgbToLinear(mesh.colors[i][c]));
    r.color = addAccessor(m, addView(m, linear.data(), n * sizeof(glm::vec3), TINYGLTF_TARGET_ARRAY_BUFFER),
                          TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
  }
  r.indices = addAccessor(
      m, addView(m, mesh.triangles.data(), mesh.triangles.size() * sizeof(glm::uvec3), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
      TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, mesh.triangles.size() * 3);
  return r;
}

double linearToSrgb(double c) {
  return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}

// An image written into the export (<folder>/<file>, 8 bits a channel), as a texture with the sampler 0; its index.
int addTexture(tinygltf::Model& m, const fs::path& root, const std::string& folder, const std::string& file,
               const gl::Image& image, const std::string& name) {
  fs::create_directories(root / folder);
  gl::writePng((root / folder / file).string(), image, 8);
  tinygltf::Image img;
  img.name = name;
  img.uri = uriOf(folder + "/" + file);
  img.mimeType = "image/png";
  m.images.push_back(img);
  tinygltf::Texture tex;
  tex.source = static_cast<int>(m.images.size() - 1);
  tex.sampler = 0;
  m.textures.push_back(tex);
  return static_cast<int>(m.textures.size() - 1);
}

// The body's surface baked at size x size: its base colour and metallic-roughness textures (their indices).
std::pair<int, int> bakeTextures(tinygltf::Model& m, const fs::path& root, const BodyRuntime& b, const Material& sm,
                                 int size) {
  const glm::vec3 linear(static_cast<float>(srgbToLinear(sm.color.r)), static_cast<float>(srgbToLinear(sm.color.g)),
                         static_cast<float>(srgbToLinear(sm.color.b)));
  const BakedSurface baked =
      bakeSurface(*b.mesh, size, surfaceTextureNamed(sm.texture), sm.textureScale, linear, sm.roughness);
  gl::Image base(size, size, 3), mr(size, size, 3);
  for (size_t i = 0; i < baked.color.size(); ++i) {
    for (int c = 0; c < 3; ++c)
      base.pixels[3 * i + static_cast<size_t>(c)] =
          static_cast<float>(linearToSrgb(std::clamp(static_cast<double>(baked.color[i][c]), 0.0, 1.0)));
    mr.pixels[3 * i + 1] = baked.roughness[i];  // glTF: roughness in green, metallic in blue
    mr.pixels[3 * i + 2] = sm.metallic;
  }
  return {addTexture(m, root, "textures", b.name + "_base.png", base, b.name + "_base"),
          addTexture(m, root, "textures", b.name + "_metallic_roughness.png", mr, b.name + "_metallic_roughness")};
}

// The textures baked for a mesh, material and size: bodies that share all three share them (base colour,
// metallic-roughness).
using BakedTextures = std::map<std::tuple<const TriangleMesh*, const Material*, int>, std::pair<int, int>>;

// A procedural surface (asphalt, concrete, clay) baked into the body's atlas: the base colour (sRGB) and
// metallic-roughness textures, at the body's map resolution (256 without a map), their factors 1.
void bakeLook(tinygltf::Model& m, tinygltf::Material& mat, const fs::path& root, const BodyRuntime& b,
              const Material& sm, BakedTextures& baked) {
  const int size = b.surface ? b.surface->resolution() : 256;
  auto [kept, fresh] = baked.try_emplace({b.mesh.get(), &sm, size}, -1, -1);
  if (fresh) kept->second = bakeTextures(m, root, b, sm, size);
  mat.pbrMetallicRoughness.baseColorTexture.index = kept->second.first;
  mat.pbrMetallicRoughness.baseColorTexture.texCoord = 0;
  mat.pbrMetallicRoughness.baseColorFactor = {1.0, 1.0, 1.0, 1.0};
  mat.pbrMetallicRoughness.metallicRoughnessTexture.index = kept->second.second;
  mat.pbrMetallicRoughness.metallicRoughnessTexture.texCoord = 0;
  mat.pbrMetallicRoughness.metallicFactor = 1.0;
  mat.pbrMetallicRoughness.roughnessFactor = 1.0;
}

// The vehicles' parts (wheels, belts, grousers) in their body's frame, and whose body (in Simulation::bodies())
// each is on.
std::vector<VehiclePart> localParts(const Simulation& sim, std::vector<int>* owners = nullptr) {
  std::vector<VehiclePart> parts;
  for (const VehicleRuntime& v : sim.vehicles()) {
    const size_t first = parts.size();
    addVehicleParts(v, glm::dmat4(1), parts);
    if (owners) owners->insert(owners->end(), parts.size() - first, v.body);
  }
  return parts;
}

// A rigid transform as a pose (the parts' transforms turn and move, never scale).
Pose poseOf(const glm::dmat4& m) { return {glm::dvec3(m[3]), glm::normalize(glm::quat_cast(glm::dmat3(m)))}; }

// Material fields another part of crumple may add (metallic, roughness): used when the struct has them.
template <class M>
void setPbr(tinygltf::Material& out, const M& mat) {
  if constexpr (requires { mat.metallic; }) out.pbrMetallicRoughness.metallicFactor = mat.metallic;
  if constexpr (requires { mat.roughness; }) out.pbrMetallicRoughness.roughnessFactor = mat.roughness;
}

}  // namespace

void GltfAnimation::record(const Simulation& sim) {
  const auto& bodies = sim.bodies();
  poses.resize(bodies.size());
  times.push_back(sim.world().time());
  for (size_t i = 0; i < bodies.size(); ++i) {
    const RigidBody& rb = sim.world().body(bodies[i].index);
    poses[i].push_back({rb.origin(), rb.q});
  }
  const std::vector<VehiclePart> now = localParts(sim);
  parts.resize(now.size());
  for (size_t k = 0; k < now.size(); ++k) parts[k].push_back(poseOf(now[k].model));
}

namespace {
// The animation "run": per moving body a translation and a rotation channel over the recorded times.
void addAnimation(tinygltf::Model& m, const Simulation& sim, const GltfAnimation& a) {
  const size_t frames = a.times.size();
  std::vector<float> times(frames);
  for (size_t f = 0; f < frames; ++f) times[f] = static_cast<float>(a.times[f]);
  const int input = addAccessor(m, addView(m, times.data(), frames * sizeof(float), 0), TINYGLTF_COMPONENT_TYPE_FLOAT,
                                TINYGLTF_TYPE_SCALAR, frames);
  m.accessors[static_cast<size_t>(input)].minValues = {times.front()};
  m.accessors[static_cast<size_t>(input)].maxValues = {times.back()};
  tinygltf::Animation anim;
  anim.name = "run";
  const auto& bodies = sim.bodies();
  // A node's translation and rotation channels through `poses` (one a frame).
  auto animate = [&](int node, const std::vector<Pose>& poses) {
    std::vector<glm::vec3> translation(frames);
    std::vector<glm::vec4> rotation(frames);  // glTF: x, y, z, w
    glm::dquat last = poses.front().orientation;
    for (size_t f = 0; f < frames; ++f) {
      translation[f] = glm::vec3(poses[f].position);
      // The same hemisphere as the frame before: the viewer's slerp then turns the short way, as the body did.
      glm::dquat q = poses[f].orientation;
      if (glm::dot(q, last) < 0) q = -q;
      last = q;
      rotation[f] = glm::vec4(static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z),
                              static_cast<float>(q.w));
    }
    auto channel = [&](const void* data, size_t bytes, int type, const char* path) {
      tinygltf::AnimationSampler sampler;
      sampler.input = input;
      sampler.output = addAccessor(m, addView(m, data, bytes, 0), TINYGLTF_COMPONENT_TYPE_FLOAT, type, frames);
      sampler.interpolation = "LINEAR";
      anim.samplers.push_back(sampler);
      tinygltf::AnimationChannel c;
      c.sampler = static_cast<int>(anim.samplers.size() - 1);
      c.target_node = node;
      c.target_path = path;
      anim.channels.push_back(c);
    };
    channel(translation.data(), frames * sizeof(glm::vec3), TINYGLTF_TYPE_VEC3, "translation");
    channel(rotation.data(), frames * sizeof(glm::vec4), TINYGLTF_TYPE_VEC4, "rotation");
  };
  // The nodes are the bodies, in order, then the vehicles' parts (addParts).
  for (size_t i = 0; i < bodies.size() && i < a.poses.size(); ++i)
    if (!sim.world().body(bodies[i].index).isStatic && a.poses[i].size() == frames)
      animate(static_cast<int>(i), a.poses[i]);
  for (size_t k = 0; k < a.parts.size(); ++k)
    if (a.parts[k].size() == frames) animate(static_cast<int>(bodies.size() + k), a.parts[k]);
  if (!anim.channels.empty()) m.animations.push_back(anim);
}
}  // namespace

namespace {
// The vehicles' wheels, belts and grousers: each a node under its body's node (node of body i: i), at its pose on
// the body, with its mesh and a plain material of its colour (rubber, dull metal).
void addParts(tinygltf::Model& m, const Simulation& sim, std::map<const TriangleMesh*, MeshAccessors>& meshes) {
  std::vector<int> owners;
  const std::vector<VehiclePart> parts = localParts(sim, &owners);
  std::map<std::string, int> counts;
  for (size_t k = 0; k < parts.size(); ++k) {
    const VehiclePart& part = parts[k];
    const std::string& body = sim.bodies()[static_cast<size_t>(owners[k])].name;
    const std::string name = body + "_" + part.kind + std::to_string(counts[body + part.kind]++);
    auto it = meshes.find(part.shape);
    if (it == meshes.end()) it = meshes.emplace(part.shape, addMesh(m, *part.shape)).first;
    tinygltf::Material mat;
    mat.name = name;
    mat.pbrMetallicRoughness.baseColorFactor = {srgbToLinear(part.color.r), srgbToLinear(part.color.g),
                                                srgbToLinear(part.color.b), 1.0};
    mat.pbrMetallicRoughness.metallicFactor = 0.0;
    mat.pbrMetallicRoughness.roughnessFactor = 0.85;
    m.materials.push_back(mat);
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.indices = it->second.indices;
    prim.material = static_cast<int>(m.materials.size() - 1);
    prim.attributes["POSITION"] = it->second.position;
    if (it->second.normal >= 0) prim.attributes["NORMAL"] = it->second.normal;
    tinygltf::Mesh mesh;
    mesh.name = name;
    mesh.primitives.push_back(prim);
    m.meshes.push_back(mesh);
    tinygltf::Node node;
    node.name = name;
    node.mesh = static_cast<int>(m.meshes.size() - 1);
    const Pose pose = poseOf(part.model);
    node.translation = {pose.position.x, pose.position.y, pose.position.z};
    node.rotation = {pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w};
    m.nodes.push_back(node);
    m.nodes[static_cast<size_t>(owners[k])].children.push_back(static_cast<int>(m.nodes.size() - 1));
  }
}
}  // namespace

void writeGltfExport(const Simulation& sim, const std::string& dir, const std::string& mapsRoot,
                     const GltfAnimation* animation) {
  const fs::path root(dir), maps(mapsRoot);
  std::error_code ec;
  fs::create_directories(root, ec);
  if (ec) throw std::runtime_error(dir + ": cannot create the export folder: " + ec.message());

  tinygltf::Model m;
  m.asset.version = "2.0";
  m.asset.generator = "crumple-sim";
  m.buffers.emplace_back();
  m.buffers[0].uri = "scene.bin";
  tinygltf::Sampler sampler;  // the maps: linear, clamped (the atlas's gutters are outside every chart)
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
  sampler.wrapS = sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  m.samplers.push_back(sampler);

  std::map<const TriangleMesh*, MeshAccessors> meshes;
  BakedTextures baked;
  tinygltf::Scene scene;
  scene.name = sim.scene().name;
  for (const BodyRuntime& b : sim.bodies()) {
    const RigidBody& rb = sim.world().body(b.index);
    tinygltf::Node node;
    node.name = b.name;
    const glm::dvec3 o = rb.origin();
    node.translation = {o.x, o.y, o.z};
    node.rotation = {rb.q.x, rb.q.y, rb.q.z, rb.q.w};  // glTF: x, y, z, w

    if (b.mesh && !b.mesh->empty()) {
      auto it = meshes.find(b.mesh.get());
      if (it == meshes.end()) it = meshes.emplace(b.mesh.get(), addMesh(m, *b.mesh)).first;
      MeshAccessors& acc = it->second;

      tinygltf::Material mat;
      mat.name = b.name;
      const Material* sm = b.material;
      const glm::vec3 color = sm ? sm->color : glm::vec3(0.7f);
      mat.pbrMetallicRoughness.baseColorFactor = {srgbToLinear(color.r), srgbToLinear(color.g),
                                                  srgbToLinear(color.b), 1.0};
      mat.pbrMetallicRoughness.metallicFactor = 0.0;
      mat.pbrMetallicRoughness.roughnessFactor = 0.6;
      if (sm) setPbr(mat, *sm);
      tinygltf::Value::Object extras;
      if (sm) extras["crumple_material"] = tinygltf::Value(sm->name);
      if (sm && acc.uv >= 0 && surfaceTextureNamed(sm->texture) != render::SurfaceTexture::None)
        bakeLook(m, mat, root, b, *sm, baked);
      if (b.surface && acc.uv >= 0) {
        const std::string file = b.name + ".png";
        // The height map as written to the output folder: 16-bit grey, 0.5 flat (docs/maps.md).
        fs::create_directories(root / "heightmaps");
        fs::copy_file(maps / "heightmaps" / file, root / "heightmaps" / file, fs::copy_options::overwrite_existing, ec);
        if (ec) throw std::runtime_error((root / "heightmaps" / file).string() + ": " + ec.message());
        // The normal map with green inverted: crumple's green points down the image, glTF's up.
        gl::Image nm = gl::readPng((maps / "normalmaps" / file).string(), 3);
        for (size_t i = 1; i < nm.pixels.size(); i += 3) nm.pixels[i] = 1.0f - nm.pixels[i];
        mat.normalTexture.index = addTexture(m, root, "normalmaps", file, nm, b.name + "_normal");
        mat.normalTexture.texCoord = 0;
        // Its tangent frame, once per mesh that carries a normal map (a viewer would make up its own otherwise).
        const TriangleMesh& mesh = *b.mesh;
        if (acc.tangent < 0 && mesh.normals.size() == mesh.positions.size()) {
          std::vector<glm::vec3> normals(mesh.normals);
          for (glm::vec3& nn : normals) nn = glm::length(nn) > 0 ? glm::normalize(nn) : glm::vec3(0, 1, 0);
          const std::vector<glm::vec4> t = tangents(mesh, normals);
          acc.tangent = addAccessor(m, addView(m, t.data(), t.size() * sizeof(glm::vec4), TINYGLTF_TARGET_ARRAY_BUFFER),
                                    TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, t.size());
        }
        extras["crumple_height_map"] = tinygltf::Value("heightmaps/" + file);
        // k in metres, from its float: rounded to 7 digits so that 0.1 reads 0.1.
        const double k = b.surface->bumpDepth();
        const double scale = std::pow(10.0, 6 - std::floor(std::log10(std::max(k, 1e-30))));
        extras["bump_depth"] = tinygltf::Value(std::round(k * scale) / scale);
      }
      mat.extras = tinygltf::Value(extras);
      m.materials.push_back(mat);

      tinygltf::Primitive prim;
      prim.mode = TINYGLTF_MODE_TRIANGLES;
      prim.indices = acc.indices;
      prim.material = static_cast<int>(m.materials.size() - 1);
      prim.attributes["POSITION"] = acc.position;
      if (acc.normal >= 0) prim.attributes["NORMAL"] = acc.normal;
      if (acc.tangent >= 0 && mat.normalTexture.index >= 0) prim.attributes["TANGENT"] = acc.tangent;
      if (acc.uv >= 0) prim.attributes["TEXCOORD_0"] = acc.uv;
      if (acc.color >= 0) prim.attributes["COLOR_0"] = acc.color;
      tinygltf::Mesh mesh;
      mesh.name = b.name;
      mesh.primitives.push_back(prim);
      m.meshes.push_back(mesh);
      node.mesh = static_cast<int>(m.meshes.size() - 1);
    }
    m.nodes.push_back(node);
    scene.nodes.push_back(static_cast<int>(m.nodes.size() - 1));
  }
  addParts(m, sim, meshes);
  m.scenes.push_back(scene);
  m.defaultScene = 0;
  if (animation && animation->times.size() >= 2) addAnimation(m, sim, *animation);
  if (m.buffers[0].data.empty()) {  // no meshes at all: no buffer (glTF forbids empty ones)
    m.buffers.clear();
  }

  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToFile(&m, (root / "scene.gltf").string(), /*embedImages=*/false,
                                   /*embedBuffers=*/false, /*prettyPrint=*/true, /*writeBinary=*/false))
    throw std::runtime_error((root / "scene.gltf").string() + ": writing the glTF export failed");
}

}  // namespace crumple
