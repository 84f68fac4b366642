// crumple-sim --export gltf: the end state of a run as a glTF 2.0 scene (docs/outputs.md, "export/").
#pragma once
#include <string>
#include <vector>

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
// The bodies' motion for an animated export (crumple-sim --export gltf --animate): their poses at `times` (s),
// one vector per body of bodies() per time, taken with record().
struct GltfAnimation {
  std::vector<double> times;
  std::vector<std::vector<Pose>> poses;  // [body][frame]: the shape frame's origin and the orientation
  std::vector<std::vector<Pose>> parts;  // [vehicle part][frame]: a wheel's, belt's or grousers' pose on its body
  void record(const Simulation& sim);    // the poses now, at the world's time
};

// With `animation` (two frames or more): one glTF animation, "run", moving every body that is not static through
// its recorded poses (LINEAR translation and rotation channels at the recorded times), so a viewer plays the run.
void writeGltfExport(const Simulation& sim, const std::string& dir, const std::string& mapsRoot,
                     const GltfAnimation* animation = nullptr);

}  // namespace crumple
