#version 450 core
// normal_map.comp: tangent-space normals from the height map by central differences, over a region: the texels
// a dent touched, grown by one (each side of a commit group: workgroup z, entry uFirst + z, its normalRegion), or
// uFullRegion of one map when uFull is set (map 0 of the arrays).
//   n = normalize(-dh/du * k / texel, -dh/dv * k / texel, 1), stored as n * 0.5 + 0.5
// in:  uHeightMaps[z]; out: uNormals[z] (rgba8)
#include "commit_side.glsl"
layout(local_size_x = 16, local_size_y = 16) in;
layout(binding = 0) uniform sampler2D uHeightMaps[8];  // bindings::commit::kHeights
layout(rgba8, binding = 0) uniform writeonly image2D uNormals[8];  // bindings::commit::kMaps
layout(std430, binding = 3) buffer NormalRegion { ivec4 uNormalRegion[]; };  // bindings::commit::kNormalRegion
uniform int uFull;
uniform ivec4 uFullRegion;
uniform int uFullResolution;
uniform float uFullSlopeScale;
int gK, gResolution;
float h(ivec2 p) {
  p = clamp(p, ivec2(0), ivec2(gResolution - 1));
  float v = 0.0;
#define FETCH(i) v = texelFetch(uHeightMaps[i], p, 0).r
  switch (gK) { EACH8(FETCH) }
  return v;
}
void main() {
  gK = int(gl_WorkGroupID.z);
  ivec4 r;
  float slopeScale;
  if (uFull != 0) {
    r = uFullRegion;
    gResolution = uFullResolution;
    slopeScale = uFullSlopeScale;
  } else {
    CommitEntry E = uEntry[uFirst + gK];
    r = uNormalRegion[E.slot];
    gResolution = E.resolution;
    slopeScale = E.slopeScale;
  }
  if (r.z < r.x || r.w < r.y) return;
  ivec2 p = r.xy + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThan(p, r.zw))) return;
  float dx = (h(p + ivec2(1, 0)) - h(p - ivec2(1, 0))) * slopeScale;
  float dy = (h(p + ivec2(0, 1)) - h(p - ivec2(0, 1))) * slopeScale;
  vec4 n = vec4(normalize(vec3(-dx, -dy, 1.0)) * 0.5 + 0.5, 1.0);
#define STORE_NORMAL(i) imageStore(uNormals[i], p, n)
  switch (gK) { EACH8(STORE_NORMAL) }
}
