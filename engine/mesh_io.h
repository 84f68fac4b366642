// Mesh files: glTF 2.0 / GLB through tinygltf (all primitives of the default
// scene, node transforms applied, merged into one mesh) and OBJ / OFF / PLY
// through OpenMesh. Broken files are MeshError, never a crash.
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
TriangleMesh loadWithOpenMesh(const std::string& path);

}  // namespace crumple
