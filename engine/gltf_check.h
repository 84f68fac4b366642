// Internal to engine/ (not installed): the checks of a glTF document before tinygltf reads it (gltf_check.cpp).
#pragma once
#include <string>
#include <vector>

namespace crumple::gltf {

// The JSON of a .gltf, or of a .glb's first chunk, checked for what tinygltf lets through silently: a negative
// byteOffset read as 0, a zero rotation, a scale of 1e30, a transform of the wrong length, nesting deep enough to
// overflow the stack. Throws MeshError naming the file and the document's key path.
void checkDocument(const std::vector<unsigned char>& bytes, bool binary, const std::string& path);

}  // namespace crumple::gltf
