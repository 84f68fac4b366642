#version 450 core
// pom_displace.vert: the displaced path's vertex stage; passes the mesh's attributes (shape frame) on to the
// tessellation stages (pom_displace.tesc, .tese), which cut each triangle to a few pixels a segment and move the
// new vertices along the normal by the height map.
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec2 aUV;
layout(location = 3) in vec3 aColor;
layout(location = 4) in vec2 aMaterialUV;
layout(location = 5) in float aMaterial;
layout(location = 6) in vec3 aSmoothNormal;  // the normal averaged over the vertices at this position
out vec3 tcPosition;
out vec3 tcNormal;
out vec2 tcUV;
out vec3 tcColor;
out vec2 tcMaterialUV;
out float tcMaterial;
out vec3 tcSmoothNormal;
out float tcIndex;  // the vertex's number (its entries in the seam tables)
void main() {
  tcPosition = aPosition;
  tcNormal = aNormal;
  tcUV = aUV;
  tcColor = aColor;
  tcMaterialUV = aMaterialUV;
  tcMaterial = aMaterial;
  tcSmoothNormal = aSmoothNormal;
  tcIndex = float(gl_VertexID);
}
