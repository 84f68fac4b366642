// What bodies are built from, loaded once and shared: physics shapes, render
// meshes with a checked one-to-one atlas (generated when a file's is missing or
// broken), their GPU copies, and undented surface maps (lazy maps: bodies of one
// mesh share them until their first dent).
#pragma once
#include <map>
#include <memory>
#include <string>

#include <crumple/deform/deformer.h>
#include <crumple/deform/surface.h>
#include <crumple/engine/scene.h>
#include <crumple/physics/shape.h>
#include <crumple/gl/image.h>
#include <crumple/render/look.h>

namespace crumple {

// One body's assets. `where` (e.g. "bodies[3]") and the scene's file name go into errors.
struct BodyAssets {
  std::shared_ptr<const Shape> shape;
  std::shared_ptr<const TriangleMesh> mesh;  // render mesh, shape frame, one-to-one uvs
  int mapResolution = 256;                   // the bump map's (its image's when it has one)
  gl::Image initialMap;                  // the bump map's image, when it has one
  bool hasImage = false;
  std::string meshKey;  // shape and map resolution: what the render mesh depends on
  std::shared_ptr<const render::Look> look;  // the mesh file's own materials (glTF), null when it has none
};

class AssetCache {
 public:
  explicit AssetCache(std::string sceneFile) : sceneFile_(std::move(sceneFile)) {}
  // Throws SceneError naming `where` and the key at fault.
  BodyAssets load(const BodyDesc& desc, const std::string& where);
  std::shared_ptr<const deform::GpuMesh> gpuMesh(const BodyAssets& a);
  // The look's textures, uploaded once per mesh file; null when the mesh has no look.
  std::shared_ptr<const render::GpuLook> gpuLook(const BodyAssets& a);
  // The body's surface: its own maps from its image, or maps shared by every undented body of the
  // same mesh and bump depth (`lazy`), or maps of its own.
  std::unique_ptr<deform::Surface> surface(const BodyAssets& a, std::shared_ptr<const deform::GpuMesh> mesh, float k,
                                           float kCollide, bool lazy, deform::Deformer& deformer);

 private:
  std::string sceneFile_;
  std::map<std::string, std::shared_ptr<const Shape>> shapes_;
  std::map<std::string, std::shared_ptr<const TriangleMesh>> meshes_;
  std::map<std::string, std::shared_ptr<const deform::GpuMesh>> gpuMeshes_;
  std::map<std::string, std::shared_ptr<const render::Look>> looks_;
  std::map<const render::Look*, std::shared_ptr<const render::GpuLook>> gpuLooks_;
  std::map<std::string, std::shared_ptr<deform::SurfaceMaps>> maps_;
};

}  // namespace crumple
