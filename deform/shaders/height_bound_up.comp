#version 450 core
// height_bound_up.comp: the upper levels of a height map's bound pyramid over the commit's region, one workgroup
// for all of them (height_bound.comp makes level 0, and all levels of a region known on the CPU). Levels
// uFirst + 1 .. uFirst + uCount, each texel the largest of the 2 x 2 below it, level after level with a barrier
// between: a region's upper levels hold few texels, and one dispatch a map replaces one a map and level.
// in:  uLevels[0] (level uFirst), the region in height texels uRegion[uSide]; out: uLevels[1 .. uCount]
layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = 0) coherent uniform image2D uLevels[8];  // levels uFirst .. uFirst + 7 of the bound
layout(std430, binding = 3) readonly buffer Region { ivec4 uRegion[]; };
uniform int uSide;
uniform int uFirst;
uniform int uCount;  // at most 7
uniform int uTile;
uniform int uResolution;
void main() {
  ivec4 r = clamp(uRegion[uSide], ivec4(0), ivec4(uResolution - 1));
  for (int k = 1; k <= uCount; ++k) {
    int span = uTile << (uFirst + k);  // height texels per bound texel at this level
    ivec2 lo = r.xy / span, hi = min(r.zw / span, imageSize(uLevels[k]) - 1);
    ivec2 n = max(hi - lo + 1, ivec2(0));
    for (int i = int(gl_LocalInvocationIndex); i < n.x * n.y; i += 64) {
      ivec2 t = lo + ivec2(i % n.x, i / n.x);
      float m = 0.0;
      for (int q = 0; q < 4; ++q) m = max(m, imageLoad(uLevels[k - 1], 2 * t + ivec2(q & 1, q >> 1)).r);
      imageStore(uLevels[k], t, vec4(m));
    }
    memoryBarrierImage();
    barrier();
  }
}
