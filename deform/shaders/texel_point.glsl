// texel_point.glsl (included): where a texel's centre lies on a triangle of X's mesh, in texel space.
// The gathers visit every texel whose square meets a triangle, also those whose centre lies outside it (at a
// chart's edge and in its gutter). Extrapolated over the triangle's plane such a centre may leave the surface: past
// a box's bottom edge a side face's texel lies half a texel below the box, inside whatever the box rests on, and
// would be cut by that overlap. Its dent is therefore the smaller of the extrapolated point's and that of the
// triangle's point nearest the centre (exact where the neighbouring triangle is coplanar: the triangle holding
// the centre gives it; at a convex crease the nearest point on the crease).

// Barycentrics (w0, w1, w2) of q in the triangle t0 t1 t2 (twice its signed area: `area`).
vec3 texelBarycentrics(vec2 q, vec2 t0, vec2 t1, vec2 t2, float area) {
  float w1 = ((q.x - t0.x) * (t2.y - t0.y) - (q.y - t0.y) * (t2.x - t0.x)) / area;
  float w2 = ((t1.x - t0.x) * (q.y - t0.y) - (t1.y - t0.y) * (q.x - t0.x)) / area;
  return vec3(1.0 - w1 - w2, w1, w2);
}

// Barycentrics of the triangle's point nearest q, given q's own (w): w where q lies inside, else the nearest
// point of the nearest edge.
vec3 nearestBarycentrics(vec2 q, vec2 t0, vec2 t1, vec2 t2, vec3 w) {
  if (all(greaterThanEqual(w, vec3(0.0)))) return w;
  vec2 a[3] = vec2[3](t0, t1, t2);
  float best = 1e30;
  vec3 out3 = w;
  for (int e = 0; e < 3; ++e) {
    vec2 p = a[e], d = a[(e + 1) % 3] - p;
    float len2 = dot(d, d);
    float s = len2 > 0.0 ? clamp(dot(q - p, d) / len2, 0.0, 1.0) : 0.0;
    vec2 r = q - (p + s * d);
    float dist = dot(r, r);
    if (dist < best) {
      best = dist;
      vec3 b = vec3(0.0);
      b[e] = 1.0 - s;
      b[(e + 1) % 3] = s;
      out3 = b;
    }
  }
  return out3;
}
