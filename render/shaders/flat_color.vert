#version 450 core
// flat_color.vert: a position and a colour per vertex, no transform.
// in:  aPosition (clip space xy), aColor
// out: vColor
layout(location = 0) in vec2 aPosition;
layout(location = 1) in vec3 aColor;
out vec3 vColor;
void main() {
  vColor = aColor;
  gl_Position = vec4(aPosition, 0.0, 1.0);
}
