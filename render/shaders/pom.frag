#version 450 core
// pom.frag: parallax occlusion mapping with soft self-shadowing, shaded in glTF's
// metallic-roughness model: a Cook-Torrance GGX BRDF (Smith-Schlick G, Schlick F)
// for the shadow-mapped sun, and image-based light from the sky (split sum: a
// prefiltered radiance cube sampled along the reflection of the bumped normal, so
// reflections bend across dents; an irradiance cube; the BRDF table). Exposure
// and an ACES fit tone map. Height convention: 0.5 flat, range k = uBumpDepth,
// so the surface lies at (h - 0.5) k above the mesh.
// in:  vWorld, vNormal, vUV, vShadow; maps uHeight (R32F), uNormalMap (RGBA8), uShadowMap,
//      uPrefiltered, uIrradiance (cube maps), uBrdfLut (RG)
// out: fragColor (tone mapped, linear; the sRGB target encodes it)
// Compiled once per combination of the features a draw uses (the renderer prepends the defines): HAS_MAPS,
// HAS_LOOK, TEXTURE (0 none, 1 asphalt, 2 concrete, 3 clay), DISPLACED, MODE (parallax: 0 occlusion,
// 1 offset limited, 2 none), DEBUG (0 shaded, 1 height, 2 normal, 4 wireframe), SHADOWS, SELF_SHADOW, IBL.
// A software rasteriser runs both sides of a branch under a mask, so what a draw does not use must not be
// in its shader at all.
// With COMPUTE_SHADING defined the same code shades from a visibility buffer in a compute shader
// (pom_shade.comp, appended): the inputs are then globals it sets, with the derivatives (what dFdx / dFdy give
// here) from the triangle's plane at the neighbouring pixels' rays, and main() is shade(). With VISIBILITY_PASS
// defined it writes the visibility buffer's ids at the marched depth instead of a colour.
#ifdef COMPUTE_SHADING
vec3 vWorld = vec3(0.0), vNormal = vec3(0.0), vColor = vec3(1.0);
vec2 vUV = vec2(0.0), vMaterialUV = vec2(0.0);
vec4 vShadow = vec4(0.0);
int vMaterial = -1;
bool gFrontFacing = true;
vec3 gWorldDx = vec3(0.0), gWorldDy = vec3(0.0);
vec2 gUvDx = vec2(0.0), gUvDy = vec2(0.0), gMaterialUvDx = vec2(0.0), gMaterialUvDy = vec2(0.0);
float gHeightLod = 0.0;
vec4 fragColor = vec4(0.0);
#define FRONT_FACING gFrontFacing
#define DX_WORLD gWorldDx
#define DY_WORLD gWorldDy
#define DX_UV gUvDx
#define DY_UV gUvDy
#define DX_MATERIAL_UV gMaterialUvDx
#define DY_MATERIAL_UV gMaterialUvDy
#define HEIGHT_LOD gHeightLod
#define FOOTPRINT(q) (max(length(mat3(uWorldToModel) * gWorldDx), length(mat3(uWorldToModel) * gWorldDy)) / max(uTextureScale, 1e-3))
#else
in vec3 vWorld;
in vec3 vNormal;
in vec2 vUV;
in vec3 vColor;  // multiplies uColor (glTF's COLOR_0)
in vec4 vShadow;
in vec2 vMaterialUV;    // the mesh file's own uv
flat in int vMaterial;  // its material in the look, -1 none
#if DISPLACED
in float vHeightLod;  // pom_displace.tese: the height map's level the surface was moved by
uniform float uMetresPerUv;
#endif
#ifdef VISIBILITY_PASS
// The visibility pass of shading in compute (a bump-mapped item): its item and triangle, at the depth of the
// surface the march found, so that what rests in a dent is seen in it there too. Nothing is shaded.
uniform uint uItem;
out uvec2 id;
vec4 fragColor;
#else
out vec4 fragColor;
#endif
// The depth of the surface the parallax march found (a body resting in a dent is drawn inside it), never nearer
// than the mesh's own (a crater's rim stays at the mesh's depth): conservative depth keeps the early depth test.
layout(depth_greater) out float gl_FragDepth;
uniform mat4 uViewProjection;
#define FRONT_FACING gl_FrontFacing
#define DX_WORLD dFdx(vWorld)
#define DY_WORLD dFdy(vWorld)
#define DX_UV dFdx(vUV)
#define DY_UV dFdy(vUV)
#define DX_MATERIAL_UV dFdx(vMaterialUV)
#define DY_MATERIAL_UV dFdy(vMaterialUV)
#define HEIGHT_LOD textureQueryLod(uHeight, vUV).x
#define FOOTPRINT(q) max(length(dFdx(q)), length(dFdy(q)))
#endif
// The look (render/look.h): per material the base colour factor (linear), metallic, roughness, normal scale,
// occlusion strength, emissive (rgb, sRGB layer), and the layers of its images (-1 none).
uniform bvec3 uLookOwn;  // the look's base colour, metallic, roughness apply (the scene did not set them)
uniform vec4 uLookBase[16], uLookParams[16], uLookEmissive[16];
uniform ivec4 uLookLayers[16];  // base colour (sRGB array), metallic-roughness, normal, occlusion (linear array)
layout(binding = 8) uniform sampler2DArray uLookSrgb;  // renderer.cpp pom::kLookSrgb
layout(binding = 9) uniform sampler2DArray uLookLinear;  // renderer.cpp pom::kLookLinear
layout(binding = 0) uniform sampler2D uHeight;  // renderer.cpp pom::kHeight
layout(binding = 1) uniform sampler2D uNormalMap;  // renderer.cpp pom::kNormalMap
layout(binding = 2) uniform sampler2DShadow uShadowMap;  // renderer.cpp pom::kShadowMap
layout(binding = 3) uniform samplerCube uPrefiltered;  // renderer.cpp pom::kPrefiltered
layout(binding = 4) uniform samplerCube uIrradiance;  // renderer.cpp pom::kIrradiance
layout(binding = 5) uniform sampler2D uBrdfLut;  // renderer.cpp pom::kBrdfLut
// The height's bound pyramid: level 0 one texel per uBoundTile x uBoundTile height texels holding the largest
// |h - 0.5| there, each level the largest of 2 x 2 below.
layout(binding = 6) uniform sampler2D uHeightBound;  // renderer.cpp pom::kHeightBound
uniform int uBoundTile;
uniform float uPrefilteredMaxLod;  // its last level: roughness 1
uniform float uMetallic, uRoughness;
uniform float uExposure;
uniform vec3 uSkyColor, uGroundColor;
uniform float uBumpDepth;
uniform vec3 uColor;  // sRGB material colour
uniform vec3 uEye;
uniform vec3 uToSun;
uniform vec3 uSunColor;
uniform int uMinSteps, uMaxSteps;
uniform vec2 uLodFade;
uniform float uTextureScale;  // its features' size, times their natural size
uniform mat4 uWorldToModel;   // the surface is laid in the mesh's frame

