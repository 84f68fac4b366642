#include <crumple/physics/polytope.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

namespace crumple {

double ConvexPolytope::planeDistance(const glm::dvec3& p, int* face, const glm::dvec3* hint, double tie) const {
  double best = -std::numeric_limits<double>::infinity();
  int bestFace = 0;
  for (size_t f = 0; f < faces.size(); ++f) {
    const double d = glm::dot(faces[f].normal, p) - faces[f].offset;
    if (d > best) {
      best = d;
      bestFace = static_cast<int>(f);
    }
  }
  if (face && hint && tie > 0) {
    // Faces about as near as the nearest: the one facing the other body.
    double score = -2;
    for (size_t f = 0; f < faces.size(); ++f) {
      if (glm::dot(faces[f].normal, p) - faces[f].offset < best - tie) continue;
      const double s = glm::dot(faces[f].normal, *hint);
      if (s > score) {
        score = s;
        bestFace = static_cast<int>(f);
      }
    }
  }
  if (face) *face = bestFace;
  return best;
}

namespace {

// Normals, offsets, edges and their directions from the vertices and face
// loops (any winding: each loop is turned to face away from the centroid).
void finish(ConvexPolytope& p) {
  p.centroid = glm::dvec3(0);
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const glm::dvec3& v : p.vertices) {
    p.centroid += v;
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  p.centroid /= static_cast<double>(p.vertices.size());
  const glm::dvec3 extent = hi - lo;
  p.size = std::max({extent.x, extent.y, extent.z});
  std::map<std::pair<int, int>, int> edgeIndex;
  for (ConvexPolytope::Face& f : p.faces) {
    // Newell's normal: robust for any planar polygon.
    glm::dvec3 n(0), c(0);
    for (size_t i = 0; i < f.loop.size(); ++i) {
      const glm::dvec3& u = p.vertices[static_cast<size_t>(f.loop[i])];
      const glm::dvec3& w = p.vertices[static_cast<size_t>(f.loop[(i + 1) % f.loop.size()])];
      n += glm::dvec3((u.y - w.y) * (u.z + w.z), (u.z - w.z) * (u.x + w.x), (u.x - w.x) * (u.y + w.y));
      c += u;
    }
    c /= static_cast<double>(f.loop.size());
    n = glm::normalize(n);
    if (glm::dot(n, c - p.centroid) < 0) {
      std::reverse(f.loop.begin(), f.loop.end());
      n = -n;
    }
    f.normal = n;
    f.offset = glm::dot(n, c);
    for (size_t i = 0; i < f.loop.size(); ++i) {
      int u = f.loop[i], w = f.loop[(i + 1) % f.loop.size()];
      if (u > w) std::swap(u, w);
      if (edgeIndex.emplace(std::make_pair(u, w), static_cast<int>(p.edges.size())).second) p.edges.push_back({u, w});
    }
  }
  for (const glm::ivec2& e : p.edges) {
    const glm::dvec3 d =
        glm::normalize(p.vertices[static_cast<size_t>(e.y)] - p.vertices[static_cast<size_t>(e.x)]);
    bool seen = false;
    for (const glm::dvec3& o : p.edgeDirections) seen = seen || std::abs(glm::dot(o, d)) > 1 - 1e-9;
    if (!seen) p.edgeDirections.push_back(d);
  }
}

// The convex hull, counter-clockwise, of points in a plane (Andrew's monotone
// chain on 2D coordinates); collinear points are dropped.
std::vector<int> hull2d(const std::vector<int>& ids, const std::vector<glm::dvec2>& q) {
  std::vector<size_t> order(ids.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](size_t i, size_t j) { return std::tie(q[i].x, q[i].y) < std::tie(q[j].x, q[j].y); });
  auto cross = [&](size_t o, size_t a, size_t b) {
    return (q[a].x - q[o].x) * (q[b].y - q[o].y) - (q[a].y - q[o].y) * (q[b].x - q[o].x);
  };
  std::vector<size_t> h(2 * order.size());
  size_t k = 0;
  for (size_t i : order) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], i) <= 0) --k;
    h[k++] = i;
  }
  for (size_t t = order.size() - 1, lower = k + 1; t-- > 0;) {
    const size_t i = order[t];
    while (k >= lower && cross(h[k - 2], h[k - 1], i) <= 0) --k;
    h[k++] = i;
  }
  h.resize(k > 0 ? k - 1 : 0);
  std::vector<int> loop;
  for (size_t i : h) loop.push_back(ids[i]);
  return loop;
}

}  // namespace

