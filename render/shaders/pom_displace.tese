#version 450 core
// pom_displace.tese: each new vertex moved along the normal by the height map, (h - 0.5) k, so dents change the
// silhouette; then what pom.vert hands the fragment stage (pom.frag, compiled with DISPLACED to skip its march).
// The direction is the normal averaged over the vertices at a position, so hard edges (a box's) do not split open.
layout(triangles, equal_spacing, ccw) in;
in vec3 tePosition[];
in vec3 teNormal[];
in vec2 teUV[];
in vec3 teColor[];
in vec2 teMaterialUV[];
in float teMaterial[];
in vec3 teSmoothNormal[];
layout(binding = 0) uniform sampler2D uHeight;  // renderer.cpp pom::kHeight
uniform float uBumpDepth;
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
  vec3 b = gl_TessCoord;
  vec3 p = b.x * tePosition[0] + b.y * tePosition[1] + b.z * tePosition[2];
  vec3 n = normalize(b.x * teNormal[0] + b.y * teNormal[1] + b.z * teNormal[2]);
  vec3 s = b.x * teSmoothNormal[0] + b.y * teSmoothNormal[1] + b.z * teSmoothNormal[2];
  s = length(s) > 1e-6 ? normalize(s) : n;
  vec2 uv = b.x * teUV[0] + b.y * teUV[1] + b.z * teUV[2];
  float d = (textureLod(uHeight, uv, 0.0).r - 0.5) * uBumpDepth;
  // The sun's shadow map holds the undisplaced meshes: look the shadow up where the vertex was, as POM does.
  vShadow = uLightViewProjection * (uModel * vec4(p, 1.0));
  p += s * (d / max(dot(s, n), 0.5));  // a depth d along n, reached along s
  vColor = b.x * teColor[0] + b.y * teColor[1] + b.z * teColor[2];
  vMaterialUV = b.x * teMaterialUV[0] + b.y * teMaterialUV[1] + b.z * teMaterialUV[2];
  vMaterial = int(round(teMaterial[0]));
  vec4 world = uModel * vec4(p, 1.0);
  vWorld = world.xyz;
  vNormal = uNormalMatrix * n;
  vUV = uv;
  gl_Position = uViewProjection * world;
}
