#version 450 core
// region_dispatch.comp: turns the touched region of every side of the commit (an invocation each) into its
// group's indirect dispatch sizes, the largest of its sides': the commit over the region (16x16 groups), the
// normal map over the region grown by a texel (16x16 groups), level 0 of the height bound over that grown region
// (a group per bound tile of uTile texels). A side with an empty region adds nothing.
// in:  uRegion[slot], the entries; out: uArgs[9 group .. + 8] (x, y grown; z set beforehand), uNormalRegion[slot]
#include "commit_side.glsl"
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };  // bindings::kRegion
layout(std430, binding = 2) buffer Args { uint uArgs[]; };  // bindings::commit::kArgs
layout(std430, binding = 3) buffer NormalRegion { ivec4 uNormalRegion[]; };  // bindings::commit::kNormalRegion
layout(std430, binding = 5) buffer Rim { uint uRimIndirect[6]; int uRimRing[2]; };  // rim_dispatch.comp's; bindings::commit::kRim
uniform int uCount;  // entries
uniform int uTile;   // height texels a side of a bound tile (SurfaceMaps::kBoundTile)
void main() {
  int e = int(gl_GlobalInvocationID.x);
  if (e >= uCount) return;
  CommitEntry E = uEntry[e];
  int s = E.slot;
  ivec4 r = uRegion[s];
  if (E.grow > 0 && r.z >= r.x) {  // crater rims widen the region by their ring
    int grow = uRimRing[s];
    r = ivec4(max(r.xy - grow, ivec2(0)), min(r.zw + grow, ivec2(E.resolution - 1)));
    uRegion[s] = r;
  }
  if (r.z < r.x || r.w < r.y) {
    uNormalRegion[s] = ivec4(0, 0, -1, -1);
    return;
  }
  uint base = uint(E.group) * 9u;
  ivec2 size = r.zw - r.xy + 1;
  atomicMax(uArgs[base + 0u], uint((size.x + 15) / 16));
  atomicMax(uArgs[base + 1u], uint((size.y + 15) / 16));
  ivec4 n = ivec4(max(r.xy - 1, ivec2(0)), min(r.zw + 1, ivec2(E.resolution - 1)));
  ivec2 ns = n.zw - n.xy + 1;
  atomicMax(uArgs[base + 3u], uint((ns.x + 15) / 16));
  atomicMax(uArgs[base + 4u], uint((ns.y + 15) / 16));
  ivec2 bs = n.zw / uTile - n.xy / uTile + 1;
  atomicMax(uArgs[base + 6u], uint(bs.x));
  atomicMax(uArgs[base + 7u], uint(bs.y));
  uNormalRegion[s] = n;
}