std::shared_ptr<const ConvexPolytope> boxPolytope(const glm::dvec3& h) {
  auto p = std::make_shared<ConvexPolytope>();
  for (int i = 0; i < 8; ++i) p->vertices.push_back({i & 1 ? h.x : -h.x, i & 2 ? h.y : -h.y, i & 4 ? h.z : -h.z});
  const int loops[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};
  for (const auto& l : loops) p->faces.push_back({glm::dvec3(0), 0, {l[0], l[1], l[2], l[3]}});
  finish(*p);
  return p;
}

std::shared_ptr<const ConvexPolytope> convexPolytope(const TriangleMesh& mesh, int maxFaces) {
  auto p = std::make_shared<ConvexPolytope>();
  // Vertices once each (a mesh splits them at texture seams).
  std::map<std::tuple<float, float, float>, int> index;
  std::vector<int> remap(mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const glm::vec3& v = mesh.positions[i];
    const auto it = index.emplace(std::make_tuple(v.x, v.y, v.z), static_cast<int>(p->vertices.size()));
    if (it.second) p->vertices.push_back(glm::dvec3(v));
    remap[i] = it.first->second;
  }
  if (p->vertices.size() < 4) return nullptr;
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (const glm::dvec3& v : p->vertices) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  const double size = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  const double tol = 1e-5 * size + 1e-6;
  // Triangles on one plane make one face.
  struct Plane {
    glm::dvec3 n, sum{0};
    double d;
    std::vector<int> ids;
  };
  std::vector<Plane> planes;
  for (const glm::uvec3& t : mesh.triangles) {
    const glm::dvec3& a = p->vertices[static_cast<size_t>(remap[t.x])];
    const glm::dvec3& b = p->vertices[static_cast<size_t>(remap[t.y])];
    const glm::dvec3& c = p->vertices[static_cast<size_t>(remap[t.z])];
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    const double len = glm::length(cr);
    if (!(len > 1e-12 * size * size)) continue;  // degenerate
    const glm::dvec3 n = cr / len;
    const double d = glm::dot(n, a);
    Plane* plane = nullptr;
    for (Plane& q : planes)
      if (glm::dot(q.n, n) > 1 - 1e-8 && std::abs(q.d - d) < tol) plane = &q;
    if (!plane) {
      if (static_cast<int>(planes.size()) >= maxFaces) return nullptr;
      planes.push_back({n, glm::dvec3(0), d, {}});
      plane = &planes.back();
    }
    plane->sum += cr;
    for (unsigned v : {t.x, t.y, t.z}) plane->ids.push_back(remap[v]);
  }
  if (planes.size() < 4) return nullptr;
  for (Plane& q : planes) {
    std::sort(q.ids.begin(), q.ids.end());
    q.ids.erase(std::unique(q.ids.begin(), q.ids.end()), q.ids.end());
    const glm::dvec3 n = glm::normalize(q.sum);
    // Convex: every vertex on the inner side of every face plane.
    const double d = glm::dot(n, p->vertices[static_cast<size_t>(q.ids[0])]);
    for (const glm::dvec3& v : p->vertices)
      if (glm::dot(n, v) - d > tol) return nullptr;
    const glm::dvec3 u = glm::normalize(std::abs(n.x) < 0.57 ? glm::cross(n, glm::dvec3(1, 0, 0))
                                                             : glm::cross(n, glm::dvec3(0, 1, 0)));
    const glm::dvec3 w = glm::cross(n, u);
    std::vector<glm::dvec2> q2;
    for (int id : q.ids) {
      const glm::dvec3& v = p->vertices[static_cast<size_t>(id)];
      q2.push_back({glm::dot(v, u), glm::dot(v, w)});
    }
    std::vector<int> loop = hull2d(q.ids, q2);
    if (loop.size() < 3) return nullptr;
    p->faces.push_back({n, d, std::move(loop)});
  }
  finish(*p);
  return p;
}

