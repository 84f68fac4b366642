#version 450 core
// dent_commit.comp: writes the new heights of each side of a group into its height map, over its touched region
// only, counts what changed, and puts the scratch back to +infinity (untouched) there, ready for the next
// deformation. Workgroup z: entry uFirst + z (commit_side.glsl); dispatched over its group's largest region.
// A side whose map keeps a change log (entry changeLog >= 0) appends each texel it changes to uChange: its log
// id, texel index (y * resolution + x) and new height (float bits), three uints an entry, at a place taken per
// workgroup (one atomic on uChangeCount a workgroup); entries past uChangeCapacity are counted, not written.
// in:  uScratch (float bits), uRegion[slot]; out: uHeights[z], uStats[statsIndex * 4 ..], uChange
//   stats: texels changed, max dent (float bits, m), texels saturated at 0
#include "commit_side.glsl"
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };  // bindings::kRegion
layout(std430, binding = 1) buffer Stats { uint uStats[]; };  // bindings::commit::kStats
layout(std430, binding = 2) buffer Scratch { uint uScratch[]; };  // new heights, row by row from scratchBase; bindings::kScratch
layout(std430, binding = 7) coherent buffer Changes {  // bindings::commit::kChanges (Deformer's change log)
  uint uChangeCount;
  uint uChangeCapacity;
  uint uChange[];
};
layout(r32f, binding = 0) uniform image2D uHeights[8];  // bindings::commit::kMaps
shared uint sCount, sBase;
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
  if (r.z < r.x || r.w < r.y) return;  // (the whole workgroup: its entry's)
  if (gl_LocalInvocationIndex == 0u) sCount = 0u;
  barrier();
  ivec2 p = r.xy + ivec2(gl_GlobalInvocationID.xy);
  bool logged = false;
  uint local = 0u;
  float nh = 0.0;
  if (all(lessThanEqual(p, r.zw))) {
    uint at = E.scratchBase + uint(p.y * E.resolution + p.x);
    uint bits = uScratch[at];
    if (bits != 0x7f800000u) {  // touched
      uScratch[at] = 0x7f800000u;
      nh = uintBitsToFloat(bits);
      float oh = loadHeight(k, p);
      if (nh != oh) {
        storeHeight(k, p, nh);
        uint base = uint(E.statsIndex) * 4u;
        atomicAdd(uStats[base + 0u], 1u);
        if (nh < oh) atomicMax(uStats[base + 1u], floatBitsToUint((oh - nh) * E.bumpDepth));
        if (nh <= 0.0) atomicAdd(uStats[base + 2u], 1u);
        if (E.changeLog >= 0) {
          local = atomicAdd(sCount, 1u);
          logged = true;
        }
      }
    }
  }
  barrier();
  if (gl_LocalInvocationIndex == 0u && sCount > 0u) sBase = atomicAdd(uChangeCount, sCount);
  barrier();
  if (!logged) return;
  uint i = sBase + local;
  if (i >= uChangeCapacity) return;
  uChange[3u * i] = uint(E.changeLog);
  uChange[3u * i + 1u] = uint(p.y * E.resolution + p.x);
  uChange[3u * i + 2u] = floatBitsToUint(nh);
}
