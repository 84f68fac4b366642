#version 450 core
// sky.vert: a triangle covering the viewport at the far plane (drawn after the
// bodies with GL_LEQUAL, so only uncovered pixels run the sky).
// out: vNdc in [-1,1]^2
out vec2 vNdc;
void main() {
  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2) * 2.0 - 1.0;
  vNdc = p;
  gl_Position = vec4(p, 1.0, 1.0);
}