namespace {

struct Scratch {
  std::vector<glm::dvec3> vb, poly, next;
};

// Closest points of segments p0p1 and q0q1 (Ericson, Real-Time Collision Detection 5.1.9).
void closestPoints(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& q0, const glm::dvec3& q1,
                   glm::dvec3& pa, glm::dvec3& pb) {
  const glm::dvec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = glm::dot(d1, d1), e = glm::dot(d2, d2), f = glm::dot(d2, r);
  const double c = glm::dot(d1, r), b = glm::dot(d1, d2);
  const double denom = a * e - b * b;
  double s = denom > 1e-18 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double t = e > 0 ? (b * s + f) / e : 0.0;
  if (t < 0) {
    t = 0;
    s = a > 0 ? std::clamp(-c / a, 0.0, 1.0) : 0.0;
  } else if (t > 1) {
    t = 1;
    s = a > 0 ? std::clamp((b - c) / a, 0.0, 1.0) : 0.0;
  }
  pa = p0 + d1 * s;
  pb = q0 + d2 * t;
}

// The edge of `p` (vertices `v`, in the working frame) parallel to `dir` that
// reaches furthest along `axis` (sign +1) or least far (sign -1).
glm::ivec2 supportEdge(const ConvexPolytope& p, const std::vector<glm::dvec3>& v, const glm::dvec3& dir,
                       const glm::dvec3& axis, double sign) {
  glm::ivec2 best = p.edges.front();
  double bestValue = -std::numeric_limits<double>::infinity();
  for (const glm::ivec2& e : p.edges) {
    const glm::dvec3 a = v[static_cast<size_t>(e.x)], b = v[static_cast<size_t>(e.y)];
    const glm::dvec3 d = b - a;
    const double len = glm::length(d);
    if (!(len > 0) || std::abs(glm::dot(d / len, dir)) < 1 - 1e-6) continue;
    const double value = sign * glm::dot(a + b, axis);
    if (value > bestValue) {
      bestValue = value;
      best = e;
    }
  }
  return best;
}

}  // namespace

