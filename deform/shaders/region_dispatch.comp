#version 450 core
// region_dispatch.comp: turns the touched region of side uSide into indirect
// dispatch sizes: one for the commit over the region (16x16 groups), one for
// the normal map over the region grown by a texel (16x16 groups), one for level 0 of the height bound over that
// grown region (a group per bound tile of uTile texels). An empty region dispatches nothing.
// in:  uRegion[uSide]; out: uIndirect[uSide * 9 .. + 8], uNormalRegion[uSide]
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };
layout(std430, binding = 2) buffer Indirect { uint uIndirect[]; };
layout(std430, binding = 3) buffer NormalRegion { ivec4 uNormalRegion[]; };
uniform int uSide;
uniform int uResolution;
uniform int uTile;  // height texels a side of a bound tile (SurfaceMaps::kBoundTile)
uniform int uGrow;  // crater rims widen the region by their ring: 1 takes it from uRimRing (rim_dispatch.comp)
layout(std430, binding = 5) buffer Rim { uint uRimIndirect[6]; int uRimRing[2]; };
void main() {
  ivec4 r = uRegion[uSide];
  int grow = uGrow > 0 ? uRimRing[uSide] : 0;
  if (grow > 0 && r.z >= r.x) {
    r = ivec4(max(r.xy - grow, ivec2(0)), min(r.zw + grow, ivec2(uResolution - 1)));
    uRegion[uSide] = r;
  }
  uint base = uint(uSide) * 9u;
  if (r.z < r.x || r.w < r.y) {
    for (uint i = 0u; i < 9u; ++i) uIndirect[base + i] = 0u;
    uNormalRegion[uSide] = ivec4(0, 0, -1, -1);
    return;
  }
  ivec2 size = r.zw - r.xy + 1;
  uIndirect[base + 0u] = uint((size.x + 15) / 16);
  uIndirect[base + 1u] = uint((size.y + 15) / 16);
  uIndirect[base + 2u] = 1u;
  ivec4 n = ivec4(max(r.xy - 1, ivec2(0)), min(r.zw + 1, ivec2(uResolution - 1)));
  ivec2 ns = n.zw - n.xy + 1;
  uIndirect[base + 3u] = uint((ns.x + 15) / 16);
  uIndirect[base + 4u] = uint((ns.y + 15) / 16);
  uIndirect[base + 5u] = 1u;
  ivec2 bs = n.zw / uTile - n.xy / uTile + 1;
  uIndirect[base + 6u] = uint(bs.x);
  uIndirect[base + 7u] = uint(bs.y);
  uIndirect[base + 8u] = 1u;
  uNormalRegion[uSide] = n;
}
