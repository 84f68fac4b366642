#version 450 core
// dent_commit.comp: writes the new heights of each side of a group into its height map, over its touched region
// only, counts what changed, and puts the scratch back to +infinity (untouched) there, ready for the next
// deformation. Workgroup z: entry uFirst + z (commit_side.glsl); dispatched over its group's largest region.
// in:  uScratch (float bits), uRegion[slot]; out: uHeights[z], uStats[statsIndex * 4 ..]
//   stats: texels changed, max dent (float bits, m), texels saturated at 0
#include "commit_side.glsl"
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };  // bindings::kRegion
layout(std430, binding = 1) buffer Stats { uint uStats[]; };  // bindings::commit::kStats
layout(std430, binding = 2) buffer Scratch { uint uScratch[]; };  // new heights, row by row from scratchBase; bindings::kScratch
layout(r32f, binding = 0) uniform image2D uHeights[8];  // bindings::commit::kMaps
float loadHeight(int k, ivec2 p) {
  float v = 0.0;
#define LOAD(i) v = imageLoad(uHeights[i], p).r
  switch (k) { EACH8(LOAD) }
  return v;
}
void storeHeight(int k, ivec2 p, float v) {
#define STORE(i) imageStore(uHeights[i], p, vec4(v))
  switch (k) { EACH8(STORE) }
}
void main() {
  int k = int(gl_WorkGroupID.z);
  CommitEntry E = uEntry[uFirst + k];
  ivec4 r = uRegion[E.slot];
  if (r.z < r.x || r.w < r.y) return;
  ivec2 p = r.xy + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThan(p, r.zw))) return;
  uint at = E.scratchBase + uint(p.y * E.resolution + p.x);
  uint bits = uScratch[at];
  if (bits == 0x7f800000u) return;  // untouched
  uScratch[at] = 0x7f800000u;
  float nh = uintBitsToFloat(bits);
  float oh = loadHeight(k, p);
  if (nh == oh) return;
  storeHeight(k, p, nh);
  uint base = uint(E.statsIndex) * 4u;
  atomicAdd(uStats[base + 0u], 1u);
  if (nh < oh) atomicMax(uStats[base + 1u], floatBitsToUint((oh - nh) * E.bumpDepth));
  if (nh <= 0.0) atomicAdd(uStats[base + 2u], 1u);
}
