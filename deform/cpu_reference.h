// A CPU reference of the deformation (the tests' oracle): rays cast along -N
// through the centres of the address-map pixels, with the same camera, the
// same bump offsets and the same update as the GPU passes, but no rasteriser.
#pragma once
#include <glm/glm.hpp>

#include "physics/mesh.h"
#include "render/image.h"

namespace crumple::deform {

struct ReferenceBody {
  const TriangleMesh* mesh = nullptr;  // shape frame, with uvs
  glm::dmat4 model{1};
  const render::Image* height = nullptr;  // null: flat
  double bumpDepth = 0.1, bumpDepthCollide = 0.02;
};

// New height map of side X after one deformation (X advanced by `depth` along
// n minus the penetration, as in Deformer::deform). Texels not hit keep their value.
render::Image referenceDeform(const ReferenceBody& x, const ReferenceBody& other, const glm::dvec3& point,
                              const glm::dvec3& n, double penetration, double depth, int addressMap);

}  // namespace crumple::deform