void polytopeContacts(const ConvexPolytope& a, const ConvexPolytope& b, const RigidMap& bToA,
                      std::vector<PolytopeContact>& out) {
  out.clear();
  thread_local Scratch s;
  std::vector<glm::dvec3>& vb = s.vb;
  vb.resize(b.vertices.size());
  for (size_t j = 0; j < vb.size(); ++j) vb[j] = bToA(b.vertices[j]);
  const std::vector<glm::dvec3>& va = a.vertices;
  auto minAlong = [](const std::vector<glm::dvec3>& v, const glm::dvec3& n) {
    double m = std::numeric_limits<double>::infinity();
    for (const glm::dvec3& x : v) m = std::min(m, glm::dot(n, x));
    return m;
  };
  // Faces of A: how far B's deepest vertex is past each plane.
  double sepA = -std::numeric_limits<double>::infinity();
  int faceA = -1;
  for (size_t f = 0; f < a.faces.size(); ++f) {
    const double sep = minAlong(vb, a.faces[f].normal) - a.faces[f].offset;
    if (sep > 0) return;  // a separating plane
    if (sep > sepA) {
      sepA = sep;
      faceA = static_cast<int>(f);
    }
  }
  double sepB = -std::numeric_limits<double>::infinity();
  int faceB = -1;
  for (size_t f = 0; f < b.faces.size(); ++f) {
    const glm::dvec3 n = bToA.rotation * b.faces[f].normal;
    const double offset = b.faces[f].offset + glm::dot(n, bToA.translation);
    const double sep = minAlong(va, n) - offset;
    if (sep > 0) return;
    if (sep > sepB) {
      sepB = sep;
      faceB = static_cast<int>(f);
    }
  }
  // Edge pairs: the axis normal to both, pointing from A to B.
  const glm::dvec3 ca = a.centroid, cb = bToA(b.centroid);
  double sepE = -std::numeric_limits<double>::infinity();
  glm::dvec3 axisE(0), dirA(0), dirB(0);
  for (const glm::dvec3& ea : a.edgeDirections) {
    for (const glm::dvec3& ebLocal : b.edgeDirections) {
      const glm::dvec3 eb = bToA.rotation * ebLocal;
      glm::dvec3 axis = glm::cross(ea, eb);
      const double len = glm::length(axis);
      if (len < 1e-6) continue;  // parallel edges: the face axes cover them
      axis /= len;
      if (glm::dot(axis, cb - ca) < 0) axis = -axis;
      const double sep = minAlong(vb, axis) + minAlong(va, -axis);
      if (sep > 0) return;
      if (sep > sepE) {
        sepE = sep;
        axisE = axis;
        dirA = ea;
        dirB = eb;
      }
    }
  }
  const double size = std::max(a.size, b.size);
  const double faceSep = std::max(sepA, sepB);
  if (sepE > faceSep + 0.05 * std::abs(faceSep) + 1e-5 * size) {
    // Two edges cross: one point, on B's edge.
    const glm::ivec2 e = supportEdge(a, va, dirA, axisE, 1.0);
    const glm::ivec2 f = supportEdge(b, vb, dirB, axisE, -1.0);
    glm::dvec3 pa, pb;
    closestPoints(va[static_cast<size_t>(e.x)], va[static_cast<size_t>(e.y)], vb[static_cast<size_t>(f.x)],
                  vb[static_cast<size_t>(f.y)], pa, pb);
    const double depth = glm::dot(pb - pa, axisE);
    if (depth < 0) out.push_back({true, pb, axisE, depth});
    return;
  }
  // The reference face: the one of least penetration, A's unless B's is clearly less.
  const bool onA = !(sepB > sepA + 0.05 * std::abs(sepA) + 1e-5 * size);
  const ConvexPolytope& ref = onA ? a : b;
  const ConvexPolytope& inc = onA ? b : a;
  const std::vector<glm::dvec3>& refV = onA ? va : vb;
  const std::vector<glm::dvec3>& incV = onA ? vb : va;
  const ConvexPolytope::Face& rf = ref.faces[static_cast<size_t>(onA ? faceA : faceB)];
  const glm::dvec3 n = onA ? rf.normal : bToA.rotation * rf.normal;
  const double offset = glm::dot(n, refV[static_cast<size_t>(rf.loop[0])]);
  // The incident face: the other body's face most nearly opposite.
  size_t incident = 0;
  double most = std::numeric_limits<double>::infinity();
  for (size_t f = 0; f < inc.faces.size(); ++f) {
    const double d = glm::dot(onA ? bToA.rotation * inc.faces[f].normal : inc.faces[f].normal, n);
    if (d < most) {
      most = d;
      incident = f;
    }
  }
  std::vector<glm::dvec3>& poly = s.poly;
  std::vector<glm::dvec3>& next = s.next;
  poly.clear();
  for (int i : inc.faces[incident].loop) poly.push_back(incV[static_cast<size_t>(i)]);
  // Clip it by the planes through the reference face's edges (Sutherland-Hodgman).
  for (size_t i = 0; i < rf.loop.size() && !poly.empty(); ++i) {
    const glm::dvec3& p0 = refV[static_cast<size_t>(rf.loop[i])];
    const glm::dvec3& p1 = refV[static_cast<size_t>(rf.loop[(i + 1) % rf.loop.size()])];
    const glm::dvec3 side = glm::cross(p1 - p0, n);  // outward: the loop runs counter-clockwise about n
    next.clear();
    for (size_t k = 0; k < poly.size(); ++k) {
      const glm::dvec3& p = poly[k];
      const glm::dvec3& q = poly[(k + 1) % poly.size()];
      const double dp = glm::dot(side, p - p0), dq = glm::dot(side, q - p0);
      if (dp <= 0) next.push_back(p);
      if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0)) next.push_back(p + (q - p) * (dp / (dp - dq)));
    }
    poly.swap(next);
  }
  for (const glm::dvec3& p : poly) {
    const double depth = glm::dot(n, p) - offset;
    if (depth < 0) out.push_back({onA, p, n, depth});
  }
}


