// The procedural surfaces of the renderer (asphalt, concrete, clay: pom.frag's surfaceTexture) on the CPU, the
// same value noise and octaves in float arithmetic: what engine/surface_bake.h bakes into an export's textures.
#pragma once
#include <glm/glm.hpp>

#include <crumple/render/renderer.h>

namespace crumple::render {

// At q (metres in the mesh's frame over the texture's scale) with `footprint` (its units a texel or pixel
// spans: octaves finer than about two of them fade to their mean): x multiplies the linear albedo (about 1 on
// average), y is added to the roughness.
glm::vec2 surfaceTexture(SurfaceTexture texture, const glm::vec3& q, float footprint);

}  // namespace crumple::render
