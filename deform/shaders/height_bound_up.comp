#version 450 core
// height_bound_up.comp: the levels above level 0 of the bound pyramids of a commit group's maps over their
// regions (height_bound.comp makes level 0, and all levels of a region known on the CPU). One workgroup a map
// (workgroup z: entry uFirst + z, its pyramid uBounds[z], its levels side by side: boundOrigin) for all of its
// levels, each texel the largest of the 2 x 2 below it, level after level with a barrier between: a region's
// upper levels hold few texels, and one dispatch for 8 maps replaces one a map and level.
// in:  level 0, the region in height texels uNormalRegion[slot]; out: levels 1 ..
#include "commit_side.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(r32f, binding = 0) coherent uniform image2D uBounds[8];  // bindings::commit::kMaps
layout(std430, binding = 3) readonly buffer NormalRegion { ivec4 uNormalRegion[]; };  // bindings::commit::kNormalRegion
uniform int uTile;
int gK;
float load(ivec2 p) {
  float v = 0.0;
#define LOAD(i) v = imageLoad(uBounds[i], p).r
  switch (gK) { EACH8(LOAD) }
  return v;
}
void store(ivec2 p, float v) {
#define STORE(i) imageStore(uBounds[i], p, vec4(v))
  switch (gK) { EACH8(STORE) }
}
int boundSize() {
  int s = 0;
#define SIZE(i) s = imageSize(uBounds[i]).y
  switch (gK) { EACH8(SIZE) }
  return s;
}
void main() {
  gK = int(gl_WorkGroupID.z);
  CommitEntry E = uEntry[uFirst + gK];
  ivec4 r = uNormalRegion[E.slot];
  if (r.z < r.x || r.w < r.y) return;  // the whole workgroup
  r = clamp(r, ivec4(0), ivec4(E.resolution - 1));
  int S = boundSize(), levels = findMSB(S) + 1;
  for (int k = 1; k < levels; ++k) {
    int span = uTile << k;  // height texels per bound texel at this level
    ivec2 lo = r.xy / span, hi = min(r.zw / span, ivec2((S >> k) - 1));
    ivec2 n = max(hi - lo + 1, ivec2(0));
    ivec2 from = boundOrigin(S, k - 1), to = boundOrigin(S, k);
    for (int i = int(gl_LocalInvocationIndex); i < n.x * n.y; i += 64) {
      ivec2 t = lo + ivec2(i % n.x, i / n.x);
      float m = 0.0;
      for (int q = 0; q < 4; ++q) m = max(m, load(from + 2 * t + ivec2(q & 1, q >> 1)));
      store(to + t, m);
    }
    memoryBarrierImage();
    barrier();
  }
}
