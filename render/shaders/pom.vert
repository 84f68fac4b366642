#version 450 core
// pom.vert: world-space position, normal and uv for the parallax-occlusion pass.
// in:  aPosition, aNormal, aUV (shape frame), aColor
// out: vWorld, vNormal, vUV, vShadow (sun clip space), vColor
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec2 aUV;
layout(location = 3) in vec3 aColor;  // vertex colour (sRGB), white where the mesh has none
layout(location = 4) in vec2 aMaterialUV;  // the mesh file's own uv (its look's images)
layout(location = 5) in float aMaterial;   // its material in the look, -1 none
uniform mat4 uModel;
uniform mat3 uNormalMatrix;
uniform mat4 uViewProjection;
uniform mat4 uLightViewProjection;
out vec3 vWorld;
out vec3 vNormal;
out vec2 vUV;
out vec4 vShadow;
out vec3 vColor;
out vec2 vMaterialUV;
flat out int vMaterial;
void main() {
  vColor = aColor;
  vMaterialUV = aMaterialUV;
  vMaterial = int(round(aMaterial));
  vec4 world = uModel * vec4(aPosition, 1.0);
  vWorld = world.xyz;
  vNormal = uNormalMatrix * aNormal;
  vUV = aUV;
  vShadow = uLightViewProjection * world;
  gl_Position = uViewProjection * world;
}
