// Mesh files: glTF 2.0 / GLB through tinygltf (all primitives of the default
// scene, node transforms applied, merged into one mesh), OBJ by our own strict
// reader, OFF / PLY through OpenMesh. Broken files are MeshError, never a crash.
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
TriangleMesh loadObj(const std::string& path);           // strict: errors name the line
TriangleMesh loadWithOpenMesh(const std::string& path);  // OFF and PLY

}  // namespace crumple
