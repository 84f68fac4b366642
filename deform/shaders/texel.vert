#version 450 core
// texel.vert: the per-texel gather (our path past the paper's section 6 gaps).
// X's mesh is drawn in its own texture space, so that each fragment is one
// texel of its height map; what travels with it is the surface point in the
// deformation camera's clip space (affine over a triangle: exact per texel).
// in:  aPosition, aNormal, aUV (shape frame)
// out: vClip (the address camera's clip space, orthographic: w = 1), vNormal (world), vUV
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec2 aUV;
uniform mat4 uModelViewProjection;
uniform mat3 uNormalToWorld;
out vec3 vClip;
out vec3 vNormal;
out vec2 vUV;
void main() {
  vClip = (uModelViewProjection * vec4(aPosition, 1.0)).xyz;
  vNormal = uNormalToWorld * aNormal;
  vUV = aUV;
  gl_Position = vec4(aUV * 2.0 - 1.0, 0.0, 1.0);
}