float heightAt(vec2 uv, vec2 gx, vec2 gy) { return (textureGrad(uHeight, uv, gx, gy).r - 0.5) * uBumpDepth; }

// The largest |h - 0.5| that filtered reads of the height map along the segment a..b (uv) can return: the
// pyramid's level whose texels span the segment's box (grown by the one texel a bilinear read reaches), where
// that box covers at most 2 x 2 texels. 0: the map is flat all along it, and a march there would find the mesh.
float boundAlong(vec2 a, vec2 b) {
  vec2 res = vec2(textureSize(uHeight, 0));
  vec2 lo = clamp(min(a, b) * res - 1.0, vec2(0.0), res - 1.0), hi = clamp(max(a, b) * res + 1.0, vec2(0.0), res - 1.0);
  float extent = max(hi.x - lo.x, hi.y - lo.y) / float(uBoundTile);
  // The pyramid's levels lie side by side in one level of the texture (deform's SurfaceMaps::boundOrigin): level
  // 0 (S x S) at (0, 0), level k >= 1 at (S, S - 2 (S >> k)).
  int S = textureSize(uHeightBound, 0).y;
  int level = min(int(ceil(log2(max(extent, 1.0)))), findMSB(S));
  ivec2 last = ivec2(max(S >> level, 1) - 1);
  ivec2 origin = level == 0 ? ivec2(0) : ivec2(S, S - 2 * (S >> level));
  float texels = 1.0 / (float(uBoundTile) * exp2(float(level)));  // pyramid texels per height texel
  ivec2 t0 = origin + min(ivec2(lo * texels), last), t1 = origin + min(ivec2(hi * texels), last);
  return max(max(texelFetch(uHeightBound, t0, 0).r, texelFetch(uHeightBound, ivec2(t1.x, t0.y), 0).r),
             max(texelFetch(uHeightBound, ivec2(t0.x, t1.y), 0).r, texelFetch(uHeightBound, t1, 0).r));
}

