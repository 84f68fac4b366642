#version 450 core
// texel.geom: keeps the triangles of X that face the deformation camera (the
// same winding test as address pass A's culling) and reach into the other
// body's depth range, clips each to the camera's
// view (so only texels the camera sees are drawn: everything is affine over a
// triangle, so the clipped polygon's attributes are exact), and grows the
// polygon in texture space by half a texel's footprint on every edge
// (conservative rasterisation), its attributes extrapolated affinely. Every
// texel the triangle touches then gets a fragment, not only those whose centre
// it covers: dents run on to a chart's edge and into its gutter, so bilinear
// sampling across the edge sees no seam. A texel two triangles reach takes the
// deeper of their values (the update's atomic minimum).
// out: gClip, gNormal, gBox (the polygon's texel bounds + 0.5: no spikes past it), the triangle (gTri01, gTri2,
//      gCorner0..2: texel and clip-space corners) for the fragment's nearest point on it (texel_point.glsl)
layout(triangles) in;
layout(triangle_strip, max_vertices = 7) out;
in vec3 vClip[];
in vec3 vNormal[];
in vec2 vUV[];
out vec3 gClip;
out vec3 gNormal;
flat out vec4 gBox;
flat out vec4 gTri01;
flat out vec3 gTri2;  // t2, twice the signed area
flat out vec3 gCorner0;
flat out vec3 gCorner1;
flat out vec3 gCorner2;
uniform int uResolution;
uniform float uViewMargin;  // clip units beyond [-1, 1] that are kept (a pixel or two)
uniform float uBumpReach;   // how far X's bumps raise a point towards the camera at most, in window depth
uniform float uFarthestOther;  // the other body's farthest window depth (its bounds, with its bumps)

const int kMax = 7;
void main() {
  vec3 c0 = vClip[0], c1 = vClip[1], c2 = vClip[2];
  // Facing: counter-clockwise in the camera's view, as pass A keeps.
  if ((c1.x - c0.x) * (c2.y - c0.y) - (c1.y - c0.y) * (c2.x - c0.x) <= 0.0) return;
  // Beyond the other body's farthest point no texel can be inside it.
  if (min(c0.z, min(c1.z, c2.z)) * 0.5 + 0.5 - uBumpReach > uFarthestOther) return;
  float res = float(uResolution);
  vec2 t0 = vUV[0] * res, t1 = vUV[1] * res, t2 = vUV[2] * res;
  float area = (t1.x - t0.x) * (t2.y - t0.y) - (t1.y - t0.y) * (t2.x - t0.x);
  if (abs(area) < 1e-12) return;
  // Clip against the view square, carrying texel coordinates (the clip-space
  // position follows from them through the triangle's affine map).
  vec2 poly[kMax], next[kMax];
  vec2 cpos[kMax], cnext[kMax];
  int n = 3;
  poly[0] = t0; poly[1] = t1; poly[2] = t2;
  cpos[0] = c0.xy; cpos[1] = c1.xy; cpos[2] = c2.xy;
  float lim = 1.0 + uViewMargin;
  for (int plane = 0; plane < 4 && n > 0; ++plane) {
    int axis = plane / 2;
    float s = plane % 2 == 0 ? 1.0 : -1.0;  // keep s * coordinate <= lim
    int m = 0;
    for (int i = 0; i < n; ++i) {
      int j = (i + 1) % n;
      float di = s * cpos[i][axis] - lim, dj = s * cpos[j][axis] - lim;
      if (di <= 0.0 && m < kMax) { next[m] = poly[i]; cnext[m] = cpos[i]; ++m; }
      if ((di <= 0.0) != (dj <= 0.0) && m < kMax) {
        float t = di / (di - dj);
        next[m] = mix(poly[i], poly[j], t);
        cnext[m] = mix(cpos[i], cpos[j], t);
        ++m;
      }
    }
    n = m;
    for (int i = 0; i < n; ++i) { poly[i] = next[i]; cpos[i] = cnext[i]; }
  }
  if (n < 3) return;
  float orient = sign(area);
  // Outward unit normal of edge i (poly[i] -> poly[i+1]) and its offset: half a texel's extent along it.
  vec2 en[kMax];
  float ed[kMax];
  vec2 tlo = poly[0], thi = poly[0];
  for (int i = 0; i < n; ++i) {
    vec2 e = poly[(i + 1) % n] - poly[i];
    float len = length(e);
    en[i] = len > 1e-9 ? vec2(e.y, -e.x) * orient / len : vec2(0.0);
    ed[i] = 0.5 * (abs(en[i].x) + abs(en[i].y));
    tlo = min(tlo, poly[i]);
    thi = max(thi, poly[i]);
  }
  vec4 box = vec4(tlo - 0.5, thi + 0.5);
  vec2 q[kMax];
  for (int i = 0; i < n; ++i) {
    // Vertex i moves to where its two edges' offset lines meet: x . n_a = d_a, x . n_b = d_b.
    vec2 na = en[(i + n - 1) % n], nb = en[i];
    float da = ed[(i + n - 1) % n], db = ed[i];
    float det = na.x * nb.y - na.y * nb.x;
    vec2 x = abs(det) > 1e-4 ? vec2(da * nb.y - db * na.y, na.x * db - nb.x * da) / det : (na * da + nb * db) * 0.5;
    float len = length(x);
    if (len > 4.0) x *= 4.0 / len;  // a needle's tip: the box trims the rest
    q[i] = poly[i] + x;
  }
  // A fan as a strip: 0, 1, n-1, 2, n-2, ...
  int lo = 1, hi = n - 1;
  for (int k = 0; k < n; ++k) {
    int i = k == 0 ? 0 : (k % 2 == 1 ? lo++ : hi--);
    // Barycentrics of q in the original triangle: attributes extrapolate affinely.
    float w1 = ((q[i].x - t0.x) * (t2.y - t0.y) - (q[i].y - t0.y) * (t2.x - t0.x)) / area;
    float w2 = ((t1.x - t0.x) * (q[i].y - t0.y) - (t1.y - t0.y) * (q[i].x - t0.x)) / area;
    float w0 = 1.0 - w1 - w2;
    gClip = w0 * c0 + w1 * c1 + w2 * c2;
    gNormal = w0 * vNormal[0] + w1 * vNormal[1] + w2 * vNormal[2];
    gBox = box;
    gTri01 = vec4(t0, t1);
    gTri2 = vec3(t2, area);
    gCorner0 = c0;
    gCorner1 = c1;
    gCorner2 = c2;
    gl_Position = vec4(q[i] / res * 2.0 - 1.0, 0.0, 1.0);
    EmitVertex();
  }
  EndPrimitive();
}
