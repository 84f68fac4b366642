#version 450 core
// address.frag: colour = texture coordinate, no lighting; depth offset by the
// height map scaled by k' (bump_depth_collide).
// The paper writes h * k'; we use (h - 0.5) * k' so that a flat map (0.5)
// changes nothing and only real bumps and dents move the surface.
// Pass A (uSign = -1): X's front faces, bumps rise towards the camera.
// Pass B (uSign = +1): the other body's back faces, its bumps reach deeper into X.
// in:  vUV, vNormal; uniforms uHeight, uBumpToDepth = k' / (zfar - znear), uSign
// out: outAddress (RG32F), outDepth (R32F copy of the written depth), outNormal (world normal)
in vec2 vUV;
in vec3 vNormal;
layout(binding = 0) uniform sampler2D uHeight;  // bindings::address::kHeights
uniform float uBumpToDepth;
uniform float uSign;
layout(location = 0) out vec2 outAddress;
layout(location = 1) out float outDepth;
layout(location = 2) out vec4 outNormal;
void main() {
  float h = texture(uHeight, vUV).r;
  float z = clamp(gl_FragCoord.z + uSign * (h - 0.5) * uBumpToDepth, 0.0, 1.0);
  gl_FragDepth = z;
  outAddress = vUV;
  outDepth = z;
  outNormal = vec4(normalize(vNormal), 1.0);
}
