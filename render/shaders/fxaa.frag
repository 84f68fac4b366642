#version 450 core
// fxaa.frag: fast approximate antialiasing of the shaded frame, one fullscreen pass
// (after Lottes' FXAA: find edges by local luma contrast, then blend across them).
//   1. Luma of the pixel and its 8 neighbours (perceptual: the square root of the
//      linear luminance). Pixels whose local contrast is below a threshold keep
//      their colour: flat areas, textures and dents are left alone.
//   2. The edge runs along x or along y, whichever has the larger second difference
//      across it; the neighbour across it with the steeper step is the other side.
//   3. Walk along the edge both ways (samples half a pixel towards the other side,
//      so each reads the mean of the two rows) until the luma leaves the edge's,
//      and blend towards the other side by how near the pixel is to the edge's end
//      that it belongs to (a staircase step becomes a ramp).
//   4. A sub-pixel blend for isolated pixels (thin lines, specks): by how far the
//      pixel differs from its neighbourhood's mean.
// in:  vUV; uScene (the frame, sRGB texture read as linear, bilinear, clamped); uTexel (1 / size)
// out: fragColor (linear; the sRGB target encodes it)
in vec2 vUV;
layout(binding = 0) uniform sampler2D uScene;  // renderer.cpp kSource
uniform vec2 uTexel;
out vec4 fragColor;

float luma(vec3 c) { return sqrt(dot(c, vec3(0.299, 0.587, 0.114))); }
float lumaAt(vec2 uv) { return luma(textureLod(uScene, uv, 0.0).rgb); }
// The 3x3 neighbourhood by texel fetches (no filtering: on a software rasteriser a filtered fetch costs
// several times an unfiltered one), clamped to the frame's edge as the sampler would.
ivec2 gPixel, gLast;
float lumaOff(int x, int y) { return luma(texelFetch(uScene, clamp(gPixel + ivec2(x, y), ivec2(0), gLast), 0).rgb); }

void main() {
  vec2 uv = vUV;
  gPixel = ivec2(gl_FragCoord.xy);
  gLast = textureSize(uScene, 0) - 1;
  vec3 cM = texelFetch(uScene, gPixel, 0).rgb;
  float lM = luma(cM);
  float lN = lumaOff(0, 1), lS = lumaOff(0, -1), lE = lumaOff(1, 0), lW = lumaOff(-1, 0);
  float lo = min(lM, min(min(lN, lS), min(lE, lW)));
  float hi = max(lM, max(max(lN, lS), max(lE, lW)));
  float range = hi - lo;
  if (range < max(0.0312, 0.125 * hi)) {
    fragColor = vec4(cM, 1.0);
    return;
  }
  float lNE = lumaOff(1, 1), lNW = lumaOff(-1, 1), lSE = lumaOff(1, -1);
  float lSW = lumaOff(-1, -1);

  // Sub-pixel blend: how much the pixel stands out from the mean of its neighbourhood.
  float mean = (2.0 * (lN + lS + lE + lW) + (lNE + lNW + lSE + lSW)) / 12.0;
  float sub = smoothstep(0.0, 1.0, clamp(abs(mean - lM) / range, 0.0, 1.0));
  sub = sub * sub * 0.75;

  // An edge along x changes across y: the second difference in y, weighted to the centre column.
  float alongX = abs(lNW - 2.0 * lW + lSW) + 2.0 * abs(lN - 2.0 * lM + lS) + abs(lNE - 2.0 * lE + lSE);
  float alongY = abs(lNW - 2.0 * lN + lNE) + 2.0 * abs(lW - 2.0 * lM + lE) + abs(lSW - 2.0 * lS + lSE);
  bool horizontal = alongX >= alongY;
  float lNeg = horizontal ? lS : lW, lPos = horizontal ? lN : lE;
  float gNeg = abs(lNeg - lM), gPos = abs(lPos - lM);
  bool towardsNeg = gNeg >= gPos;
  float threshold = 0.25 * max(gNeg, gPos);
  float edgeLuma = 0.5 * (lM + (towardsNeg ? lNeg : lPos));
  vec2 across = horizontal ? vec2(0.0, uTexel.y) : vec2(uTexel.x, 0.0);
  if (towardsNeg) across = -across;
  vec2 along = horizontal ? vec2(uTexel.x, 0.0) : vec2(0.0, uTexel.y);

  // Walk both ways on the line between the two rows, strides growing with distance (the five steps of
  // Lottes' default quality preset: ten cost llvmpipe a third of a small frame, every pixel running the loop).
  const float stride[5] = float[](1.0, 1.5, 2.0, 4.0, 12.0);
  vec2 start = uv + 0.5 * across;
  vec2 p1 = start - along, p2 = start + along;
  float d1 = lumaAt(p1) - edgeLuma, d2 = lumaAt(p2) - edgeLuma;
  bool end1 = abs(d1) >= threshold, end2 = abs(d2) >= threshold;
  for (int i = 1; i < 5 && !(end1 && end2); ++i) {
    if (!end1) {
      p1 -= along * stride[i];
      d1 = lumaAt(p1) - edgeLuma;
      end1 = abs(d1) >= threshold;
    }
    if (!end2) {
      p2 += along * stride[i];
      d2 = lumaAt(p2) - edgeLuma;
      end2 = abs(d2) >= threshold;
    }
  }
  float dist1 = horizontal ? uv.x - p1.x : uv.y - p1.y;
  float dist2 = horizontal ? p2.x - uv.x : p2.y - uv.y;
  bool nearer1 = dist1 < dist2;
  float dist = min(dist1, dist2), span = dist1 + dist2;
  // Blend only when the luma at the nearer end moves away from the centre's side of the edge
  // (the pixel lies on the staircase step that ends there).
  bool centreBelow = lM < edgeLuma;
  bool stepHere = ((nearer1 ? d1 : d2) < 0.0) != centreBelow;
  float edgeBlend = stepHere ? 0.5 - dist / span : 0.0;
  float amount = max(edgeBlend, sub);
  fragColor = vec4(textureLod(uScene, uv + amount * across, 0.0).rgb, 1.0);
}
