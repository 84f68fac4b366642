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
// With a crease bevel (uCrease 1), per corner: its node's place (deform::SurfaceMaps::crease) less the move its
// own chart's height would make it (pom_displace.tese adds these, interpolated, to each point's own move), and the
// same by the other chart's heights for the seam edge whose first end it is (edge (i + 2) % 3: the twin's first
// uv) and whose second end it is (edge (i + 1) % 3: the twin's second uv).
out vec3 teAdd[];
out vec3 teTwinAdd1[];
out vec3 teTwinAdd2[];
uniform vec2 uViewport;       // pixels
uniform float uMaxLevel;

// The move corner i would make by the height at uvAt (read as its own vertex reads it there): along its averaged
// normal, (h - 0.5) k.
vec3 cornerMove(int i, vec2 uvAt) {
  gSegment = segmentAt(tcPosition[i]);
  vec3 s = length(tcSmoothNormal[i]) > 1e-6 ? normalize(tcSmoothNormal[i]) : tcNormal[i];
  return s * ((heightNear(uvAt) - 0.5) * uBumpDepth);
}

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
  if (uCrease != 0) {
    int i = gl_InvocationID;
    vec3 place = crease[vertexNode[int(tcIndex[i])]].xyz;
    teAdd[gl_InvocationID] = place - cornerMove(i, tcUV[i]);
    teTwinAdd1[gl_InvocationID] = teTwinAdd2[gl_InvocationID] = vec3(0.0);
    if (uSeams != 0) {
      vec4 first = seamEdge[3 * gl_PrimitiveID + (i + 2) % 3], second = seamEdge[3 * gl_PrimitiveID + (i + 1) % 3];
      if (first.x >= 0.0) teTwinAdd1[gl_InvocationID] = place - cornerMove(i, first.xy);
      if (second.x >= 0.0) teTwinAdd2[gl_InvocationID] = place - cornerMove(i, second.zw);
    }
  }
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
