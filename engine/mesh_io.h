// Mesh files: glTF 2.0 / GLB through tinygltf (all primitives of the default
// scene, node transforms applied, merged into one mesh), OBJ, OFF and PLY by our own
// strict readers. Broken files are MeshError, never a crash.
// Every format refuses coordinates beyond 1e30 and meshes of over 4194304 triangles (engine/mesh_io_detail.h).
#pragma once
#include <stdexcept>
#include <string>

#include "physics/mesh.h"

namespace crumple {

struct MeshError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

TriangleMesh loadMeshFile(const std::string& path);
TriangleMesh loadGltf(const std::string& path);
TriangleMesh loadObj(const std::string& path);  // strict: errors name the line
TriangleMesh loadOff(const std::string& path);  // strict: errors name the line or the byte
TriangleMesh loadPly(const std::string& path);  // strict: errors name the header line or the record

}  // namespace crumple
