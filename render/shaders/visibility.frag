#version 450 core
// visibility.frag: which item and which of its triangles is nearest at each pixel (depth LESS).
uniform uint uItem;
out uvec2 id;
void main() { id = uvec2(uItem, uint(gl_PrimitiveID)); }