// Value noise: a hash per lattice point, smoothly interpolated; fbm: octaves of it, each fading to its mean
// once its features are smaller than about two pixels (`footprint`: metres per pixel), so that nothing aliases.
float hash3(vec3 p) {
  p = fract(p * vec3(0.1031, 0.1030, 0.0973));
  p += dot(p, p.yxz + 33.33);
  return fract((p.x + p.y) * p.z);
}
float valueNoise(vec3 x) {
  vec3 i = floor(x), f = fract(x);
  f = f * f * (3.0 - 2.0 * f);
  return mix(mix(mix(hash3(i), hash3(i + vec3(1, 0, 0)), f.x), mix(hash3(i + vec3(0, 1, 0)), hash3(i + vec3(1, 1, 0)), f.x), f.y),
             mix(mix(hash3(i + vec3(0, 0, 1)), hash3(i + vec3(1, 0, 1)), f.x), mix(hash3(i + vec3(0, 1, 1)), hash3(i + vec3(1, 1, 1)), f.x), f.y),
             f.z);
}
float fadeFor(float frequency, float footprint) { return clamp(2.0 - 4.0 * frequency * footprint, 0.0, 1.0); }
float fbm(vec3 p, float frequency, int octaves, float footprint) {
  float sum = 0.0, amplitude = 0.5, total = 0.0;
  for (int i = 0; i < octaves; ++i) {
    sum += amplitude * mix(0.5, valueNoise(p * frequency + float(i) * 17.31), fadeFor(frequency, footprint));
    total += amplitude;
    amplitude *= 0.5;
    frequency *= 2.03;
  }
  return sum / total;
}
// A procedural surface at q (metres in the mesh's frame over the scale): x multiplies the albedo (about 1 on
// average), y is added to the roughness.
vec2 surfaceTexture(vec3 q, float footprint) {
#if TEXTURE == 1
  {
    // Asphalt: worn and tar-darkened patches of a metre or two, 2 cm grain, pale stone chips.
    float patches = fbm(q, 0.6, 3, footprint);
    float grain = fbm(q, 45.0, 2, footprint);
    float chips = smoothstep(0.74, 0.8, valueNoise(q * 110.0 + 5.0)) * fadeFor(110.0, footprint);
    float tar = smoothstep(0.45, 0.8, patches);
    float albedo = mix(1.1, 0.84, tar) * mix(0.82, 1.18, grain) + 0.7 * chips;
    return vec2(albedo, 0.12 * (grain - 0.5) - 0.15 * tar);
  }
#elif TEXTURE == 2
  {
    // Concrete: cloudy mottling, faint larger stains, pores of a centimetre or so.
    float mottle = fbm(q, 0.9, 4, footprint);
    float stains = fbm(q + 31.0, 0.18, 2, footprint);
    float pores = smoothstep(0.8, 0.88, valueNoise(q * 70.0 + 11.0)) * fadeFor(70.0, footprint);
    float albedo = mix(0.82, 1.14, mottle) * mix(0.88, 1.06, stains) * (1.0 - 0.45 * pores);
    return vec2(albedo, 0.14 * (mottle - 0.5) + 0.1 * pores);
  }
#elif TEXTURE == 3
  {
    // Clay: broad damp and dry areas, clods of a few centimetres.
    float damp = fbm(q, 0.7, 4, footprint);
    float clods = fbm(q + 7.0, 9.0, 3, footprint);
    float albedo = mix(0.72, 1.2, damp) * mix(0.82, 1.12, clods);
    return vec2(albedo, 0.08 * (clods - 0.5) - 0.15 * smoothstep(0.55, 0.75, 1.0 - damp));
  }
#else
  return vec2(1.0, 0.0);
#endif
}

