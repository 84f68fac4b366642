#version 450 core
// crease_bevel.comp: the displaced renderer moves each vertex along its averaged normal by its height; where a
// map is crushed on one side of a hard edge and not on the other (a side panel pushed 10 cm in, the underside
// beside it untouched), the untouched side's nodes would stay where they were, a shelf standing out of the
// crushed panel with a one-segment wall for an edge. This makes each node follow a deeper neighbour: no node
// ends further from where a neighbour that moved more went than the edge between them is long, so the crease
// becomes a bevel of 1:1 (Deformer::creaseBevel). Per node n (GpuMesh::nodeUvs, nodeLinks, nodeFrames), by
// uStage:
//   0: uOwn[n] = uTo[n] = its own move, s_n (h_n - 0.5) k, h_n the lowest height at its uvs (as the renderer reads
//      a point that deep)
//   1: uTo[n] = uFrom[n] brought, for each neighbour m whose move is longer, in the lists' order, to within
//      |n m| of uFrom[m]: one round of the relaxation
//   2: uTo[n] = uFrom[n], where the renderer draws it (xyz, from where it lies; w 0)
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer NodeUvs { uint uUvs[]; };        // bindings::bevel::kUvs
layout(std430, binding = 1) readonly buffer NodeLinks { uint uLinks[]; };    // bindings::bevel::kLinks
layout(std430, binding = 2) buffer Own { vec4 uOwn[]; };                     // bindings::bevel::kOwn
layout(std430, binding = 3) readonly buffer From { vec4 uFrom[]; };          // bindings::bevel::kFrom
layout(std430, binding = 4) writeonly buffer To { vec4 uTo[]; };             // bindings::bevel::kTo
layout(std430, binding = 5) readonly buffer NodeFrames { vec4 uFrames[]; };  // bindings::bevel::kFrames
layout(binding = 0) uniform sampler2D uHeight;                               // bindings::bevel::kHeight
uniform int uStage;
uniform int uNodes;
uniform float uBumpDepth;  // k (m)
uniform float uTexel;      // a texel's size on the surface (m)
// As pom_displace.tese's heightNear for a vertex close by: filtered over as far as the surface moves there.
float heightNear(vec2 uv) {
  float coarse = textureLod(uHeight, uv, log2(max(0.5 * uBumpDepth / uTexel, 1.0))).r;
  float reach = abs(coarse - 0.5) * uBumpDepth;
  return textureLod(uHeight, uv, log2(max(reach / uTexel, 1.0))).r;
}
void main() {
  uint n = gl_GlobalInvocationID.x;
  uint nodes = uint(uNodes);
  if (n >= nodes) return;
  if (uStage == 0) {
    float h = 2.0;
    for (uint i = uUvs[n]; i < uUvs[n + 1u]; ++i) {
      uint at = nodes + 1u + 2u * i;
      h = min(h, heightNear(vec2(uintBitsToFloat(uUvs[at]), uintBitsToFloat(uUvs[at + 1u]))));
    }
    vec4 own = vec4(uFrames[2u * n + 1u].xyz * ((h - 0.5) * uBumpDepth), 0.0);
    uOwn[n] = own;
    uTo[n] = own;
  } else if (uStage == 1) {
    vec3 mine = uFrom[n].xyz;
    float reach = length(mine);
    vec3 moved = mine;
    for (uint i = uLinks[n]; i < uLinks[n + 1u]; ++i) {
      uint at = nodes + 1u + 2u * i;
      vec3 other = uFrom[uLinks[at]].xyz;
      if (!(length(other) > reach)) continue;
      float edge = uintBitsToFloat(uLinks[at + 1u]);
      vec3 apart = moved - other;
      float gap = length(apart);
      if (gap > edge) moved = other + apart * (edge / gap);
    }
    uTo[n] = vec4(moved, 0.0);
  } else {
    uTo[n] = vec4(uFrom[n].xyz, 0.0);
  }
}
