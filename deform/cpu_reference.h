// A CPU reference of the deformation (the tests' oracle), per texel: every
// texel of X whose centre lies on a triangle facing the deformation camera
// takes its surface point (raised or lowered by its height, k'), and an exact
// ray along -N through that point finds the other body's farthest back face
// (with its bumps); where that lies beyond the point, the texel drops by the
// depth between them, as the default (gather) path computes it. Same camera,
// same offsets, same update; no rasteriser and no address map.
#pragma once
#include <glm/glm.hpp>

#include <crumple/physics/mesh.h>
#include <crumple/gl/image.h>

namespace crumple::deform {

struct ReferenceBody {
  const TriangleMesh* mesh = nullptr;  // shape frame, with uvs
  glm::dmat4 model{1};
  const gl::Image* height = nullptr;  // null: flat
  double bumpDepth = 0.1, bumpDepthCollide = 0.02;
};

// New height map of side X after one deformation (X advanced by `depth` along
// n minus the penetration, as in Deformer::deform; no texel cut deeper than `depth` and the bumps' reach along
// n, as DeformRequest::boundByDepth). Texels not hit keep their value.
gl::Image referenceDeform(const ReferenceBody& x, const ReferenceBody& other, const glm::dvec3& point,
                              const glm::dvec3& n, double penetration, double depth);

}  // namespace crumple::deform
