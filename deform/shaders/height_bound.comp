#version 450 core
// height_bound.comp: one level of a height map's bound pyramid over a region. Level 0 holds, per tile of
// uTile x uTile texels, the largest |h - 0.5| (how far the surface leaves the mesh, over k); each level above
// the largest of the 2 x 2 below. The renderer's parallax march reads it to skip rays over undented texels.
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
void main() {
  ivec4 r = uSide >= 0 ? uRegion[uSide] : uFullRegion;
  r = clamp(r, ivec4(0), ivec4(uResolution - 1));
  int span = uTile << uLevel;  // height texels per bound texel at this level
  ivec2 t = r.xy / span + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThan(t, r.zw / span)) || any(greaterThanEqual(t, imageSize(uBound)))) return;
  float m = 0.0;
  if (uLevel == 0) {
    ivec2 first = t * uTile, last = min(first + uTile, ivec2(uResolution)) - 1;
    for (int y = first.y; y <= last.y; ++y)
      for (int x = first.x; x <= last.x; ++x) m = max(m, abs(texelFetch(uHeight, ivec2(x, y), 0).r - 0.5));
  } else {
    for (int k = 0; k < 4; ++k) m = max(m, imageLoad(uBelow, 2 * t + ivec2(k & 1, k >> 1)).r);
  }
  imageStore(uBound, t, vec4(m));
}