namespace {

// The reference rectangle's face (axis `axis`, side `sign`, of the box of half extents `hr` about the origin)
// against the incident box (half extents `hi`; its axes `r[j]` and centre `t` in the reference frame): the face
// of the incident box most nearly opposite, clipped to the rectangle's sides, its points below the face.
void clipBoxFace(const glm::dvec3& hr, const glm::dvec3& hi, const glm::dmat3& r, const glm::dvec3& t, int axis,
                 double sign, bool normalOfA, std::vector<PolytopeContact>& out) {
  // The incident face: the axis most nearly along the normal, on the side facing the reference body.
  int j = 0;
  double best = std::abs(r[0][axis]);
  for (int k = 1; k < 3; ++k)
    if (std::abs(r[k][axis]) > best) {
      best = std::abs(r[k][axis]);
      j = k;
    }
  const double faceSign = sign * r[j][axis] < 0 ? 1.0 : -1.0;
  const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
  const glm::dvec3 centre = t + r[j] * (faceSign * hi[j]);
  const glm::dvec3 u = r[j1] * hi[j1], w = r[j2] * hi[j2];
  // A polygon of at most 8 points (a quadrilateral clipped by four lines), clipped from one buffer into the other.
  glm::dvec3 bufferA[8] = {centre + u + w, centre - u + w, centre - u - w, centre + u - w};
  glm::dvec3 bufferB[8];
  glm::dvec3* poly = bufferA;
  glm::dvec3* next = bufferB;
  int count = 4;
  const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
  for (int plane = 0; plane < 4 && count > 0; ++plane) {
    const int k = plane < 2 ? a1 : a2;
    const double side = plane % 2 == 0 ? 1.0 : -1.0;
    const double limit = hr[k];
    int kept = 0;
    double dp = side * poly[0][k] - limit;
    for (int m = 0; m < count; ++m) {
      const glm::dvec3& p = poly[m];
      const glm::dvec3& q = poly[m + 1 < count ? m + 1 : 0];
      const double dq = side * q[k] - limit;
      if (dp <= 0) next[kept++] = p;
      if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0)) next[kept++] = p + (q - p) * (dp / (dp - dq));
      dp = dq;
    }
    count = kept;
    std::swap(poly, next);
  }
  glm::dvec3 n(0);
  n[axis] = sign;
  for (int m = 0; m < count; ++m) {
    const double depth = sign * poly[m][axis] - hr[axis];
    if (depth < 0) out.push_back({normalOfA, poly[m], n, depth});
  }
}

}  // namespace

