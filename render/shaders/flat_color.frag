#version 450 core
// flat_color.frag: writes the interpolated vertex colour.
in vec3 vColor;
out vec4 fragColor;
void main() { fragColor = vec4(vColor, 1.0); }
