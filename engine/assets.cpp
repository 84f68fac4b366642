#include <crumple/engine/assets.h>

#include <filesystem>
#include <sstream>

#include <crumple/engine/atlas.h>
#include <crumple/engine/mesh_io.h>
#include <crumple/engine/primitives.h>
#include <crumple/core/log.h>

namespace crumple {

namespace fs = std::filesystem;

namespace {
std::string shapeKey(const ShapeDesc& s) {
  std::ostringstream os;
  os.precision(17);
  if (s.type == "box")
    os << "box:" << s.size.x << "," << s.size.y << "," << s.size.z;
  else if (s.type == "sphere")
    os << "sphere:" << s.radius;
  else if (s.type == "mesh")
    os << "mesh:" << s.file << "|" << s.scale.x << "," << s.scale.y << "," << s.scale.z;
  else
    os << s.type << ":" << s.radius << "," << s.height;
  return os.str();
}
}  // namespace

BodyAssets AssetCache::load(const BodyDesc& d, const std::string& where) {
  const int res = d.bumpMap.present ? d.bumpMap.resolution : 256;
  BodyAssets out;
  gl::Image& initial = out.initialMap;
  bool& hasImage = out.hasImage;
  if (d.bumpMap.present && !d.bumpMap.image.empty()) {
    try {
      initial = gl::readPng(d.bumpMap.image, 1);
    } catch (const gl::ImageError& e) {
      throw SceneError(sceneFile_, where + ".bump_map.image", e.what());
    }
    if (initial.width != initial.height)
      throw SceneError(sceneFile_, where + ".bump_map.image",
                       "must be square, got " + std::to_string(initial.width) + "x" + std::to_string(initial.height));
    if (initial.width < 8 || initial.width > 4096)
      throw SceneError(sceneFile_, where + ".bump_map.image", "size must be in [8, 4096]");
    hasImage = true;
  }
  const int mapRes = out.mapResolution = hasImage ? initial.width : res;
  const std::string key = shapeKey(d.shape);
  const std::string meshKey = out.meshKey = key + "|" + std::to_string(mapRes);

  // Physics shape, shared between bodies of one shape.
  std::shared_ptr<const Shape> shape;
  std::shared_ptr<const TriangleMesh> mesh;
  if (auto it = meshes_.find(meshKey); it != meshes_.end()) mesh = it->second;
  try {
    if (auto it = shapes_.find(key); it != shapes_.end()) shape = it->second;
    const ShapeDesc& s = d.shape;
    if (s.type == "box") {
      if (!shape) shape = makeBox(s.size);
      if (!mesh) mesh = std::make_shared<TriangleMesh>(boxMesh(s.size, mapRes));
    } else if (s.type == "sphere") {
      if (!shape) shape = makeSphere(s.radius);
      if (!mesh) mesh = std::make_shared<TriangleMesh>(sphereMesh(s.radius, mapRes));
    } else if (s.type == "capsule") {
      if (!shape) shape = makeCapsule(s.radius, s.height);
      if (!mesh) mesh = std::make_shared<TriangleMesh>(capsuleMesh(s.radius, s.height, mapRes));
    } else if (s.type == "cylinder") {
      if (!shape) shape = makeCylinder(s.radius, s.height);
      if (!mesh) mesh = std::make_shared<TriangleMesh>(cylinderMesh(s.radius, s.height, mapRes));
    } else {
      TriangleMesh m;
      render::Look look;
      try {
        m = loadMeshFile(s.file, &look);
      } catch (const MeshError& e) {
        throw SceneError(sceneFile_, where + ".shape.file", e.what());
      }
      for (auto& p : m.positions) p *= glm::vec3(s.scale);
      for (auto& n : m.normals) n = glm::normalize(n / glm::vec3(s.scale));
      const double volume = polyhedralMassProperties(m).volume;
      if (volume < 0) {
        logWarning(where, " (", d.name, "): ", s.file, " is inside out: flipped its triangles");
        for (auto& t : m.triangles) std::swap(t.y, t.z);
        for (auto& n : m.normals) n = -n;
      }
      if (!mesh) {
        const AtlasCheck check = checkAtlas(m, mapRes);
        if (!check.oneToOne) {
          std::string why = check.missing             ? "has no texture coordinates"
                            : check.overlappingTexels ? std::to_string(check.overlappingTexels) + " texels used twice"
                            : check.outsideTriangles
                                ? std::to_string(check.outsideTriangles) + " triangles outside [0,1]"
                                : std::to_string(check.collapsedTriangles) + " triangles with no texture area";
          m = generateAtlas(m, mapRes);
          logInfo(where, " (", d.name, "): ", fs::path(s.file).filename().string(), " ", why,
                  ": generated an automatic one-to-one atlas");
        }
        mesh = std::make_shared<TriangleMesh>(std::move(m));
      }
      if (!look.empty() && !looks_.count(key)) looks_[key] = std::make_shared<const render::Look>(std::move(look));
      if (!shape) shape = makeMeshShape(*mesh);
    }
  } catch (const std::invalid_argument& e) {
    throw SceneError(sceneFile_, where + ".shape", e.what());
  }
  shapes_[key] = shape;
  meshes_[meshKey] = mesh;
  out.shape = shape;
  out.mesh = mesh;
  if (auto it = looks_.find(key); it != looks_.end()) out.look = it->second;
  return out;
}

std::shared_ptr<const deform::GpuMesh> AssetCache::gpuMesh(const BodyAssets& a) {
  auto& g = gpuMeshes_[a.meshKey];
  if (!g) g = std::make_shared<deform::GpuMesh>(*a.mesh);
  return g;
}

std::shared_ptr<const render::GpuLook> AssetCache::gpuLook(const BodyAssets& a) {
  if (!a.look) return nullptr;
  auto& g = gpuLooks_[a.look.get()];
  if (!g) g = std::make_shared<const render::GpuLook>(*a.look);
  return g;
}

std::unique_ptr<deform::Surface> AssetCache::surface(const BodyAssets& a, std::shared_ptr<const deform::GpuMesh> g,
                                                     float k, float kc, bool lazy, deform::Deformer& deformer) {
  const int mapRes = a.mapResolution;
  const float texel = static_cast<float>(g->metresPerUv / mapRes);
  std::shared_ptr<deform::SurfaceMaps> maps;
  if (a.hasImage) {
    maps = deformer.createMaps(mapRes, &a.initialMap, k, texel);
  } else if (lazy) {
    auto& shared = maps_[a.meshKey + "|" + std::to_string(k)];
    if (!shared) shared = deformer.createMaps(mapRes, nullptr, k, texel);
    maps = shared;
  } else {
    maps = deformer.createMaps(mapRes, nullptr, k, texel);
  }
  return std::make_unique<deform::Surface>(std::move(g), mapRes, k, kc, maps);
}

}  // namespace crumple
