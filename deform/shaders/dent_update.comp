#version 450 core
// dent_update.comp: the bump-map update of section 4.2 on the GPU.
// For each address-map pixel where both passes wrote and dD = D_other - D_X > 0:
//   h' = clamp(h - dD (zfar - znear) / k, 0, 1) at X's texel addressed by the pixel;
// several pixels addressing one texel: the deepest wins (imageAtomicMin on the
// float bits, which order like the values since heights are >= 0).
// in:  address/depth/normal maps of both passes, X's height map
// out: uScratch (float bits, +infinity where untouched), uRegion[uSide] grows to the touched texels
layout(local_size_x = 16, local_size_y = 16) in;
layout(binding = 0) uniform sampler2D uAddressX;  // bindings::update::kAddressX
layout(binding = 1) uniform sampler2D uDepthX;  // bindings::update::kDepthX
layout(binding = 2) uniform sampler2D uAddressOther;  // bindings::update::kAddressOther
layout(binding = 3) uniform sampler2D uDepthOther;  // bindings::update::kDepthOther
layout(binding = 4) uniform sampler2D uNormalX;  // bindings::update::kNormalX
layout(binding = 5) uniform sampler2D uHeightX;  // bindings::update::kHeightX
layout(std430, binding = 2) buffer Scratch { uint uScratch[]; };  // new heights, row by row from uScratchBase; bindings::kScratch
uniform uint uScratchBase;
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };  // bindings::kRegion
uniform int uSide;
uniform ivec2 uSize;
uniform int uResolution;
uniform float uDepthToHeight;  // (zfar - znear) / k
uniform int uTangentMode;      // 0 none, 1 multiply by |N . N_C|, 2 divide with a floor
uniform float uTangentFloor;
uniform float uPushDepth;      // the deepest a texel is dented, window depth (SideUpdate::pushDepth)
uniform vec3 uViewNormal;      // N_C as owned by X (towards the camera)
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(p, uSize))) return;
  vec2 a = texelFetch(uAddressX, p, 0).rg;
  vec2 o = texelFetch(uAddressOther, p, 0).rg;
  if (a.x < 0.0 || o.x < 0.0) return;
  float dD = texelFetch(uDepthOther, p, 0).r - texelFetch(uDepthX, p, 0).r;
  if (!(dD > 0.0)) return;
  dD = min(dD, uPushDepth);  // an overlap beyond X's advance (and the bumps) was there before the push
  if (uTangentMode != 0) {
    float c = abs(dot(normalize(texelFetch(uNormalX, p, 0).xyz), uViewNormal));
    dD = uTangentMode == 1 ? dD * c : dD / max(c, uTangentFloor);
  }
  ivec2 t = clamp(ivec2(floor(a * float(uResolution))), ivec2(0), ivec2(uResolution - 1));
  float h = texelFetch(uHeightX, t, 0).r;
  // A multiply, then a subtraction, each rounded (`precise`: no driver fuses
  // them), as the read-back path computes on the CPU: the two paths give
  // bit-identical maps on every driver. (An fma() is not one either: Mesa's
  // llvmpipe splits it into a multiply and an add, NVIDIA's fuses it.)
  precise float drop = dD * uDepthToHeight;
  precise float h2 = clamp(h - drop, 0.0, 1.0);
  if (!(h2 < h)) return;
  atomicMin(uScratch[uScratchBase + uint(t.y * uResolution + t.x)], floatBitsToUint(h2));
  atomicMin(uRegion[uSide].x, t.x);
  atomicMin(uRegion[uSide].y, t.y);
  atomicMax(uRegion[uSide].z, t.x);
  atomicMax(uRegion[uSide].w, t.y);
}
