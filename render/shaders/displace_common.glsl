// displace_common.glsl: what pom_displace.tesc and pom_displace.tese share (the renderer puts it after their
// #version line): the height map, the seam and crease tables, the view, and heightNear.
layout(binding = 0) uniform sampler2D uHeight;  // renderer.cpp pom::kHeight
// Where the mesh's uv charts meet (deform::GpuMesh::seamEdges, seamVertices), read where uSeams is 1.
layout(std430, binding = 2) readonly buffer SeamEdges { vec4 seamEdge[]; };        // renderer pom::kSeamEdges
layout(std430, binding = 3) readonly buffer SeamVertices { vec4 seamVertex[]; };  // renderer pom::kSeamVertices
uniform int uSeams;
// The crease bevel (deform::SurfaceMaps::crease, per node) and each vertex's node, read where uCrease is 1.
layout(std430, binding = 4) readonly buffer VertexNodes { uint vertexNode[]; };  // renderer pom::kVertexNodes
layout(std430, binding = 5) readonly buffer Crease { vec4 crease[]; };           // renderer pom::kCrease
uniform int uCrease;
uniform float uBumpDepth;
uniform float uSegmentPixels;  // the tessellation's segment on screen (pixels)
uniform float uPixelAngle;     // a pixel's size at 1 m from the eye (m)
uniform float uMetresPerUv;    // the mesh's size of one uv unit (m)
uniform mat4 uModel;
uniform mat4 uViewProjection;
float gSegment = 0.0;          // the segment here (m)
// The segment (m) at a point of the mesh (shape frame).
float segmentAt(vec3 p) { return uSegmentPixels * max((uViewProjection * (uModel * vec4(p, 1.0))).w, 0.0) * uPixelAngle; }

// The height at uv filtered over the surface around it (the map's mip levels): over about a segment, and over as
// far as the surface moves there, whichever is more. The vertices stand a segment apart; a crease whose height
// drops by centimetres from one texel to the next (a crushed, saturated map) read at them alone aliases into
// spikes along it, where the filtered height slopes at most about 1:1. A function of uv and of the vertex's
// distance alone: a vertex shared by two triangles moves the same way in both.
float gLod = 0.0;  // the level heightNear read last
float heightNear(vec2 uv) {
  float texel = uMetresPerUv / float(textureSize(uHeight, 0).x);  // m
  float coarse = textureLod(uHeight, uv, log2(max(0.5 * uBumpDepth / texel, 1.0))).r;
  float reach = max(gSegment, abs(coarse - 0.5) * uBumpDepth);
  gLod = log2(max(reach / texel, 1.0));
  return textureLod(uHeight, uv, gLod).r;
}
