// pom_shade.comp: shades one item's pixels from the visibility buffer with pom.frag's code (compiled with
// COMPUTE_SHADING; this file is appended to it after its #version line and defines). On GPUs whose graphics
// stages run on a few of their multiprocessors (NVIDIA's H100 and H200) the fragment stage only writes which
// item and triangle is nearest (visibility.frag); the shading, parallax march included, runs here on all of them.
// One invocation a pixel of the item's screen rectangle uRect (x, y, width, height): where the buffer names this
// item (uItem), its triangle's three vertices (GpuMesh's 17 floats) give what pom.vert would have interpolated,
// perspective-correct: the pixel's ray meets the triangle's plane; the rays of the next pixel along x and along
// y give the derivatives. The colour goes to uOut, sRGB-encoded as the fragment stage's sRGB target would.
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 10) uniform usampler2D uIds;  // item, triangle; item 0xffffffff: none; renderer.cpp pom::kVisibilityIds
layout(rgba8, binding = 0) writeonly uniform image2D uOut;  // renderer.cpp pom::kShaded
layout(std430, binding = 0) readonly buffer Vertices { float uVertex[]; };  // renderer.cpp pom::kVertices
layout(std430, binding = 1) readonly buffer Indices { uint uIndex[]; };  // renderer.cpp pom::kIndices
uniform uint uItem;
uniform ivec4 uRect;
uniform ivec2 uFrameSize;
uniform mat4 uInvViewProjection;
uniform mat4 uModel;
uniform mat3 uNormalMatrix;
uniform mat4 uLightViewProjection;

// The ray from the eye through the point (x, y) of the frame (pixels), relative to the eye.
vec3 rayAt(vec2 p) {
  vec2 ndc = p / vec2(uFrameSize) * 2.0 - 1.0;
  vec4 far = uInvViewProjection * vec4(ndc, 1.0, 1.0);
  return far.xyz / far.w - uEye;
}
// Barycentric weights of where the ray meets the plane of the triangle a, b, c (relative to the eye).
vec3 weightsAt(vec3 ray, vec3 a, vec3 b, vec3 c, vec3 n) {
  float t = dot(a, n) / dot(ray, n);
  vec3 p = ray * t;
  float nn = dot(n, n);
  float wa = dot(cross(b - p, c - p), n) / nn, wb = dot(cross(c - p, a - p), n) / nn;
  return vec3(wa, wb, 1.0 - wa - wb);
}
vec3 attribute3(uint v[3], uint offset, vec3 w) {
  vec3 r = vec3(0.0);
  for (int k = 0; k < 3; ++k) {
    uint i = v[k] * 17u + offset;
    r += w[k] * vec3(uVertex[i], uVertex[i + 1u], uVertex[i + 2u]);
  }
  return r;
}
vec2 attribute2(uint v[3], uint offset, vec3 w) {
  vec2 r = vec2(0.0);
  for (int k = 0; k < 3; ++k) {
    uint i = v[k] * 17u + offset;
    r += w[k] * vec2(uVertex[i], uVertex[i + 1u]);
  }
  return r;
}
vec3 srgbEncode(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

void main() {
  ivec2 local = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(local, uRect.zw))) return;
  ivec2 pixel = uRect.xy + local;
  uvec2 id = texelFetch(uIds, pixel, 0).xy;
  if (id.x != uItem) return;
  uint v[3] = uint[3](uIndex[3u * id.y], uIndex[3u * id.y + 1u], uIndex[3u * id.y + 2u]);
  vec3 a = (uModel * vec4(attribute3(v, 0u, vec3(1, 0, 0)), 1.0)).xyz - uEye;
  vec3 b = (uModel * vec4(attribute3(v, 0u, vec3(0, 1, 0)), 1.0)).xyz - uEye;
  vec3 c = (uModel * vec4(attribute3(v, 0u, vec3(0, 0, 1)), 1.0)).xyz - uEye;
  vec3 n = cross(b - a, c - a);
  vec2 centre = vec2(pixel) + 0.5;
  vec3 w = weightsAt(rayAt(centre), a, b, c, n);
  vec3 wx = weightsAt(rayAt(centre + vec2(1.0, 0.0)), a, b, c, n);
  vec3 wy = weightsAt(rayAt(centre + vec2(0.0, 1.0)), a, b, c, n);
  // Counter-clockwise on screen (GL's front faces) is the plane's normal facing the eye.
  gFrontFacing = dot(n, a) < 0.0;
  vec3 world = w.x * a + w.y * b + w.z * c;
  vWorld = world + uEye;
  gWorldDx = (wx.x * a + wx.y * b + wx.z * c) - world;
  gWorldDy = (wy.x * a + wy.y * b + wy.z * c) - world;
  vNormal = uNormalMatrix * attribute3(v, 3u, w);
  vUV = attribute2(v, 6u, w);
  gUvDx = attribute2(v, 6u, wx) - vUV;
  gUvDy = attribute2(v, 6u, wy) - vUV;
  vColor = attribute3(v, 8u, w);
  vMaterialUV = attribute2(v, 11u, w);
  gMaterialUvDx = attribute2(v, 11u, wx) - vMaterialUV;
  gMaterialUvDy = attribute2(v, 11u, wy) - vMaterialUV;
  vMaterial = int(round(uVertex[v[2] * 17u + 13u]));  // flat: the provoking (last) vertex's
  vShadow = uLightViewProjection * vec4(vWorld, 1.0);
  // The level the fragment stage's textureQueryLod names: level 0, the only one the maps are sampled at here
  // (their other levels are the displaced path's, read through a sampler of its own).
  gHeightLod = 0.0;
  shade();
  imageStore(uOut, pixel, vec4(srgbEncode(fragColor.rgb), fragColor.a));
}
