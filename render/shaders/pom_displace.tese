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
in float teIndex[];
in vec3 teAdd[];      // pom_displace.tesc (with a crease bevel): per corner, its node's place less its own move
in vec3 teTwinAdd1[];  // the same by the other chart's heights, for the edge whose first end it is (edge (i + 2) % 3)
in vec3 teTwinAdd2[];  // and for the edge whose second end it is (edge (i + 1) % 3)
uniform mat3 uNormalMatrix;
uniform mat4 uLightViewProjection;
out vec3 vWorld;
out vec3 vNormal;
out vec2 vUV;
out vec4 vShadow;
out vec3 vColor;
out vec2 vMaterialUV;
flat out int vMaterial;
out float vHeightLod;  // the level of the height map the vertex was moved by (pom.frag shades with its slopes)

void main() {
  vec3 b = gl_TessCoord;
  vec3 p = b.x * tePosition[0] + b.y * tePosition[1] + b.z * tePosition[2];
  vec3 n = normalize(b.x * teNormal[0] + b.y * teNormal[1] + b.z * teNormal[2]);
  vec3 s = b.x * teSmoothNormal[0] + b.y * teSmoothNormal[1] + b.z * teSmoothNormal[2];
  s = length(s) > 1e-6 ? normalize(s) : n;
  vec2 uv = b.x * teUV[0] + b.y * teUV[1] + b.z * teUV[2];
  // Without a crease bevel, on a seam (a point of an edge, or a corner, that another chart holds too) the lower of
  // the charts' heights there: each side reads both and moves its point alike, so the seam stays closed where the
  // charts' dents differ (a crease across a hard edge would tear it open into spikes).
  gSegment = segmentAt(p);
  float hOwn = heightNear(uv);
  float h = hOwn;
  vHeightLod = gLod;
  if (uSeams != 0 && uCrease == 0) {
    int zeros = int(b.x == 0.0) + int(b.y == 0.0) + int(b.z == 0.0);
    if (zeros == 2) {
      int v = int(teIndex[b.x == 1.0 ? 0 : b.y == 1.0 ? 1 : 2]);
      vec4 first = seamVertex[2 * v], second = seamVertex[2 * v + 1];
      int others = int(second.z);
      if (others > 0) h = min(h, heightNear(first.xy));
      if (others > 1) h = min(h, heightNear(first.zw));
      if (others > 2) h = min(h, heightNear(second.xy));
    } else if (zeros == 1) {
      int e = b.x == 0.0 ? 0 : b.y == 0.0 ? 1 : 2;  // the edge opposite corner e
      vec4 twin = seamEdge[3 * gl_PrimitiveID + e];
      if (twin.x >= 0.0) h = min(h, heightNear(b[(e + 1) % 3] * twin.xy + b[(e + 2) % 3] * twin.zw));
    }
  }
  float d = (h - 0.5) * uBumpDepth;
  // The sun's shadow map holds the undisplaced meshes: look the shadow up where the vertex was, as POM does.
  vShadow = uLightViewProjection * (uModel * vec4(p, 1.0));
  if (uCrease != 0) {
    // With a crease bevel (deform::SurfaceMaps::crease: per node, where it is drawn): each corner is drawn there,
    // and each point moves by its own height plus, interpolated over the triangle, what its corners add to theirs,
    // so a chart left behind by a crushed neighbour follows it in a bevel instead of standing as a wall. A point
    // of a seam takes the deeper of the two charts' moves, which each side computes alike.
    int zeros = int(b.x == 0.0) + int(b.y == 0.0) + int(b.z == 0.0);
    vec3 moved;
    if (zeros == 2) {
      moved = crease[vertexNode[int(teIndex[b.x == 1.0 ? 0 : b.y == 1.0 ? 1 : 2])]].xyz;
    } else {
      vec3 own = s * ((hOwn - 0.5) * uBumpDepth);
      moved = own + b.x * teAdd[0] + b.y * teAdd[1] + b.z * teAdd[2];
      if (zeros == 1 && uSeams != 0) {
        int e = b.x == 0.0 ? 0 : b.y == 0.0 ? 1 : 2;  // the edge opposite corner e
        vec4 twin = seamEdge[3 * gl_PrimitiveID + e];
        if (twin.x >= 0.0) {
          int c1 = (e + 1) % 3, c2 = (e + 2) % 3;
          vec3 other = s * ((heightNear(b[c1] * twin.xy + b[c2] * twin.zw) - 0.5) * uBumpDepth) +
                       b[c1] * teTwinAdd1[c1] + b[c2] * teTwinAdd2[c2];
          if (dot(other, s) < dot(moved, s) || (dot(other, s) == dot(moved, s) && other.x < moved.x)) moved = other;
        }
      }
    }
    p += moved;
  } else {
    p += s * (d / max(dot(s, n), 0.5));  // a depth d along n, reached along s
  }
  vColor = b.x * teColor[0] + b.y * teColor[1] + b.z * teColor[2];
  vMaterialUV = b.x * teMaterialUV[0] + b.y * teMaterialUV[1] + b.z * teMaterialUV[2];
  vMaterial = int(round(teMaterial[0]));
  vec4 world = uModel * vec4(p, 1.0);
  vWorld = world.xyz;
  vNormal = uNormalMatrix * n;
  vUV = uv;
  gl_Position = uViewProjection * world;
}