void boxContacts(const glm::dvec3& ha, const glm::dvec3& hb, const RigidMap& bToA, std::vector<PolytopeContact>& out,
                 double* separation) {
  out.clear();
  if (separation) *separation = -1;
  const glm::dmat3& r = bToA.rotation;  // r[j]: B's axis j in A's frame; r[j][i] its i-th component
  const glm::dvec3& t = bToA.translation;
  glm::dmat3 absR;
  for (int j = 0; j < 3; ++j) absR[j] = glm::abs(r[j]);
  // A's faces: B's deepest vertex past the face on the side facing B.
  double sepA = -std::numeric_limits<double>::infinity();
  int faceA = 0;
  for (int i = 0; i < 3; ++i) {
    const double sep = std::abs(t[i]) - ha[i] - (hb.x * absR[0][i] + hb.y * absR[1][i] + hb.z * absR[2][i]);
    if (sep > 0) {
      if (separation) *separation = sep;
      return;
    }
    if (sep > sepA) {
      sepA = sep;
      faceA = i;
    }
  }
  double sepB = -std::numeric_limits<double>::infinity();
  int faceB = 0;
  for (int j = 0; j < 3; ++j) {
    const double sep = std::abs(glm::dot(t, r[j])) - hb[j] - glm::dot(ha, absR[j]);
    if (sep > 0) {
      if (separation) *separation = sep;
      return;
    }
    if (sep > sepB) {
      sepB = sep;
      faceB = j;
    }
  }
  // Edge pairs: axis e_i x r_j, pointing from A to B. Unnormalised, its components are r_j's (0, -r_j[i2],
  // r_j[i1]) and its length sqrt(r_j[i1]^2 + r_j[i2]^2); B's axis k != j projects on it as +-r_m[i], m the third.
  // An edge pair counts only where it separates (then nothing touches) or where its separation passes the faces'
  // by the margin below (then two edges cross): the others are told apart without the root and the division.
  const double size = 2 * std::max({ha.x, ha.y, ha.z, hb.x, hb.y, hb.z});
  const double faceSep = std::max(sepA, sepB);
  const double edgeMargin = faceSep + 0.05 * std::abs(faceSep) + 1e-5 * size;  // edges must do better than this
  double sepE = -std::numeric_limits<double>::infinity();
  int edgeA = 0, edgeB = 0;
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      const double len2 = r[j][i1] * r[j][i1] + r[j][i2] * r[j][i2];
      if (len2 < 1e-12) continue;  // parallel edges: the face axes cover them
      const double along = std::abs(t[i2] * r[j][i1] - t[i1] * r[j][i2]);
      const double reachA = ha[i1] * absR[j][i2] + ha[i2] * absR[j][i1];
      const double reachB = hb[j1] * absR[j2][i] + hb[j2] * absR[j1][i];
      const double num = along - reachA - reachB;
      if (num > 0) {  // a separating axis (its gap reported only where the division keeps it exact enough)
        if (separation) *separation = len2 >= 1e-6 ? num / std::sqrt(len2) : -1.0;
        return;
      }
      // num / len > edgeMargin needs edgeMargin < 0 and num^2 < edgeMargin^2 len^2 (both negative); a little
      // slack, and the exact test decides.
      if (!(edgeMargin < 0) || num * num > edgeMargin * edgeMargin * len2 * (1 + 1e-9)) continue;
      const double sep = num / std::sqrt(len2);
      if (sep > sepE) {
        sepE = sep;
        edgeA = i;
        edgeB = j;
      }
    }
  }
  if (sepE > edgeMargin) {
    // Two edges cross: A's edge along e_i furthest along the axis, B's along r_j least far; one point, on B's edge.
    glm::dvec3 e(0);
    e[edgeA] = 1;
    glm::dvec3 axisE = glm::normalize(glm::cross(e, r[edgeB]));
    if (glm::dot(axisE, t) < 0) axisE = -axisE;
    glm::dvec3 a0, a1;
    for (int k = 0; k < 3; ++k) a0[k] = a1[k] = axisE[k] < 0 ? -ha[k] : ha[k];
    a0[edgeA] = -ha[edgeA];
    a1[edgeA] = ha[edgeA];
    const glm::dvec3 inB = glm::transpose(r) * axisE;
    glm::dvec3 b0, b1;
    for (int k = 0; k < 3; ++k) b0[k] = b1[k] = inB[k] < 0 ? hb[k] : -hb[k];
    b0[edgeB] = -hb[edgeB];
    b1[edgeB] = hb[edgeB];
    glm::dvec3 pa, pb;
    closestPoints(a0, a1, bToA(b0), bToA(b1), pa, pb);
    const double depth = glm::dot(pb - pa, axisE);
    if (depth < 0) out.push_back({true, pb, axisE, depth});
    return;
  }
  if (!(sepB > sepA + 0.05 * std::abs(sepA) + 1e-5 * size)) {
    clipBoxFace(ha, hb, r, t, faceA, t[faceA] > 0 ? 1.0 : -1.0, true, out);
    return;
  }
  // B's face is the reference: clip in B's frame, then bring the points and the normal back into A's.
  const glm::dmat3 rt = glm::transpose(r);
  const glm::dvec3 tb = -(rt * t);
  clipBoxFace(hb, ha, rt, tb, faceB, tb[faceB] > 0 ? 1.0 : -1.0, false, out);
  for (PolytopeContact& c : out) {
    c.point = bToA(c.point);
    c.normal = r * c.normal;
  }
}

}  // namespace crumple
