#version 450 core
// address.vert: the address-map passes (Wrotek et al. figure 11, RenderPassA/B).
// in:  aPosition, aNormal, aUV (shape frame)
// out: vUV (the address), vNormal (world)
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec2 aUV;
uniform mat4 uModelViewProjection;
uniform mat3 uNormalToWorld;
out vec2 vUV;
out vec3 vNormal;
void main() {
  vUV = aUV;
  vNormal = uNormalToWorld * aNormal;
  gl_Position = uModelViewProjection * vec4(aPosition, 1.0);
}
