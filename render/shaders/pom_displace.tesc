#version 450 core
// pom_displace.tesc: tessellation levels from each edge's length on screen (uSegmentPixels a segment, up to
// uMaxLevel); an edge's level depends only on its two ends, so neighbouring triangles agree and no cracks open.
// Triangles wholly outside one side of the view (with a margin for the displacement) are dropped.
layout(vertices = 3) out;
in vec3 tcPosition[];
in vec3 tcNormal[];
in vec2 tcUV[];
in vec3 tcColor[];
in vec2 tcMaterialUV[];
in float tcMaterial[];
in vec3 tcSmoothNormal[];
in float tcIndex[];
out vec3 tePosition[];
out vec3 teNormal[];
out vec2 teUV[];
out vec3 teColor[];
out vec2 teMaterialUV[];
out float teMaterial[];
out vec3 teSmoothNormal[];
out float teIndex[];
uniform mat4 uModel;
uniform mat4 uViewProjection;
uniform vec2 uViewport;       // pixels
uniform float uSegmentPixels;  // target length of a segment on screen
uniform float uMaxLevel;
uniform float uBumpDepth;

float level(vec4 a, vec4 b) {
  if (a.w <= 1e-3 || b.w <= 1e-3) return uMaxLevel;  // crosses the eye's plane: finest
  vec2 pa = a.xy / a.w * 0.5 * uViewport, pb = b.xy / b.w * 0.5 * uViewport;
  return clamp(distance(pa, pb) / uSegmentPixels, 1.0, uMaxLevel);
}

void main() {
  tePosition[gl_InvocationID] = tcPosition[gl_InvocationID];
  teNormal[gl_InvocationID] = tcNormal[gl_InvocationID];
  teUV[gl_InvocationID] = tcUV[gl_InvocationID];
  teColor[gl_InvocationID] = tcColor[gl_InvocationID];
  teMaterialUV[gl_InvocationID] = tcMaterialUV[gl_InvocationID];
  teMaterial[gl_InvocationID] = tcMaterial[gl_InvocationID];
  teSmoothNormal[gl_InvocationID] = tcSmoothNormal[gl_InvocationID];
  teIndex[gl_InvocationID] = tcIndex[gl_InvocationID];
  if (gl_InvocationID == 0) {
    vec4 c[3];
    for (int i = 0; i < 3; ++i) c[i] = uViewProjection * (uModel * vec4(tcPosition[i], 1.0));
    // Outside: every corner beyond the same clip plane, with the displacement's reach as a margin.
    float margin = 0.5 * uBumpDepth;
    bool outside = false;
    for (int axis = 0; axis < 3 && !outside; ++axis) {
      bool allLow = true, allHigh = true;
      for (int i = 0; i < 3; ++i) {
        float w = c[i].w + margin * 4.0;
        allLow = allLow && c[i][axis] < -w;
        allHigh = allHigh && c[i][axis] > w;
      }
      outside = allLow || allHigh;
    }
    if (outside) {
      gl_TessLevelOuter[0] = gl_TessLevelOuter[1] = gl_TessLevelOuter[2] = 0.0;
      gl_TessLevelInner[0] = 0.0;
    } else {
      // Outer level i is the edge opposite corner i.
      float e0 = level(c[1], c[2]), e1 = level(c[2], c[0]), e2 = level(c[0], c[1]);
      gl_TessLevelOuter[0] = e0;
      gl_TessLevelOuter[1] = e1;
      gl_TessLevelOuter[2] = e2;
      gl_TessLevelInner[0] = max(e0, max(e1, e2));
    }
  }
}
