#version 450 core
// address_bin.comp: pass B of figure 11 for the gather (the other body's back faces, the farthest one
// anywhere) rasterised in compute, step 1 of 2 (address_raster.comp is step 2), for the sides of a wave whose
// other body has this mesh: workgroup z takes entry uFirst + z (its slot, transform and cull depth). One workgroup
// 64 triangles, a lane each: it puts the corners into window coordinates and keeps the triangle when it faces away
// from the camera (GL's counter-clockwise front faces culled), is not degenerate and reaches the entry's depth
// (triangles wholly nearer the camera cannot dent X), writing its setup. Then the lanes share, kept triangle after
// kept triangle, the 8 x 8-pixel tiles its box covers and append it to every tile of the slot's reach whose pixel
// centres it may hold (16 tiles a lane at most; lanes of one triangle never contend for a tile's counter), listing
// each tile that gets its first entry among the active ones. A triangle whose box spans more than 1024 tiles goes
// to the list of large ones instead, which every tile of the reach tests (few: the back faces' areas sum to about
// the map's times its depth complexity). A tile keeps at most uCapacity entries; its count still grows, and
// step 2 then tests every triangle for that tile.
// Per slot at fixed strides: counts, tile lists and active tiles; per entry, from its `setup`: the setups and the
// large triangles. Setup, 6 vec4 a triangle: corners 0 and 1 (window x, y in pixels), corner 2 and depths 0 and 1, depth 2, the
// texture coordinates (u0 v0 u1 v1, u2 v2), and the box of pixel centres (min x, min y, max x, max y; empty for a
// triangle not kept). Step 2 evaluates each edge from its endpoints in a fixed order, so that two triangles
// sharing an edge get values that are each other's negation bit for bit: no cracks between them on any GPU.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Vertices { float uVertex[]; };  // GpuMesh: 17 floats a vertex; bindings::address::kVertices
layout(std430, binding = 1) readonly buffer Indices { uint uIndex[]; };  // bindings::address::kIndices
layout(std430, binding = 2) writeonly buffer Setup { vec4 uSetup[]; };  // bindings::address::kSetup
// TileCount, T + 6 uints a slot: per tile (T of them) the entries, then [T] the large triangles', [T + 1] the
// active tiles', [T + 2] and [T + 3] the reach's tiles (x0 | y0 << 16, x1 | y1 << 16) where there are large ones,
// [T + 4] unused, [T + 5] whether a large triangle makes every tile of the reach active.
layout(std430, binding = 3) buffer TileCount { uint uTileCount[]; };  // bindings::address::kTileCount
layout(std430, binding = 4) writeonly buffer TileList { uint uTileList[]; };  // bindings::address::kTileList
layout(std430, binding = 5) writeonly buffer Large { uint uLarge[]; };  // bindings::address::kLarge
layout(std430, binding = 6) writeonly buffer Active { uint uActive[]; };  // the tiles step 2 runs; bindings::address::kActive
struct Entry {
  mat4 mvp;           // the other body's model-view-projection
  int slot, triangles;
  uint setup;         // its first triangle's index into Setup and Large
  int group;          // its raster dispatch: Args[3 group ..]
  float reach;        // triangles whose window depth stays below it are left out (they cannot dent X)
  float bumpToDepth;  // (step 2)
  int sampler, mode;  // (step 2)
};
layout(std430, binding = 7) readonly buffer Entries { Entry uEntry[]; };  // bindings::address::kEntries
// Step 2's indirect dispatches, one a group of entries: x = the most active tiles of its sides (at most 65535),
// y = 1, z = its entries (set beforehand).
layout(std430, binding = 8) buffer Args { uint uArgs[]; };  // bindings::address::kArgs
// Per slot, the pixels (x0, y0, x1, y1) X's texels may read (texel_gather.comp's cull): no tile outside is listed.
layout(std430, binding = 9) readonly buffer Reach { ivec4 uReach[]; };  // bindings::address::kReach
uniform int uSize;       // the address map (pixels)
uniform int uCapacity;   // entries a tile
uniform int uFirst;      // workgroup z's entry: uFirst + z
const int kTile = 8, kLarge = 1024;
Entry gE;                // this workgroup's
uint gCounts;            // its slot's TileCount, list and active offsets
uint gTiles;
const uint kRowGroups = 32768u;  // workgroups a row (y: the rows)
// The workgroup's kept triangles (not large), binned one after another by all lanes.
shared uint sCount;
shared uint sTriangle[64];
shared ivec4 sTiles[64];  // tile box (inclusive)
shared vec3 sEdge[64 * 3];
shared vec4 sBox[64];     // pixel-centre box
shared vec2 sOrigin[64];
vec3 corner(uint i) {
  uint v = uIndex[i] * 17u;
  vec4 c = gE.mvp * vec4(uVertex[v], uVertex[v + 1u], uVertex[v + 2u], 1.0);
  vec3 ndc = c.xyz / c.w;
  return vec3((ndc.xy * 0.5 + 0.5) * float(uSize), ndc.z * 0.5 + 0.5);
}
vec2 uvOf(uint i) {
  uint v = uIndex[i] * 17u;
  return vec2(uVertex[v + 6u], uVertex[v + 7u]);
}
// w(p) = a x + b y + c, zero on the edge from p to q, positive on the side of r.
vec3 edge(vec2 p, vec2 q) { return vec3(p.y - q.y, q.x - p.x, p.x * q.y - p.y * q.x); }
// Puts a tile that got its first entry into the active list: step 2 runs a workgroup for these only (the
// targets are cleared beforehand), not one for every tile of the map; a large triangle makes them all active.
uint tileCount() {
  uint tilesX = uint((uSize + kTile - 1) / kTile);
  return tilesX * tilesX;
}
void dispatchAtLeast(uint groups) { atomicMax(uArgs[3u * uint(gE.group)], min(groups, 65535u)); }
void activate(uint id) {
  uint slot = atomicAdd(uTileCount[gCounts + gTiles + 1u], 1u);
  uActive[uint(gE.slot) * gTiles + slot] = id;
  dispatchAtLeast(slot + 1u);
}
// The tiles (x0, y0, x1, y1, inclusive; empty when x1 < x0) that hold pixels of the slot's reach.
ivec4 reachTiles() {
  ivec4 r = uReach[gE.slot];
  int last = (uSize + kTile - 1) / kTile - 1;
  if (r.z < r.x || r.w < r.y) return ivec4(1, 1, 0, 0);
  return ivec4(clamp(r.xy / kTile, ivec2(0), ivec2(last)), clamp(r.zw / kTile, ivec2(0), ivec2(last)));
}
// Whether triangle j of the workgroup's list (edge functions from its origin, pixel-centre box) may hold a pixel
// centre of a tile: every edge function reaches zero somewhere over the tile's centres within the box (a tolerance
// of a thousandth of a pixel for rounding).
bool mayHold(uint j, ivec2 tile) {
  ivec4 r = uReach[gE.slot];
  if (any(greaterThan(tile * kTile, r.zw)) || any(lessThan(tile * kTile + kTile - 1, r.xy))) return false;
  vec4 box = sBox[j];
  vec2 lo = max(vec2(tile * kTile) + 0.5, box.xy) - sOrigin[j], hi = min(vec2(tile * kTile + kTile - 1) + 0.5, box.zw) - sOrigin[j];
  bool outside = false;
  for (uint e = 0u; e < 3u; ++e) {
    vec3 f = sEdge[3u * j + e];
    float best = f.x * (f.x > 0.0 ? hi.x : lo.x) + f.y * (f.y > 0.0 ? hi.y : lo.y) + f.z;
    outside = outside || best < -0.5 * (abs(f.x) + abs(f.y));
  }
  return !outside;
}
void main() {
  gE = uEntry[uFirst + int(gl_WorkGroupID.z)];
  gTiles = tileCount();
  gCounts = uint(gE.slot) * (gTiles + 6u);
  uint lane = gl_LocalInvocationIndex;
  if (lane == 0u) sCount = 0u;
  barrier();
  uint t = (gl_WorkGroupID.x + gl_WorkGroupID.y * kRowGroups) * 64u + lane;
  if (t < uint(gE.triangles)) {
    vec3 p0 = corner(3u * t), p1 = corner(3u * t + 1u), p2 = corner(3u * t + 2u);
    float area = (p1.x - p0.x) * (p2.y - p0.y) - (p2.x - p0.x) * (p1.y - p0.y);
    // Its depth plane's change over a diagonal pixel step: a texel's bilinear read takes the 2 x 2 pixels around
    // it, so a triangle within a pixel or two of where the other body reaches X is kept too (as the fragment
    // stage, which draws every back face, would have seen its pixels).
    float dzdx = ((p1.z - p0.z) * (p2.y - p0.y) - (p2.z - p0.z) * (p1.y - p0.y)) / area;
    float dzdy = ((p2.z - p0.z) * (p1.x - p0.x) - (p1.z - p0.z) * (p2.x - p0.x)) / area;
    float ring = 2.0 * (abs(dzdx) + abs(dzdy));
    bool kept = area < 0.0 && !(p0.z < 0.0 && p1.z < 0.0 && p2.z < 0.0) && !(p0.z > 1.0 && p1.z > 1.0 && p2.z > 1.0) &&
                !(max(max(p0.z, p1.z), p2.z) + ring < gE.reach);
    // Pixel centres (i + 0.5) within the box, within the map.
    vec2 lo = min(min(p0.xy, p1.xy), p2.xy), hi = max(max(p0.xy, p1.xy), p2.xy);
    ivec2 first = max(ivec2(ceil(lo - 0.5)), ivec2(0)), last = min(ivec2(floor(hi - 0.5)), ivec2(uSize - 1));
    kept = kept && all(lessThanEqual(first, last));
    vec2 uv0 = uvOf(3u * t), uv1 = uvOf(3u * t + 1u), uv2 = uvOf(3u * t + 2u);
    vec4 box = kept ? vec4(vec2(first) + 0.5, vec2(last) + 0.5) : vec4(1.0, 1.0, 0.0, 0.0);
    uint s = 6u * (gE.setup + t);
    uSetup[s] = vec4(p0.xy, p1.xy);
    uSetup[s + 1u] = vec4(p2.xy, p0.z, p1.z);
    uSetup[s + 2u] = vec4(p2.z, 0.0, 0.0, 0.0);
    uSetup[s + 3u] = vec4(uv0, uv1);
    uSetup[s + 4u] = vec4(uv2, 0.0, 0.0);
    uSetup[s + 5u] = box;
    ivec4 tiles = ivec4(first / kTile, last / kTile);
    if (kept && (tiles.z - tiles.x + 1) * (tiles.w - tiles.y + 1) > kLarge) {
      // Large: every tile of the reach runs it (address_raster.comp); the reach's tiles kept for the next clear.
      uLarge[gE.setup + atomicAdd(uTileCount[gCounts + gTiles], 1u)] = t;
      ivec4 rt = reachTiles();
      uTileCount[gCounts + gTiles + 2u] = uint(rt.x) | (uint(rt.y) << 16);
      uTileCount[gCounts + gTiles + 3u] = uint(rt.z) | (uint(rt.w) << 16);
      atomicMax(uTileCount[gCounts + gTiles + 5u], 1u);
      if (rt.z >= rt.x) dispatchAtLeast(uint((rt.z - rt.x + 1) * (rt.w - rt.y + 1)));
    } else if (kept) {
      uint j = atomicAdd(sCount, 1u);
      // Edge functions for the tile test, in pixels from corner 0 (positive inside; kept triangles are clockwise
      // in window coordinates).
      vec2 o = p0.xy, q1 = p1.xy - o, q2 = p2.xy - o;
      sTriangle[j] = t;
      sTiles[j] = tiles;
      sEdge[3u * j] = -edge(q1, q2);
      sEdge[3u * j + 1u] = -edge(q2, vec2(0.0));
      sEdge[3u * j + 2u] = -edge(vec2(0.0), q1);
      sBox[j] = box;
      sOrigin[j] = o;
    }
  }
  barrier();
  uint kept = sCount;
  uint tilesX = uint((uSize + kTile - 1) / kTile);
  for (uint j = 0u; j < kept; ++j) {  // the lanes share the tiles of each kept triangle's box
    ivec4 tb = sTiles[j];
    int w = tb.z - tb.x + 1, count = w * (tb.w - tb.y + 1);
    for (int k = int(lane); k < count; k += 64) {  // 16 times at most
      ivec2 tile = ivec2(tb.x + k % w, tb.y + k / w);
      if (!mayHold(j, tile)) continue;
      uint id = uint(tile.y) * tilesX + uint(tile.x);
      uint slot = atomicAdd(uTileCount[gCounts + id], 1u);
      if (slot < uint(uCapacity)) uTileList[(uint(gE.slot) * gTiles + id) * uint(uCapacity) + slot] = sTriangle[j];
      if (slot == 0u) activate(id);
    }
  }
}
