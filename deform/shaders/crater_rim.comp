#version 450 core
// crater_rim.comp: the paper's future work, "a crumple effect in which a dent
// leaves crater-like rings": the volume a dent pushed down is raised in a ring
// around it, so repeated hits build rims instead of flattening the map.
// Works in texture space over the touched region grown by the ring width W
// (atlas charts have uniform texel density, so texel distance is surface distance).
//   uMode 0: sum the dent's volume (texels whose new height is below the old)
//   uMode 1: ring weights w = 1 - d / W (d: texel distance to the nearest dented texel), summed
//   uMode 2: raise each ring texel by V * w / sum(w)
// in/out: uScratch (float bits), uHeight (old map); uSums[uSide * 2 + 0..1] fixed point 2^-20; W: uRimRing[uSide]
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 2) buffer Scratch { uint uScratch[]; };  // new heights, row by row from uScratchBase; bindings::kScratch
layout(binding = 1) uniform sampler2D uHeight;  // bindings::rim::kHeight
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };  // bindings::kRegion
layout(std430, binding = 4) buffer Sums { uint uSums[]; };  // bindings::rim::kSums
layout(std430, binding = 5) buffer Rim { uint uRimIndirect[6]; int uRimRing[2]; };  // rim_dispatch.comp's; bindings::rim::kRim
uniform int uSide;
uniform int uMode;
uniform int uResolution;
uniform uint uScratchBase;
uint at(ivec2 p) { return uScratchBase + uint(p.y * uResolution + p.x); }
const float kFixed = 1048576.0;
bool dented(ivec2 p) { return uintBitsToFloat(uScratch[at(p)]) < texelFetch(uHeight, p, 0).r; }
void main() {
  ivec4 r = uRegion[uSide];
  if (r.z < r.x) return;
  int uRing = uRimRing[uSide];  // W in texels
  ivec2 lo = max(r.xy - uRing, ivec2(0)), hi = min(r.zw + uRing, ivec2(uResolution - 1));
  ivec2 p = lo + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThan(p, hi))) return;
  float old = texelFetch(uHeight, p, 0).r;
  if (uMode == 0) {
    float nh = uintBitsToFloat(uScratch[at(p)]);  // +infinity where untouched
    if (nh < old) atomicAdd(uSums[uSide * 2], uint((old - nh) * kFixed + 0.5));
    return;
  }
  if (dented(p)) return;
  float best = float(uRing) + 1.0;
  for (int dy = -uRing; dy <= uRing; ++dy)
    for (int dx = -uRing; dx <= uRing; ++dx) {
      ivec2 q = p + ivec2(dx, dy);
      if (any(lessThan(q, r.xy)) || any(greaterThan(q, r.zw))) continue;
      float d = length(vec2(dx, dy));
      if (d < best && dented(q)) best = d;
    }
  if (best > float(uRing)) return;
  float w = 1.0 - best / float(uRing + 1);
  if (uMode == 1) {
    atomicAdd(uSums[uSide * 2 + 1], uint(w * kFixed + 0.5));
    return;
  }
  float volume = float(uSums[uSide * 2]) / kFixed, weights = max(float(uSums[uSide * 2 + 1]) / kFixed, 1e-6);
  float raised = min(old + volume * w / weights, 1.0);
  uScratch[at(p)] = floatBitsToUint(raised);
}
