#version 450 core
// texel.geom: keeps the triangles of X that face the deformation camera (the
// same winding test as address pass A's culling) and lie in its view, and
// grows each one in texture space by half a texel's footprint on every edge
// (conservative rasterisation), carrying its attributes along affinely. Every
// texel the triangle touches then gets a fragment, not only those whose centre
// it covers: dents run on to a chart's edge and into its gutter, so bilinear
// sampling across the edge sees no seam. A texel two triangles reach takes the
// deeper of their values (the update's atomic minimum).
// out: gClip, gNormal (extrapolated), gBox (the triangle's texel bounds + 0.5: no spikes past it)
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
in vec3 vClip[];
in vec3 vNormal[];
in vec2 vUV[];
out vec3 gClip;
out vec3 gNormal;
flat out vec4 gBox;
uniform int uResolution;
void main() {
  vec3 c0 = vClip[0], c1 = vClip[1], c2 = vClip[2];
  // Facing: counter-clockwise in the camera's view, as pass A keeps.
  if ((c1.x - c0.x) * (c2.y - c0.y) - (c1.y - c0.y) * (c2.x - c0.x) <= 0.0) return;
  // In view: the triangle's bounds meet the viewport.
  vec2 lo = min(c0.xy, min(c1.xy, c2.xy)), hi = max(c0.xy, max(c1.xy, c2.xy));
  if (any(greaterThan(lo, vec2(1.0))) || any(lessThan(hi, vec2(-1.0)))) return;
  float res = float(uResolution);
  vec2 p[3] = vec2[3](vUV[0] * res, vUV[1] * res, vUV[2] * res);
  float area = (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
  if (abs(area) < 1e-12) return;
  float orient = sign(area);
  // Outward unit normal of edge i (p[i] -> p[i+1]) and its offset: half a texel's extent along it.
  vec2 en[3];
  float ed[3];
  for (int i = 0; i < 3; ++i) {
    vec2 e = p[(i + 1) % 3] - p[i];
    en[i] = normalize(vec2(e.y, -e.x) * orient);
    ed[i] = 0.5 * (abs(en[i].x) + abs(en[i].y));
  }
  vec2 tlo = min(p[0], min(p[1], p[2])) - 0.5, thi = max(p[0], max(p[1], p[2])) + 0.5;
  for (int i = 0; i < 3; ++i) {
    // Vertex i moves to where its two edges' offset lines meet: x . n_a = d_a, x . n_b = d_b.
    vec2 na = en[(i + 2) % 3], nb = en[i];
    float da = ed[(i + 2) % 3], db = ed[i];
    float det = na.x * nb.y - na.y * nb.x;
    vec2 x = abs(det) > 1e-4 ? vec2(da * nb.y - db * na.y, na.x * db - nb.x * da) / det : na * da;
    float len = length(x);
    if (len > 4.0) x *= 4.0 / len;  // a needle's tip: the box below trims the rest
    vec2 q = p[i] + x;
    // Barycentrics of q in the original triangle: attributes extrapolate affinely.
    float w1 = ((q.x - p[0].x) * (p[2].y - p[0].y) - (q.y - p[0].y) * (p[2].x - p[0].x)) / area;
    float w2 = ((p[1].x - p[0].x) * (q.y - p[0].y) - (p[1].y - p[0].y) * (q.x - p[0].x)) / area;
    float w0 = 1.0 - w1 - w2;
    gClip = w0 * c0 + w1 * c1 + w2 * c2;
    gNormal = w0 * vNormal[0] + w1 * vNormal[1] + w2 * vNormal[2];
    gBox = vec4(tlo, thi);
    gl_Position = vec4(q / res * 2.0 - 1.0, 0.0, 1.0);
    EmitVertex();
  }
  EndPrimitive();
}
