#version 450 core
// height_bound.comp: a level of height maps' bound pyramids over a region. Level 0 holds, per tile of
// uTile x uTile texels, the largest |h - 0.5| (how far the surface leaves the mesh, over k); each level above
// the largest of the 2 x 2 below. The renderer's parallax march reads it to skip rays over undented texels.
// Two uses: level 0 of each side of a commit group (workgroup z: entry uFirst + z, over its normalRegion; its
// height map uHeightMaps[z], its bound's level 0 uBounds[z]); or one map (uFull set) at level uLevel over
// uFullRegion (its height map uHeightMaps[0], its pyramid uBounds[0]). The levels lie side by side in one
// texture (boundOrigin).
// Level 0: one workgroup a bound texel, its 64 invocations sharing the tile's texels (a tile's 256 fetches in
// one invocation ran one after another: on a large GPU the commit's height bound was then latency, not work);
// the levels above: one invocation a texel, 8 x 8 a workgroup.
#include "commit_side.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) uniform sampler2D uHeightMaps[8];  // bindings::commit::kHeights
layout(r32f, binding = 0) uniform image2D uBounds[8];  // bindings::commit::kMaps
layout(std430, binding = 3) buffer NormalRegion { ivec4 uNormalRegion[]; };  // bindings::commit::kNormalRegion
uniform int uFull;
uniform ivec4 uFullRegion;
uniform int uFullResolution;
uniform int uLevel;  // with uFull
uniform int uTile;
shared uint sLargest;  // float bits of the tile's largest |h - 0.5| (>= 0: ordered as unsigned)
int gK;
float fetchHeight(ivec2 p) {
  float v = 0.0;
#define FETCH(i) v = texelFetch(uHeightMaps[i], p, 0).r
  switch (gK) { EACH8(FETCH) }
  return v;
}
int boundSize() {  // level 0's side: the texture's height
  int s = 0;
#define SIZE(i) s = imageSize(uBounds[i]).y
  switch (gK) { EACH8(SIZE) }
  return s;
}
void main() {
  gK = uFull != 0 ? 0 : int(gl_WorkGroupID.z);
  ivec4 r;
  int resolution, level = uFull != 0 ? uLevel : 0;
  if (uFull != 0) {
    r = uFullRegion;
    resolution = uFullResolution;
  } else {
    CommitEntry E = uEntry[uFirst + gK];
    r = uNormalRegion[E.slot];
    resolution = E.resolution;
  }
  // The same for every invocation of the workgroup: it returns whole, before the barriers.
  if (r.z < r.x || r.w < r.y) return;
  r = clamp(r, ivec4(0), ivec4(resolution - 1));
  int span = uTile << level;  // height texels per bound texel at this level
  if (level == 0) {
    ivec2 t = r.xy / span + ivec2(gl_WorkGroupID.xy);
    if (any(greaterThan(t, r.zw / span)) || any(greaterThanEqual(t, ivec2(boundSize())))) return;
    if (gl_LocalInvocationIndex == 0u) sLargest = 0u;
    barrier();
    ivec2 first = t * uTile, size = min(first + uTile, ivec2(resolution)) - first;
    float m = 0.0;
    for (int i = int(gl_LocalInvocationIndex); i < size.x * size.y; i += 64)
      m = max(m, abs(fetchHeight(first + ivec2(i % size.x, i / size.x)) - 0.5));
    atomicMax(sLargest, floatBitsToUint(m));
    barrier();
    if (gl_LocalInvocationIndex != 0u) return;
    vec4 v = vec4(uintBitsToFloat(sLargest));
#define STORE_BOUND(i) imageStore(uBounds[i], t, v)
    switch (gK) { EACH8(STORE_BOUND) }
    return;
  }
  // uFull: level uLevel from the level below.
  int S = imageSize(uBounds[0]).y;
  ivec2 t = r.xy / span + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThan(t, r.zw / span)) || any(greaterThanEqual(t, ivec2(S >> level)))) return;
  ivec2 below = boundOrigin(S, level - 1) + 2 * t;
  float m = 0.0;
  for (int k = 0; k < 4; ++k) m = max(m, imageLoad(uBounds[0], below + ivec2(k & 1, k >> 1)).r);
  imageStore(uBounds[0], boundOrigin(S, level) + t, vec4(m));
}
