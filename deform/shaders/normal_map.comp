#version 450 core
// normal_map.comp: tangent-space normals from the height map by central
// differences, over a region (the texels a dent touched, grown by one).
//   n = normalize(-dh/du * k / texel, -dh/dv * k / texel, 1), stored as n * 0.5 + 0.5
// in:  uHeight, uNormalRegion[uSide] (or uFullRegion when uSide < 0); out: uNormal (rgba8)
layout(local_size_x = 16, local_size_y = 16) in;
layout(binding = 0) uniform sampler2D uHeight;
layout(rgba8, binding = 1) uniform writeonly image2D uNormal;
layout(std430, binding = 3) buffer NormalRegion { ivec4 uNormalRegion[]; };
uniform int uSide;
uniform ivec4 uFullRegion;
uniform int uResolution;
uniform float uSlopeScale;  // k / (2 * texel size in metres)
float h(ivec2 p) { return texelFetch(uHeight, clamp(p, ivec2(0), ivec2(uResolution - 1)), 0).r; }
void main() {
  ivec4 r = uSide >= 0 ? uNormalRegion[uSide] : uFullRegion;
  ivec2 p = r.xy + ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThan(p, r.zw))) return;
  float dx = (h(p + ivec2(1, 0)) - h(p - ivec2(1, 0))) * uSlopeScale;
  float dy = (h(p + ivec2(0, 1)) - h(p - ivec2(0, 1))) * uSlopeScale;
  vec3 n = normalize(vec3(-dx, -dy, 1.0));
  imageStore(uNormal, p, vec4(n * 0.5 + 0.5, 1.0));
}
