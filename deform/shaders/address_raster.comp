#version 450 core
// address_raster.comp: step 2 of the compute pass B (address_bin.comp is step 1), for a group of the wave's
// sides: workgroup z takes entry uFirst + z (its slot: a layer of the targets; its other body's height map:
// uHeights[sampler]). Dispatched indirectly over the active tiles only (those step 1 gave something to test, all
// where a large triangle was listed; the other tiles hold "none" already), each workgroup taking every
// gl_NumWorkGroups.x-th of its side's. The same shader clears (uMode 1, every entry of the wave, before step 1
// resets the lists: the entry's mode 1, the tiles its last raster ran; 2, every tile; 0, none): a tile's
// pixels back to "none", so that no pass clears a whole map (glClearTexImage there ran at fragment-stage speed
// on NVIDIA's compute GPUs: 0.45 ms at 1024). One workgroup an 8 x 8 tile, one invocation a pixel: of
// the tile's triangles and the large ones (all triangles where its list overflowed),
// those whose edge
// functions are all >= 0 at the pixel centre and whose window depth lies in [0, 1] (GL's depth clipping) give a
// depth offset by the other body's height map as address.frag does, z' = clamp(z + (h - 0.5) k', 0, 1); the
// farthest one above 0 wins (depth GREATER against a depth buffer cleared to 0; on equal depths the triangle
// drawn first, the lower index). Written: the address (its texture coordinate; -1 where none) and its depth
// (1 where none), the targets the hardware pass would have left.
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 2) readonly buffer Setup { vec4 uSetup[]; };  // bindings::address::kSetup
layout(std430, binding = 3) readonly buffer TileCount { uint uTileCount[]; };  // bindings::address::kTileCount
layout(std430, binding = 4) readonly buffer TileList { uint uTileList[]; };  // bindings::address::kTileList
layout(std430, binding = 5) readonly buffer Large { uint uLarge[]; };  // bindings::address::kLarge
layout(std430, binding = 6) readonly buffer Active { uint uActive[]; };  // bindings::address::kActive
struct Entry {                // address_bin.comp's
  mat4 mvp;
  int slot, triangles;
  uint setup;
  int group;
  float reach;
  float bumpToDepth;          // the other body's k' / (zfar - znear)
  int sampler;                // its height map in uHeights
  int mode;                   // the clear: 0 nothing, 1 the tiles its last raster listed, 2 every tile
};
layout(std430, binding = 7) readonly buffer Entries { Entry uEntry[]; };  // bindings::address::kEntries
// Per slot, the pixels (x0, y0, x1, y1) X's texels may read (texel_gather.comp's cull): tiles outside get "none".
layout(std430, binding = 9) readonly buffer Reach { ivec4 uReach[]; };  // bindings::address::kReach
layout(binding = 0) uniform sampler2D uHeights[16];  // indexed by the workgroup's entry: dynamically uniform; bindings::address::kHeights
layout(rg32f, binding = 0) writeonly uniform image2DArray uAddress;  // bindings::address::kAddress
layout(r32f, binding = 1) writeonly uniform image2DArray uDepth;  // bindings::address::kDepth
uniform int uSize;
uniform int uCapacity;
uniform int uMode;           // 0: raster the active tiles; 1: clear
uniform int uFirst;          // workgroup z's entry: uFirst + z
Entry gE;
uint gCounts;                // the slot's TileCount offset
uint gTiles;
// The edge u -> v at p: the cross product (v - u) x (p - u), evaluated from the endpoint that sorts first, so that
// the triangle on the other side of the edge (which runs it v -> u) gets exactly the negation; `owns`: whether a
// pixel centre on the edge (0) belongs to this triangle (the one that runs the edge in the sorted direction).
float edgeAt(vec2 u, vec2 v, vec2 p, out bool owns) {
  owns = u.x < v.x || (u.x == v.x && u.y < v.y);
  vec2 a = owns ? u : v, b = owns ? v : u;
  precise float e = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
  return owns ? e : -e;
}
// Inside a clockwise triangle (the kept back faces): every edge value < 0, or 0 on an edge it owns.
bool inside(float e, bool owns) { return e < 0.0 || (e == 0.0 && owns); }
const int kTile = 8;  // pixels a side of a tile, as address_bin.comp's
shared vec4 sSetup[64 * 6];
shared uint sId[64];
void rasterTile(uint tile, uint tilesX) {
  uint lane = gl_LocalInvocationIndex;
  ivec2 pixel = ivec2(int(tile % tilesX), int(tile / tilesX)) * kTile + ivec2(gl_LocalInvocationID.xy);
  vec2 centre = vec2(pixel) + 0.5;
  uint listed = uTileCount[gCounts + tile];
  bool overflowed = listed > uint(uCapacity);
  uint total = overflowed ? uint(gE.triangles) : listed + uTileCount[gCounts + gTiles];
  ivec4 r = uReach[gE.slot];
  ivec2 corner = ivec2(int(tile % tilesX), int(tile / tilesX)) * kTile;
  if (any(greaterThan(corner, r.zw)) || any(lessThan(corner + kTile - 1, r.xy))) total = 0u;  // none here
  float best = 0.0;
  uint bestId = 0xffffffffu;
  vec2 bestUv = vec2(-1.0);
  for (uint base = 0u; base < total; base += 64u) {
    uint k = base + lane;
    if (k < total) {
      uint t = overflowed ? k
               : k < listed ? uTileList[(uint(gE.slot) * gTiles + tile) * uint(uCapacity) + k]
                            : uLarge[gE.setup + k - listed];
      sId[lane] = t;
      for (uint j = 0u; j < 6u; ++j) sSetup[lane * 6u + j] = uSetup[6u * (gE.setup + t) + j];
    }
    barrier();
    uint n = min(64u, total - base);
    for (uint j = 0u; j < n; ++j) {
      vec4 box = sSetup[j * 6u + 5u];
      if (any(lessThan(centre, box.xy)) || any(greaterThan(centre, box.zw))) continue;
      vec4 c01 = sSetup[j * 6u], c2z = sSetup[j * 6u + 1u];
      bool o0, o1, o2;
      float e0 = edgeAt(c01.zw, c2z.xy, centre, o0), e1 = edgeAt(c2z.xy, c01.xy, centre, o1),
            e2 = edgeAt(c01.xy, c01.zw, centre, o2);
      if (!(inside(e0, o0) && inside(e1, o1) && inside(e2, o2))) continue;
      float sum = e0 + e1 + e2;
      if (!(sum < 0.0)) continue;
      vec3 w = vec3(e0, e1, e2) / sum;
      float z = dot(w, vec3(c2z.zw, sSetup[j * 6u + 2u].x));
      if (z < 0.0 || z > 1.0) continue;
      vec4 uvs = sSetup[j * 6u + 3u];
      vec2 uv = w.x * uvs.xy + w.y * uvs.zw + w.z * sSetup[j * 6u + 4u].xy;
      float h = textureLod(uHeights[gE.sampler], uv, 0.0).r;
      float zz = clamp(z + (h - 0.5) * gE.bumpToDepth, 0.0, 1.0);
      uint id = sId[j];
      if (zz > best || (zz == best && bestId != 0xffffffffu && id < bestId)) {
        best = zz;
        bestId = id;
        bestUv = uv;
      }
    }
    barrier();
  }
  if (any(greaterThanEqual(pixel, ivec2(uSize)))) return;
  bool seen = bestId != 0xffffffffu;
  imageStore(uAddress, ivec3(pixel, gE.slot), vec4(bestUv, 0.0, 0.0));
  imageStore(uDepth, ivec3(pixel, gE.slot), vec4(seen ? best : 1.0));
}
void clearTile(uint tile, uint tilesX) {
  ivec2 pixel = ivec2(int(tile % tilesX), int(tile / tilesX)) * kTile + ivec2(gl_LocalInvocationID.xy);
  if (any(greaterThanEqual(pixel, ivec2(uSize)))) return;
  imageStore(uAddress, ivec3(pixel, gE.slot), vec4(-1.0, -1.0, 0.0, 0.0));
  imageStore(uDepth, ivec3(pixel, gE.slot), vec4(1.0));
}
void main() {
  gE = uEntry[uFirst + int(gl_WorkGroupID.z)];
  if (uMode == 1 && gE.mode == 0) return;  // its targets hold "none" already
  uint tilesX = uint((uSize + kTile - 1) / kTile);
  gTiles = tilesX * tilesX;
  gCounts = uint(gE.slot) * (gTiles + 6u);
  // The tiles to run: every tile of a rectangle (where large triangles are: the reach's tiles, kept by
  // address_bin.comp; the clear of a target in an unknown state: all), else the listed (active) ones.
  bool rect = (uMode == 1 && gE.mode == 2) || uTileCount[gCounts + gTiles + 5u] != 0u;
  uvec4 box = uvec4(0u, 0u, tilesX - 1u, tilesX - 1u);
  if (rect && !(uMode == 1 && gE.mode == 2)) {
    uint lo = uTileCount[gCounts + gTiles + 2u], hi = uTileCount[gCounts + gTiles + 3u];
    box = uvec4(lo & 0xffffu, lo >> 16, hi & 0xffffu, hi >> 16);
  }
  uint w = box.z >= box.x ? box.z - box.x + 1u : 0u;
  uint count = rect ? w * (box.w >= box.y ? box.w - box.y + 1u : 0u) : uTileCount[gCounts + gTiles + 1u];
  for (uint a = gl_WorkGroupID.x; a < count; a += gl_NumWorkGroups.x) {
    uint tile = rect ? (box.y + a / w) * tilesX + box.x + a % w : uActive[uint(gE.slot) * gTiles + a];
    if (uMode == 0) rasterTile(tile, tilesX);
    else clearTile(tile, tilesX);
  }
}
