#version 450 core
// address_view.frag: shows an address map (uv in RG, -1 where nothing was drawn).
in vec2 vUV;
layout(binding = 0) uniform sampler2D uAddress;  // renderer.cpp kSource
out vec4 fragColor;
void main() {
  vec2 a = texture(uAddress, vUV).rg;
  fragColor = a.x < 0.0 ? vec4(0.0, 0.0, 0.3, 1.0) : vec4(a, 0.0, 1.0);
}
