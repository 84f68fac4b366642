#version 450 core
// texel_gather.frag: the bump-map update of section 4.2, gathered per texel.
// The texel's surface point, raised or lowered by its height (k', as address
// pass A does), is looked up in the other body's depth map like a shadow-map
// lookup: where the other body's farthest back face lies beyond it (dD > 0),
//   h' = clamp(h - dD (zfar - znear) / k, 0, 1)
// at this very texel. The other body's depth is interpolated bilinearly between
// the four nearest address-map pixels where all four saw it (the nearest one at
// its silhouette), so the address map's size trades the dent's accuracy, never
// its continuity: every texel of the footprint gets its value.
// A texel whose centre lies outside the triangle (conservative rasterisation) dents by the smaller of its
// extrapolated point's depth and that of the triangle's point nearest it (texel_point.glsl).
// in:  gClip, gNormal, gBox, the triangle (flat); X's height map, the other body's depth pass
// out: uScratch (float bits, minimum), uRegion[uSide] grows to the touched texels
in vec3 gClip;
in vec3 gNormal;
flat in vec4 gBox;
flat in vec4 gTri01;
flat in vec3 gTri2;
flat in vec3 gCorner0;
flat in vec3 gCorner1;
flat in vec3 gCorner2;
#include "texel_point.glsl"
layout(binding = 2) uniform sampler2D uAddressOther;  // bindings::update::kAddressOther
layout(binding = 3) uniform sampler2D uDepthOther;  // bindings::update::kDepthOther
layout(binding = 5) uniform sampler2D uHeightX;  // bindings::update::kHeightX
layout(std430, binding = 2) buffer Scratch { uint uScratch[]; };  // new heights, row by row from uScratchBase; bindings::kScratch
uniform uint uScratchBase;
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };  // bindings::kRegion
uniform int uSide;
uniform int uSize;             // address map (pixels)
uniform int uResolution;       // X's map (texels)
uniform float uBumpToDepth;    // X's k' / (zfar - znear)
uniform float uDepthToHeight;  // (zfar - znear) / k
uniform int uTangentMode;      // 0 none, 1 multiply by |N . N_C|, 2 divide with a floor
uniform float uTangentFloor;
uniform float uPushDepth;      // the deepest a texel is dented, window depth (SideUpdate::pushDepth)
uniform vec3 uViewNormal;      // N_C as owned by X (towards the camera)
bool seen(ivec2 q) { return all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(uSize))) && texelFetch(uAddressOther, q, 0).r >= 0.0; }
float depthAt(ivec2 q) { return texelFetch(uDepthOther, q, 0).r; }
// How far the other body's depth lies beyond X's surface point `clip` (window depth; <= 0: not inside it, or not
// seen there), X's point raised by its height h.
float beyond(vec3 clip, float h) {
  // Pixel coordinates in the address map (pixel centres at integers).
  vec2 px = (clip.xy * 0.5 + 0.5) * float(uSize) - 0.5;
  if (any(lessThan(px, vec2(-0.5))) || any(greaterThan(px, vec2(float(uSize) - 0.5)))) return -1.0;
  ivec2 b = ivec2(floor(px));
  vec2 w = px - vec2(b);
  float dO;
  if (seen(b) && seen(b + ivec2(1, 0)) && seen(b + ivec2(0, 1)) && seen(b + ivec2(1, 1))) {
    dO = mix(mix(depthAt(b), depthAt(b + ivec2(1, 0)), w.x), mix(depthAt(b + ivec2(0, 1)), depthAt(b + ivec2(1, 1)), w.x), w.y);
  } else {
    ivec2 q = ivec2(floor(px + 0.5));
    if (!seen(q)) return -1.0;
    dO = depthAt(q);
  }
  float zX = clamp(clip.z * 0.5 + 0.5 - (h - 0.5) * uBumpToDepth, 0.0, 1.0);
  return dO - zX;
}
void main() {
  vec2 f = gl_FragCoord.xy;
  if (any(lessThan(f, gBox.xy)) || any(greaterThan(f, gBox.zw))) return;
  ivec2 t = ivec2(f);
  if (any(lessThan(t, ivec2(0))) || any(greaterThanEqual(t, ivec2(uResolution)))) return;
  float h = texelFetch(uHeightX, t, 0).r;
  float dD = beyond(gClip, h);
  if (!(dD > 0.0)) return;
  vec3 w = texelBarycentrics(f, gTri01.xy, gTri01.zw, gTri2.xy, gTri2.z);
  if (any(lessThan(w, vec3(0.0)))) {
    vec3 wn = nearestBarycentrics(f, gTri01.xy, gTri01.zw, gTri2.xy, w);
    dD = min(dD, beyond(wn.x * gCorner0 + wn.y * gCorner1 + wn.z * gCorner2, h));
    if (!(dD > 0.0)) return;
  }
  // X advanced by d into the other (retracted first to contact): an overlap beyond d and the reach of
  // the maps' bumps was there before the push (a pose the contact did not measure) and is not this
  // event's.
  dD = min(dD, uPushDepth);
  if (uTangentMode != 0) {
    float c = abs(dot(normalize(gNormal), uViewNormal));
    dD = uTangentMode == 1 ? dD * c : dD / max(c, uTangentFloor);
  }
  float h2 = clamp(fma(-dD, uDepthToHeight, h), 0.0, 1.0);
  if (!(h2 < h)) return;
  atomicMin(uScratch[uScratchBase + uint(t.y * uResolution + t.x)], floatBitsToUint(h2));
  // Most fragments leave the region as it is: read before the atomics.
  ivec4 r = uRegion[uSide];
  if (t.x < r.x) atomicMin(uRegion[uSide].x, t.x);
  if (t.y < r.y) atomicMin(uRegion[uSide].y, t.y);
  if (t.x > r.z) atomicMax(uRegion[uSide].z, t.x);
  if (t.y > r.w) atomicMax(uRegion[uSide].w, t.y);
}
