#version 450 core
// visibility.vert: positions alone, for the visibility buffer (pom_shade.comp shades from it).
layout(location = 0) in vec3 aPosition;
uniform mat4 uModelViewProjection;
void main() { gl_Position = uModelViewProjection * vec4(aPosition, 1.0); }
