#version 450 core
// shadow.vert: depth-only pass from the sun. in: aPosition; uniform uLightModelViewProjection.
layout(location = 0) in vec3 aPosition;
uniform mat4 uLightModelViewProjection;
void main() { gl_Position = uLightModelViewProjection * vec4(aPosition, 1.0); }
