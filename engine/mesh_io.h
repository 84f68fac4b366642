// Mesh files: glTF 2.0 / GLB through tinygltf (all primitives of the default
// scene, node transforms applied, merged into one mesh), OBJ, OFF and PLY by our own
// strict readers. Broken files are MeshError, never a crash.
// Every format refuses coordinates beyond 1e30 and meshes of over 4194304 triangles (engine/mesh_io_detail.h).
#pragma once
#include <stdexcept>
#include <string>

#include <crumple/physics/mesh.h>

namespace crumple {
namespace render {
struct Look;
}

struct MeshError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// With `look`, a glTF file's materials and images are read into it as well (empty for other formats, and for a
// glTF whose primitives have no material), and the mesh gains materialUvs and materialIds.
TriangleMesh loadMeshFile(const std::string& path, render::Look* look = nullptr);
TriangleMesh loadGltf(const std::string& path, render::Look* look = nullptr);
TriangleMesh loadObj(const std::string& path);  // strict: errors name the line
TriangleMesh loadOff(const std::string& path);  // strict: errors name the line or the byte
TriangleMesh loadPly(const std::string& path);  // strict: errors name the header line or the record

}  // namespace crumple
