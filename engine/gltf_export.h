// crumple-sim --export gltf: the end state of a run as a glTF 2.0 scene (docs/outputs.md, "export/").
#pragma once
#include <string>

#include <crumple/engine/simulation.h>

namespace crumple {

// Writes `dir`/scene.gltf and scene.bin, with every body as a node at its final pose
// (translation: the shape frame's origin, as summary.json's `position`; rotation: its orientation),
// one mesh per body (crumple's render mesh in the shape frame, its atlas as TEXCOORD_0) and one
// material per body (base colour, metallic, roughness; the normal map as normalTexture, green
// inverted to glTF's convention; the height map in the material's extras).
// The maps are taken from `mapsRoot`/heightmaps/<body>.png and `mapsRoot`/normalmaps/<body>.png (as
// OutputWriter writes them) and written to `dir`/heightmaps/ and `dir`/normalmaps/.
// Throws std::runtime_error when a file cannot be written.
void writeGltfExport(const Simulation& sim, const std::string& dir, const std::string& mapsRoot);

}  // namespace crumple
