#version 450 core
// height_bound.comp: one level of a height map's bound pyramid over a region. Level 0 holds, per tile of
// uTile x uTile texels, the largest |h - 0.5| (how far the surface leaves the mesh, over k); each level above
// the largest of the 2 x 2 below. The renderer's parallax march reads it to skip rays over undented texels.
// Level 0: one workgroup a bound texel, its 64 invocations sharing the tile's texels (a tile's 256 fetches in
// one invocation ran one after another: on a large GPU the commit's height bound was then latency, not work);
// the levels above: one invocation a texel, 8 x 8 a workgroup.
// in:  uHeight (level 0), uBelow (level uLevel - 1), the region in height texels: uRegion[uSide] (the commit's,
//      on the GPU) or uFullRegion when uSide < 0; out: uBound at uLevel
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) uniform sampler2D uHeight;
layout(r32f, binding = 1) uniform writeonly image2D uBound;
layout(r32f, binding = 2) uniform readonly image2D uBelow;
layout(std430, binding = 3) buffer Region { ivec4 uRegion[]; };
uniform int uSide;
uniform ivec4 uFullRegion;
uniform int uLevel;
uniform int uTile;
uniform int uResolution;
shared uint sLargest;  // float bits of the tile's largest |h - 0.5| (>= 0: ordered as unsigned)
void main() {
  ivec4 r = uSide >= 0 ? uRegion[uSide] : uFullRegion;
  r = clamp(r, ivec4(0), ivec4(uResolution - 1));
  int span = uTile << uLevel;  // height texels per bound texel at this level
  if (uLevel == 0) {
    ivec2 t = r.xy / span + ivec2(gl_WorkGroupID.xy);
    // The same for every invocation of the workgroup: it returns whole, before the barriers.
    if (any(greaterThan(t, r.zw / span)) || any(greaterThanEqual(t, imageSize(uBound)))) return;
    if (gl_LocalInvocationIndex == 0u) sLargest = 0u;
    barrier();
    ivec2 first = t * uTile, size = min(first + uTile, ivec2(uResolution)) - first;
    float m = 0.0;
    for (int i = int(gl_LocalInvocationIndex); i < size.x * size.y; i += 64)
      m = max(m, abs(texelFetch(uHeight, first + ivec2(i % size.x, i / size.x), 0).r - 0.5));
    atomicMax(sLargest, floatBitsToUint(m));
    barrier();
    if (gl_LocalInvocationIndex == 0u) imageStore(uBound, t, vec4(uintBitsToFloat(sLargest)));
    return;
  }
  ivec2 t = r.xy / span + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThan(t, r.zw / span)) || any(greaterThanEqual(t, imageSize(uBound)))) return;
  float m = 0.0;
  for (int k = 0; k < 4; ++k) m = max(m, imageLoad(uBelow, 2 * t + ivec2(k & 1, k >> 1)).r);
  imageStore(uBound, t, vec4(m));
}
