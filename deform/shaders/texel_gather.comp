#version 450 core
// texel_gather.comp: the gather of texel_gather.frag (the bump-map update of section 4.2, per texel) in compute,
// for up to 14 sides of a wave whose X has this mesh and map resolution (workgroup z: entry uFirst + z). Where the
// address pass runs in compute (GPUs with a narrow fragment stage) X's texels are visited here by every
// invocation of the GPU instead of being drawn through the graphics stages (texel.vert, texel.geom).
// Two modes. uMode 0 (cull): an invocation a (tile of 16 x 16 texels, side): the tile (TexelCover) is kept when
// it lists triangles and its box in the shape frame meets the side's view and reaches the other body's farthest
// depth; kept tiles are appended to the group's list, whose length sizes mode 1's indirect dispatch (a large GPU
// then launches workgroups for the few tiles near the contact, not for every tile of every side's map).
// uMode 1 (gather): a workgroup a listed (tile, side) (striding when there are more than 65535): each invocation
// takes its texel and
// every triangle of the tile's list that faces the camera (as address pass A keeps), reaches the other body's
// depth range and whose footprint in texture space, grown by half a texel, holds the texel's centre (the
// texels texel.geom's conservative rasterisation reaches), the triangle's affine map extrapolated to the centre
// for its surface point and normal, kept where that point lies in the view grown by half the texel's footprint
// (texel.geom clips the triangle to the view first). Each (texel, triangle) is updated as texel_gather.frag
// does; the deepest wins.
// in:  X's mesh (vertices, indices), the tile lists, X's height map uHeights[sampler], the other body's depth
//      pass (layer `slot` of uAddressOther, uDepthOther)
// out: uScratch (float bits, minimum), uRegion[slot] grows to the touched texels
layout(local_size_x = 16, local_size_y = 16) in;
#include "texel_point.glsl"
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };  // bindings::kRegion
layout(std430, binding = 1) readonly buffer Vertices { float uVertex[]; };  // GpuMesh: 17 floats a vertex; bindings::gather::kVertices
layout(std430, binding = 2) buffer Scratch { uint uScratch[]; };  // bindings::kScratch
layout(std430, binding = 3) readonly buffer Indices { uint uIndex[]; };  // bindings::gather::kIndices
layout(std430, binding = 4) readonly buffer TileStart { uint uTileStart[]; };  // bindings::gather::kTileStart
layout(std430, binding = 5) readonly buffer TileTriangles { uint uTileTriangle[]; };  // bindings::gather::kTileTriangles
layout(std430, binding = 6) readonly buffer TileBox { vec4 uTileBox[]; };  // bindings::gather::kTileBoxes
struct Entry {
  mat4 mvp;                // X's shape frame to the address camera's clip space (orthographic: w = 1)
  vec4 normalToWorld[3];   // columns
  vec4 viewNormal;         // N_C as owned by X (towards the camera); w: the view's half-size in clip units
  int slot, resolution, sampler, tangentMode;
  uint scratchBase;
  float farthestOther;     // the other body's farthest window depth (its bounds, with its bumps)
  float bumpToDepth;       // X's k' / (zfar - znear)
  float depthToHeight;     // (zfar - znear) / k
  float tangentFloor;
  float bumpReach;         // how far X's bumps raise a point towards the camera at most (window depth)
  float pushDepth;         // the deepest a texel is dented, window depth (SideUpdate::pushDepth)
  float pad1;
};
layout(std430, binding = 7) readonly buffer Entries { Entry uEntry[]; };  // bindings::gather::kEntries
// The kept tiles, (side << 20) | tile each; their head: [0] their count, [1 .. 3] mode 1's indirect dispatch
// (x: min(count, 65535)).
layout(std430, binding = 8) buffer Kept { uint uKept[]; };  // bindings::gather::kKept
layout(std430, binding = 10) buffer KeptHead { uint uHead[4]; };  // bindings::gather::kKeptHead
// Per slot, the address-map pixels (x0, y0, x1, y1) the kept tiles' texels may read (mode 0 grows it): the
// compute raster writes only there.
layout(std430, binding = 9) buffer Reach { ivec4 uReach[]; };  // bindings::gather::kReach
layout(binding = 0) uniform sampler2DArray uAddressOther;  // bindings::gather::kAddressOthers
layout(binding = 1) uniform sampler2DArray uDepthOther;  // bindings::gather::kDepthOthers
layout(binding = 2) uniform sampler2D uHeights[14];  // X's height map: the entry's `sampler`; bindings::gather::kHeights
uniform int uSize;    // address map (pixels)
uniform int uFirst;
uniform int uMode;    // 0: cull the tiles, 1: gather the kept ones
const int kTile = 16;
Entry gE;
// A chunk of the tile's triangles, set up by one invocation each: texel-space corners t0 t1 | t2 area orient,
// clip-space corners c0 (xyz, kept) | c1 | c2, world normals n0 | n1 | n2.
shared vec4 sTri[128 * 8];  // 16 KiB
// X's height at texel t, from the side's map: constant indices into the sampler array (Mesa's llvmpipe read
// the other samplers of this shader as zero once uHeights was indexed by a variable, dynamically uniform or not).
float heightX(ivec2 t) {
  switch (gE.sampler) {
    case 0: return texelFetch(uHeights[0], t, 0).r;
    case 1: return texelFetch(uHeights[1], t, 0).r;
    case 2: return texelFetch(uHeights[2], t, 0).r;
    case 3: return texelFetch(uHeights[3], t, 0).r;
    case 4: return texelFetch(uHeights[4], t, 0).r;
    case 5: return texelFetch(uHeights[5], t, 0).r;
    case 6: return texelFetch(uHeights[6], t, 0).r;
    case 7: return texelFetch(uHeights[7], t, 0).r;
    case 8: return texelFetch(uHeights[8], t, 0).r;
    case 9: return texelFetch(uHeights[9], t, 0).r;
    case 10: return texelFetch(uHeights[10], t, 0).r;
    case 11: return texelFetch(uHeights[11], t, 0).r;
    case 12: return texelFetch(uHeights[12], t, 0).r;
    case 13: return texelFetch(uHeights[13], t, 0).r;
  }
  return 0.5;
}
bool seen(ivec2 q) {
  return all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(uSize))) &&
         texelFetch(uAddressOther, ivec3(q, gE.slot), 0).r >= 0.0;
}
float depthAt(ivec2 q) { return texelFetch(uDepthOther, ivec3(q, gE.slot), 0).r; }
vec3 position(uint v) { return vec3(uVertex[v * 17u], uVertex[v * 17u + 1u], uVertex[v * 17u + 2u]); }
vec3 normalOf(uint v) { return vec3(uVertex[v * 17u + 3u], uVertex[v * 17u + 4u], uVertex[v * 17u + 5u]); }
vec2 uvOf(uint v) { return vec2(uVertex[v * 17u + 6u], uVertex[v * 17u + 7u]); }
void setUp(uint tri, uint j) {
  uint i0 = uIndex[3u * tri], i1 = uIndex[3u * tri + 1u], i2 = uIndex[3u * tri + 2u];
  vec3 c0 = (gE.mvp * vec4(position(i0), 1.0)).xyz, c1 = (gE.mvp * vec4(position(i1), 1.0)).xyz,
       c2 = (gE.mvp * vec4(position(i2), 1.0)).xyz;
  float res = float(gE.resolution);
  vec2 t0 = uvOf(i0) * res, t1 = uvOf(i1) * res, t2 = uvOf(i2) * res;
  float area = (t1.x - t0.x) * (t2.y - t0.y) - (t1.y - t0.y) * (t2.x - t0.x);
  // Facing: counter-clockwise in the camera's view, as pass A keeps; within reach of the other body's depth.
  bool kept = (c1.x - c0.x) * (c2.y - c0.y) - (c1.y - c0.y) * (c2.x - c0.x) > 0.0 &&
              !(min(c0.z, min(c1.z, c2.z)) * 0.5 + 0.5 - gE.bumpReach > gE.farthestOther) &&
              abs(area) >= 1e-12;
  mat3 toWorld = mat3(gE.normalToWorld[0].xyz, gE.normalToWorld[1].xyz, gE.normalToWorld[2].xyz);
  sTri[j * 8u] = vec4(t0, t1);
  sTri[j * 8u + 1u] = vec4(t2, area, area > 0.0 ? 1.0 : -1.0);
  sTri[j * 8u + 2u] = vec4(c0, kept ? 1.0 : 0.0);
  sTri[j * 8u + 3u] = vec4(c1, 0.0);
  sTri[j * 8u + 4u] = vec4(c2, 0.0);
  sTri[j * 8u + 5u] = vec4(toWorld * normalOf(i0), 0.0);
  sTri[j * 8u + 6u] = vec4(toWorld * normalOf(i1), 0.0);
  sTri[j * 8u + 7u] = vec4(toWorld * normalOf(i2), 0.0);
}
// Whether the texel centre q lies in the triangle's footprint grown by half a texel along each edge normal (and
// within its box grown by half a texel): the texel's square overlaps the triangle.
bool reaches(vec2 q, vec2 t0, vec2 t1, vec2 t2, float orient) {
  vec2 lo = min(min(t0, t1), t2) - 0.5, hi = max(max(t0, t1), t2) + 0.5;
  if (any(lessThan(q, lo)) || any(greaterThan(q, hi))) return false;
  vec2 a[3] = vec2[3](t0, t1, t2);
  for (int e = 0; e < 3; ++e) {
    vec2 p = a[e], d = a[(e + 1) % 3] - p;
    vec2 n = orient * vec2(d.y, -d.x);  // outward
    float s = dot(n, q - p) - 0.5 * (abs(n.x) + abs(n.y));
    // A centre on the grown edge (a square that only touches the triangle, at a chart's edge on the texel grid)
    // is reached across its bottom and left edges, not its top and right: the rasteriser's rule for samples on
    // an edge, so that of two triangles meeting there exactly one reaches it.
    if (s > 0.0 || (s == 0.0 && !(n.y < 0.0 || (n.y == 0.0 && n.x < 0.0)))) return false;
  }
  return true;
}
// Whether tile `tile` of side gE's map may hold texels to dent: it lists triangles and its box meets the view (grown
// by a tenth: texels extrapolated past the box's triangles) and reaches the other body's farthest depth.
vec3 cmin, cmax;  // the kept tile's box in clip space
bool kept(uint tileIndex) {
  if (uTileStart[tileIndex + 1u] == uTileStart[tileIndex]) return false;
  float lim = gE.viewNormal.w;
  vec3 lo = uTileBox[2u * tileIndex].xyz, hi = uTileBox[2u * tileIndex + 1u].xyz;
  cmin = vec3(1e30);
  cmax = vec3(-1e30);
  for (int c = 0; c < 8; ++c) {
    vec3 p = vec3((c & 1) != 0 ? hi.x : lo.x, (c & 2) != 0 ? hi.y : lo.y, (c & 4) != 0 ? hi.z : lo.z);
    vec3 q = (gE.mvp * vec4(p, 1.0)).xyz;
    cmin = min(cmin, q);
    cmax = max(cmax, q);
  }
  return !(cmin.x > lim || cmax.x < -lim || cmin.y > lim || cmax.y < -lim ||
           cmin.z * 0.5 + 0.5 - gE.bumpReach > gE.farthestOther);
}
// How far the other body's depth lies beyond X's surface point `clip` (window depth; <= 0: not inside it, or
// outside the view grown by `reach` or not seen there), X's point raised by its height h.
float beyond(vec3 clip, vec2 reach, float h) {
  if (any(greaterThan(abs(clip.xy), reach))) return -1.0;
  // Pixel coordinates in the address map (pixel centres at integers).
  vec2 px = (clip.xy * 0.5 + 0.5) * float(uSize) - 0.5;
  if (any(lessThan(px, vec2(-0.5))) || any(greaterThan(px, vec2(float(uSize) - 0.5)))) return -1.0;
  ivec2 b = ivec2(floor(px));
  vec2 w = px - vec2(b);
  float dO;
  if (seen(b) && seen(b + ivec2(1, 0)) && seen(b + ivec2(0, 1)) && seen(b + ivec2(1, 1))) {
    dO = mix(mix(depthAt(b), depthAt(b + ivec2(1, 0)), w.x), mix(depthAt(b + ivec2(0, 1)), depthAt(b + ivec2(1, 1)), w.x),
             w.y);
  } else {
    ivec2 nearest = ivec2(floor(px + 0.5));
    if (!seen(nearest)) return -1.0;
    dO = depthAt(nearest);
  }
  float zX = clamp(clip.z * 0.5 + 0.5 - (h - 0.5) * gE.bumpToDepth, 0.0, 1.0);
  return dO - zX;
}
void gatherTile(uint tileIndex, int tilesX) {
  ivec2 tile = ivec2(int(tileIndex) % tilesX, int(tileIndex) / tilesX);
  uint first = uTileStart[tileIndex], count = uTileStart[tileIndex + 1u] - first;
  float lim = gE.viewNormal.w;
  ivec2 t = tile * kTile + ivec2(gl_LocalInvocationID.xy);
  bool inMap = all(lessThan(t, ivec2(gE.resolution)));
  vec2 q = vec2(t) + 0.5;
  float h = inMap ? heightX(t) : 0.0;
  float newHeight = h;
  for (uint base = 0u; base < count; base += 128u) {
    uint n = min(128u, count - base);
    if (gl_LocalInvocationIndex < n) setUp(uTileTriangle[first + base + gl_LocalInvocationIndex], gl_LocalInvocationIndex);
    barrier();
    for (uint j = 0u; j < n && inMap; ++j) {
      vec4 c0k = sTri[j * 8u + 2u];
      if (c0k.w == 0.0) continue;
      vec4 t01 = sTri[j * 8u], t2a = sTri[j * 8u + 1u];
      vec2 t0 = t01.xy, t1 = t01.zw, t2 = t2a.xy;
      if (!reaches(q, t0, t1, t2, t2a.w)) continue;
      float area = t2a.z;
      vec3 w = texelBarycentrics(q, t0, t1, t2, area);
      vec3 c1 = sTri[j * 8u + 3u].xyz, c2 = sTri[j * 8u + 4u].xyz;
      // The view grown by half the texel's footprint there (the clip coordinates' change over a texel).
      vec2 dx = ((c1.xy - c0k.xy) * (t2.y - t0.y) - (c2.xy - c0k.xy) * (t1.y - t0.y)) / area;
      vec2 dy = ((c2.xy - c0k.xy) * (t1.x - t0.x) - (c1.xy - c0k.xy) * (t2.x - t0.x)) / area;
      vec2 reach = lim + 0.5 * (abs(dx) + abs(dy));
      float dD = beyond(w.x * c0k.xyz + w.y * c1 + w.z * c2, reach, h);
      if (!(dD > 0.0)) continue;
      if (any(lessThan(w, vec3(0.0)))) {  // texel_point.glsl: a centre outside the triangle
        vec3 wn = nearestBarycentrics(q, t0, t1, t2, w);
        dD = min(dD, beyond(wn.x * c0k.xyz + wn.y * c1 + wn.z * c2, reach, h));
        if (!(dD > 0.0)) continue;
      }
      // X advanced by d into the other (retracted first to contact): an overlap beyond d and the reach of
      // the maps' bumps was there before the push (a pose the contact did not measure) and is not this
      // event's.
      dD = min(dD, gE.pushDepth);
      if (gE.tangentMode != 0) {
        vec3 normal = w.x * sTri[j * 8u + 5u].xyz + w.y * sTri[j * 8u + 6u].xyz + w.z * sTri[j * 8u + 7u].xyz;
        float c = abs(dot(normalize(normal), gE.viewNormal.xyz));
        dD = gE.tangentMode == 1 ? dD * c : dD / max(c, gE.tangentFloor);
      }
      newHeight = min(newHeight, clamp(fma(-dD, gE.depthToHeight, h), 0.0, 1.0));
    }
    barrier();
  }
  if (!(newHeight < h)) return;
  atomicMin(uScratch[gE.scratchBase + uint(t.y * gE.resolution + t.x)], floatBitsToUint(newHeight));
  int s = gE.slot;
  ivec4 r = uRegion[s];  // most texels leave the region as it is: read before the atomics
  if (t.x < r.x) atomicMin(uRegion[s].x, t.x);
  if (t.y < r.y) atomicMin(uRegion[s].y, t.y);
  if (t.x > r.z) atomicMax(uRegion[s].z, t.x);
  if (t.y > r.w) atomicMax(uRegion[s].w, t.y);
}
void main() {
  if (uMode == 0) {
    gE = uEntry[uFirst + int(gl_WorkGroupID.z)];
    int tilesX = (gE.resolution + kTile - 1) / kTile;
    uint tileIndex = gl_WorkGroupID.x * 256u + gl_LocalInvocationIndex;
    if (tileIndex >= uint(tilesX * tilesX) || !kept(tileIndex)) return;
    uint at = atomicAdd(uHead[0], 1u);
    atomicMax(uHead[1], min(at + 1u, 65535u));
    uKept[at] = (gl_WorkGroupID.z << 20) | tileIndex;
    // The pixels its texels project to (the box holds them), and the next ones a bilinear read takes.
    vec2 plo = (clamp(cmin.xy, -2.0, 2.0) * 0.5 + 0.5) * float(uSize) - 0.5, phi = (clamp(cmax.xy, -2.0, 2.0) * 0.5 + 0.5) * float(uSize) - 0.5;
    ivec2 a = max(ivec2(floor(plo)) - 2, ivec2(0)), b = min(ivec2(ceil(phi)) + 2, ivec2(uSize - 1));
    if (any(greaterThan(a, b))) return;
    atomicMin(uReach[gE.slot].x, a.x);
    atomicMin(uReach[gE.slot].y, a.y);
    atomicMax(uReach[gE.slot].z, b.x);
    atomicMax(uReach[gE.slot].w, b.y);
    return;
  }
  uint listed = uHead[0];
  for (uint a = gl_WorkGroupID.x; a < listed; a += gl_NumWorkGroups.x) {
    uint item = uKept[a];
    gE = uEntry[uFirst + int(item >> 20)];
    gatherTile(item & 0xfffffu, (gE.resolution + kTile - 1) / kTile);
    barrier();  // the next item's setup overwrites the triangles
  }
}
