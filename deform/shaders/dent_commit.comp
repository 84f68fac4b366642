#version 450 core
// dent_commit.comp: writes the new heights of one side into its height map,
// over the touched region only, counts what changed, and puts the scratch
// back to +infinity (untouched) there, ready for the next deformation.
// in:  uScratch (float bits), uRegion[uSide]; out: uHeight, uStats[uStatsIndex * 4 ..]
//   stats: texels changed, max dent (float bits, m), texels saturated at 0
layout(local_size_x = 16, local_size_y = 16) in;
layout(std430, binding = 2) buffer Scratch { uint uScratch[]; };  // new heights, row by row from uScratchBase
layout(r32f, binding = 1) uniform image2D uHeight;
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };
layout(std430, binding = 1) buffer Stats { uint uStats[]; };
uniform int uSide;
uniform int uStatsIndex;
uniform float uBumpDepth;
uniform uint uScratchBase;
uniform int uResolution;
void main() {
  ivec4 r = uRegion[uSide];
  ivec2 p = r.xy + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThan(p, r.zw))) return;
  uint at = uScratchBase + uint(p.y * uResolution + p.x);
  uint bits = uScratch[at];
  if (bits == 0x7f800000u) return;  // untouched
  uScratch[at] = 0x7f800000u;
  float nh = uintBitsToFloat(bits);
  float oh = imageLoad(uHeight, p).r;
  if (nh == oh) return;
  imageStore(uHeight, p, vec4(nh));
  uint base = uint(uStatsIndex) * 4u;
  atomicAdd(uStats[base + 0u], 1u);
  if (nh < oh) atomicMax(uStats[base + 1u], floatBitsToUint((oh - nh) * uBumpDepth));
  if (nh <= 0.0) atomicAdd(uStats[base + 2u], 1u);
}