#ifdef COMPUTE_SHADING
void shade() {
#else
void main() {
#endif
#if DEBUG == 4
  fragColor = vec4(0.05, 0.9, 0.3, 1.0);
#ifndef COMPUTE_SHADING
  gl_FragDepth = gl_FragCoord.z;
#endif
  return;
#endif
  vec3 N = normalize(vNormal);
  if (!FRONT_FACING) N = -N;
  vec3 V = normalize(vWorld - uEye);  // from the eye into the surface
  // Cotangent frame (Schueler 2006): gradients of u and v along the surface.
  vec3 dp1 = DX_WORLD, dp2 = DY_WORLD;
  vec2 duv1 = DX_UV, duv2 = DY_UV;
  vec3 dp2perp = cross(dp2, N), dp1perp = cross(N, dp1);
  float det = dot(cross(dp1, dp2), N);
  vec3 gradU = (dp2perp * duv1.x + dp1perp * duv2.x) / (abs(det) > 1e-20 ? det : 1e-20);
  vec3 gradV = (dp2perp * duv1.y + dp1perp * duv2.y) / (abs(det) > 1e-20 ? det : 1e-20);
  vec2 uv = vUV;
  vec3 shift = vec3(0.0);  // where parallax moved the surface point (world), for the look's uv
  float surfaceHeight = 0.0;
  float fade = 1.0;
#if HAS_MAPS
  {
    float lod = HEIGHT_LOD;
    fade = 1.0 - smoothstep(uLodFade.x, uLodFade.y, lod);
    float cosV = max(-dot(V, N), 0.05);
    vec2 uvPerDepth = vec2(dot(gradU, V), dot(gradV, V)) / cosV;  // uv change per metre of descent
#if DISPLACED
    // The surface is where the map puts it already: shade it where it is.
#elif MODE == 0
    vec2 top = vUV - uvPerDepth * (0.5 * uBumpDepth);
    // Over undented texels the march would end on the mesh itself: skipped (a software rasteriser runs a
    // loop until every pixel of its block is done, so this is most of a frame's parallax work).
    if (fade > 0.0 && boundAlong(top, top + uvPerDepth * uBumpDepth) > 0.0) {
      // Linear march from the top of the height field (+k/2) down to its bottom (-k/2).
      int steps = int(mix(float(uMaxSteps), float(uMinSteps), cosV));
      float stepDepth = uBumpDepth / float(steps);
      float prevDiff = 0.5 * uBumpDepth - heightAt(top, duv1, duv2);
      float depth = 0.0;
      vec2 hitUV = top + uvPerDepth * uBumpDepth;
      for (int i = 1; i <= steps; ++i) {
        float d = float(i) * stepDepth;
        vec2 p = top + uvPerDepth * d;
        float diff = (0.5 * uBumpDepth - d) - heightAt(p, duv1, duv2);
        if (diff <= 0.0) {
          // Secant refinement between the last point above and the first below.
          float t = prevDiff / max(prevDiff - diff, 1e-9);
          depth = d - stepDepth + t * stepDepth;
          hitUV = top + uvPerDepth * depth;
          break;
        }
        prevDiff = diff;
      }
      uv = mix(vUV, hitUV, fade);
      shift = V / cosV * (depth - 0.5 * uBumpDepth) * fade;
    }
#elif MODE == 1
    {
      // Offset limiting (Welsh 2004), as the paper renders: no division by the view angle.
      float h = heightAt(vUV, duv1, duv2);
      uv = vUV - vec2(dot(gradU, V), dot(gradV, V)) * h * fade;
      shift = -V * h * fade;
    }
#endif
    surfaceHeight = heightAt(uv, duv1, duv2);
  }
#endif
#ifndef COMPUTE_SHADING
  if (shift == vec3(0.0)) {
    gl_FragDepth = gl_FragCoord.z;
  } else {
    vec4 clip = uViewProjection * vec4(vWorld + shift, 1.0);
    gl_FragDepth = clamp(max(gl_FragCoord.z, (clip.z / clip.w) * 0.5 + 0.5), 0.0, 1.0);
  }
#ifdef VISIBILITY_PASS
  id = uvec2(uItem, uint(gl_PrimitiveID));
  return;
#endif
#endif
#if DEBUG == 1
  fragColor = vec4(vec3(HAS_MAPS != 0 ? textureGrad(uHeight, uv, duv1, duv2).r : 0.5), 1.0);
  return;
#endif
  // The look: base colour, metallic, roughness and occlusion from the file's material and images, and its normal
  // map, which tilts the surface the dent normal map then bends.
  vec3 baseColor = pow(uColor * vColor, vec3(2.2));
  float metallic = uMetallic, roughness = uRoughness, occlusion = 1.0;
  vec3 emissive = vec3(0.0);
  vec3 Nl = N;
#if HAS_LOOK
  if (vMaterial >= 0) {
    int mi = min(vMaterial, 15);
    vec2 m1 = DX_MATERIAL_UV, m2 = DY_MATERIAL_UV;
    vec3 gradMU = (dp2perp * m1.x + dp1perp * m2.x) / (abs(det) > 1e-20 ? det : 1e-20);
    vec3 gradMV = (dp2perp * m1.y + dp1perp * m2.y) / (abs(det) > 1e-20 ? det : 1e-20);
    vec2 muv = vMaterialUV + vec2(dot(gradMU, shift), dot(gradMV, shift));
    ivec4 layer = uLookLayers[mi];
    vec4 p = uLookParams[mi];
    if (uLookOwn.x) {
      vec4 b = uLookBase[mi];
      if (layer.x >= 0) b *= textureGrad(uLookSrgb, vec3(muv, layer.x), m1, m2);
      baseColor = b.rgb * pow(vColor, vec3(2.2));
    }
    vec4 mr = layer.y >= 0 ? textureGrad(uLookLinear, vec3(muv, layer.y), m1, m2) : vec4(1.0);
    if (uLookOwn.y) metallic = p.x * mr.b;
    if (uLookOwn.z) roughness = p.y * mr.g;
    if (layer.w >= 0) occlusion = mix(1.0, textureGrad(uLookLinear, vec3(muv, layer.w), m1, m2).r, p.w);
    emissive = uLookEmissive[mi].rgb;
    if (uLookEmissive[mi].w >= 0.0) emissive *= textureGrad(uLookSrgb, vec3(muv, uLookEmissive[mi].w), m1, m2).rgb;
    if (layer.z >= 0 && length(gradMU) > 0.0 && length(gradMV) > 0.0) {
      vec3 nt = textureGrad(uLookLinear, vec3(muv, layer.z), m1, m2).xyz * 2.0 - 1.0;
      nt.xy *= p.z;
      // glTF's green points up the image, towards -v (crumple's own maps: towards +v; the export flips it).
      vec3 T = normalize(gradMU - N * dot(gradMU, N));
      vec3 B = normalize(gradMV - N * dot(gradMV, N));
      Nl = normalize(T * nt.x - B * nt.y + N * nt.z);
    }
  }
#endif
#if TEXTURE != 0
  {
    vec3 q = (uWorldToModel * vec4(vWorld, 1.0)).xyz / max(uTextureScale, 1e-3);
    float footprint = FOOTPRINT(q);
    vec2 t = surfaceTexture(q, footprint);
    baseColor *= t.x;
    roughness = clamp(roughness + t.y, 0.0, 1.0);
  }
#endif
  vec3 Nb = Nl;
#if HAS_MAPS
  {
#if DISPLACED && !defined(COMPUTE_SHADING)
    // The slopes of the surface as it was moved: the height map at the level the tessellation read it
    // (vHeightLod), by central differences over that level's texels, as the normal map is made from level 0.
    // Where a deep crease was smoothed for the vertices, the normal map's level-0 slopes (nearly vertical walls
    // one texel wide) would light the smooth surface as torn, in black slivers and bright spikes.
    float lod = max(vHeightLod, 0.0);
    float texelUv = exp2(floor(lod)) / float(textureSize(uHeight, 0).x);
    float hx = textureLod(uHeight, uv + vec2(texelUv, 0.0), lod).r - textureLod(uHeight, uv - vec2(texelUv, 0.0), lod).r;
    float hy = textureLod(uHeight, uv + vec2(0.0, texelUv), lod).r - textureLod(uHeight, uv - vec2(0.0, texelUv), lod).r;
    float slope = uBumpDepth / (2.0 * max(texelUv * uMetresPerUv, 1e-9));
    vec3 nt = normalize(vec3(-hx * slope, -hy * slope, 1.0));
#else
    vec3 nt = textureGrad(uNormalMap, uv, duv1, duv2).xyz * 2.0 - 1.0;
#endif
    vec3 T = normalize(gradU - Nl * dot(gradU, Nl));
    vec3 B = normalize(gradV - Nl * dot(gradV, Nl));
    Nb = normalize(T * nt.x + B * nt.y + Nl * nt.z);
  }
#endif
#if DEBUG == 2
  fragColor = vec4(HAS_MAPS != 0 ? textureGrad(uNormalMap, uv, duv1, duv2).xyz : vec3(0.5, 0.5, 1.0), 1.0);
  return;
#endif

  vec3 L = normalize(uToSun);
  float shadow = 1.0;
#if SHADOWS
  {
    vec3 s = vShadow.xyz / vShadow.w * 0.5 + 0.5;
    if (all(greaterThan(s, vec3(0.0))) && all(lessThan(s, vec3(1.0)))) {
      float bias = 0.0015 + 0.003 * (1.0 - max(dot(N, L), 0.0));
      vec2 texel = 1.0 / vec2(textureSize(uShadowMap, 0));
      float sum = 0.0;
      for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) sum += texture(uShadowMap, vec3(s.xy + vec2(x, y) * texel, s.z - bias));
      shadow = sum / 9.0;
    }
  }
#endif
  float selfShadow = 1.0;
#if HAS_MAPS && SELF_SHADOW && MODE == 0
  float cosL = max(dot(L, N), 0.05);
  vec2 uvPerRise = vec2(dot(gradU, L), dot(gradV, L)) / cosL;
  float rise = 0.5 * uBumpDepth - surfaceHeight;
  // Nothing rises over a flat stretch towards the sun: no march there.
  if (fade > 0.0 && dot(N, L) > 0.0 && boundAlong(uv, uv + uvPerRise * rise) > 0.0) {
    // March towards the sun; the deepest obstruction, weighted by nearness, darkens (soft shadow).
    const int n = 12;
    float occlusion = 0.0;
    for (int i = 1; i <= n; ++i) {
      float r = rise * float(i) / float(n);
      float above = heightAt(uv + uvPerRise * r, duv1, duv2) - (surfaceHeight + r);
      occlusion = max(occlusion, above / uBumpDepth * 8.0 * (1.0 - float(i) / float(n + 1)));
    }
    selfShadow = 1.0 - clamp(occlusion, 0.0, 1.0) * fade;
  }
#endif
  const float PI = 3.14159265;
  vec3 albedo = baseColor;
  float rough = clamp(roughness, 0.045, 1.0);
  vec3 F0 = mix(vec3(0.04), albedo, metallic);
  vec3 toEye = -V;
  float NV = max(dot(Nb, toEye), 1e-3);
  // The sun: Cook-Torrance with GGX. sunColor is the radiance a white Lambert surface facing it returns.
  vec3 H = normalize(L + toEye);
  float NL = max(dot(Nb, L), 0.0), NH = max(dot(Nb, H), 0.0), VH = max(dot(toEye, H), 0.0);
  float a2 = rough * rough * rough * rough;
  float dd = NH * NH * (a2 - 1.0) + 1.0;
  float D = a2 / (PI * dd * dd);
  float k = (rough + 1.0) * (rough + 1.0) / 8.0;
  float G = (NL / (NL * (1.0 - k) + k)) * (NV / (NV * (1.0 - k) + k));
  vec3 F = F0 + (1.0 - F0) * pow(1.0 - VH, 5.0);
  vec3 specular = D * G * F / max(4.0 * NL * NV, 1e-4);
  vec3 kd = (1.0 - F) * (1.0 - metallic);
  vec3 c = (kd * albedo + PI * specular) * uSunColor * NL * shadow * selfShadow;
  // The sky: split-sum image-based light.
  vec3 Fr = F0 + (max(vec3(1.0 - rough), F0) - F0) * pow(1.0 - NV, 5.0);
  vec3 R = reflect(V, Nb);
  float horizon = clamp(1.0 + 1.5 * dot(R, N), 0.0, 1.0);  // reflections from below the mesh's surface fade
#if IBL
  vec3 prefiltered = textureLod(uPrefiltered, R, rough * uPrefilteredMaxLod).rgb;
#else
  vec3 prefiltered = mix(uGroundColor, uSkyColor, 0.5 + 0.5 * R.y);
#endif
  prefiltered *= horizon * horizon;
  vec2 ab = texture(uBrdfLut, vec2(NV, rough)).rg;
#if IBL
  vec3 irradiance = texture(uIrradiance, Nb).rgb;
#else
  vec3 irradiance = mix(uGroundColor, uSkyColor, 0.5 + 0.5 * Nb.y);
#endif
  vec3 ambient = (1.0 - Fr) * (1.0 - metallic) * albedo * irradiance + prefiltered * (F0 * ab.x + ab.y);
  c += ambient * mix(1.0, selfShadow, 0.5) * occlusion + emissive;
  c *= uExposure;
  fragColor = vec4(clamp(c * (2.51 * c + 0.03) / (c * (2.43 * c + 0.59) + 0.14), 0.0, 1.0), 1.0);
}
