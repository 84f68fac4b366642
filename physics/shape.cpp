#include <crumple/physics/shape.h>

#include <crumple/physics/sample_tree.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/constants.hpp>
#include <map>
#include <stdexcept>
#include <tuple>

namespace crumple {

const char* shapeTypeName(ShapeType t) {
  switch (t) {
    case ShapeType::Box:
      return "box";
    case ShapeType::Sphere:
      return "sphere";
    case ShapeType::Capsule:
      return "capsule";
    case ShapeType::Cylinder:
      return "cylinder";
    case ShapeType::Mesh:
      return "mesh";
  }
  return "?";
}

namespace {

// Inside a box the nearest face is ambiguous along its edges: a box resting
// squarely on another has its corners exactly on the lower box's side planes,
// and "nearest face" would push it sideways. Faces within `tie` of the nearest
// are candidates; the hint (direction towards the other body) picks among them.
double boxDistance(const glm::dvec3& p, const glm::dvec3& h, glm::dvec3* grad, const glm::dvec3* hint) {
  const glm::dvec3 q = glm::abs(p) - h;
  const double qMax = std::max({q.x, q.y, q.z});
  const glm::dvec3 outside = glm::max(q, glm::dvec3(0));
  const double outLen = qMax > 0 ? glm::length(outside) : 0.0;  // inside: no square root
  const double inside = std::min(qMax, 0.0);
  if (grad) {
    const glm::dvec3 s(p.x < 0 ? -1 : 1, p.y < 0 ? -1 : 1, p.z < 0 ? -1 : 1);
    if (outLen > 0) {
      *grad = s * outside / outLen;
    } else {
      int axis = q.x >= q.y ? (q.x >= q.z ? 0 : 2) : (q.y >= q.z ? 1 : 2);
      if (hint) {
        const double tie = 0.1 * std::min({h.x, h.y, h.z});
        double best = -2;
        for (int i = 0; i < 3; ++i) {
          if (q[i] < q[axis] - tie) continue;
          const double score = s[i] * (*hint)[i];
          if (score > best) {
            best = score;
            axis = i;
          }
        }
      }
      glm::dvec3 g(0);
      g[axis] = s[axis];
      *grad = g;
    }
  }
  return outLen + inside;
}

// Distance to a y-axis segment of half length hh, minus r (capsule).
double capsuleDistance(const glm::dvec3& p, double r, double hh, glm::dvec3* grad) {
  const glm::dvec3 c(0, std::clamp(p.y, -hh, hh), 0);
  const glm::dvec3 d = p - c;
  const double len = glm::length(d);
  if (grad) *grad = len > 1e-12 ? d / len : glm::dvec3(1, 0, 0);  // on the axis: any radial direction
  return len - r;
}

double cylinderDistance(const glm::dvec3& p, double r, double hh, glm::dvec3* grad) {
  const double radial = std::sqrt(p.x * p.x + p.z * p.z);
  const glm::dvec2 q(radial - r, std::abs(p.y) - hh);
  const glm::dvec2 outside = glm::max(q, glm::dvec2(0));
  const double outLen = glm::length(outside);
  const double inside = std::min(std::max(q.x, q.y), 0.0);
  if (grad) {
    const glm::dvec3 radialDir = radial > 1e-12 ? glm::dvec3(p.x, 0, p.z) / radial : glm::dvec3(1, 0, 0);
    const glm::dvec3 axialDir(0, p.y < 0 ? -1 : 1, 0);
    glm::dvec2 g2;
    if (outLen > 0)
      g2 = outside / outLen;
    else
      g2 = q.x >= q.y ? glm::dvec2(1, 0) : glm::dvec2(0, 1);
    *grad = glm::normalize(g2.x * radialDir + g2.y * axialDir);
  }
  return outLen + inside;
}

// The radius about the shape origin of the least sphere there holding the shape: its farthest point's distance (a
// box's corner; a mesh's farthest vertex: its triangles lie within their vertices' sphere). Also the samples'
// tree, where there are enough of them.
void finishBounds(Shape& s) {
  switch (s.type) {
    case ShapeType::Box:
      s.boundingRadius = glm::length(s.halfExtents);
      break;
    case ShapeType::Sphere:
      s.boundingRadius = s.radius;
      break;
    case ShapeType::Capsule:
      s.boundingRadius = s.halfHeight + s.radius;
      break;
    case ShapeType::Cylinder:
      s.boundingRadius = std::sqrt(s.radius * s.radius + s.halfHeight * s.halfHeight);
      break;
    case ShapeType::Mesh:
      s.boundingRadius = 0;
      for (const glm::dvec3& p : s.samples) s.boundingRadius = std::max(s.boundingRadius, glm::length(p));
      break;
  }
  s.cachedHalfThickness = s.computeHalfThickness();
  if (s.samples.size() > SampleTree::kMinSamples) s.sampleTree = std::make_shared<const SampleTree>(s.samples);
}

}  // namespace

double Shape::distanceSlope() const {
  switch (type) {
    case ShapeType::Box:
    case ShapeType::Sphere:
    case ShapeType::Capsule:
    case ShapeType::Cylinder:
      return 1.0;
    case ShapeType::Mesh:
      return polytope || !grid ? 0.0 : grid->lipschitz();
  }
  return 0.0;
}

double Shape::distance(const glm::dvec3& p, glm::dvec3* gradient, const glm::dvec3* hint, double gradientBelow) const {
  switch (type) {
    case ShapeType::Box:
      return boxDistance(p, halfExtents, gradient, hint);
    case ShapeType::Sphere: {
      const double len = glm::length(p);
      if (gradient) *gradient = len > 1e-12 ? p / len : glm::dvec3(0, 1, 0);
      return len - radius;
    }
    case ShapeType::Capsule:
      return capsuleDistance(p, radius, halfHeight, gradient);
    case ShapeType::Cylinder:
      return cylinderDistance(p, radius, halfHeight, gradient);
    case ShapeType::Mesh: {
      if (!polytope) return grid->distance(p, gradient, gradientBelow);
      // Convex: inside, the nearest face plane is the exact distance (the grid
      // rounds the edges off, by up to a cell); outside, the grid's value, never
      // below the plane distance (a lower bound there).
      int face = 0;
      const double tie = 0.1 * halfThickness();
      const double planes = polytope->planeDistance(p, &face, hint, tie);
      if (planes <= 0) {
        if (gradient) *gradient = polytope->faces[static_cast<size_t>(face)].normal;
        return planes;
      }
      const double field = grid->distance(p, gradient);
      if (field >= planes) return field;
      if (gradient) *gradient = polytope->faces[static_cast<size_t>(face)].normal;
      return planes;
    }
  }
  return 0;
}

double Shape::computeHalfThickness() const {
  switch (type) {
    case ShapeType::Box:
      return std::min({halfExtents.x, halfExtents.y, halfExtents.z});
    case ShapeType::Sphere:
    case ShapeType::Capsule:
      return radius;
    case ShapeType::Cylinder:
      return std::min(radius, halfHeight);
    case ShapeType::Mesh: {
      const glm::dvec3 e = (boundsMax - boundsMin) * 0.5;
      // A conservative guess for thin-walled meshes, a quarter of the smallest half extent, unless every
      // part of the mesh was found thicker (a torus: its tube's radius).
      return std::max(std::min({e.x, e.y, e.z}) * 0.25, localHalfThickness);
    }
  }
  return 0;
}

std::shared_ptr<Shape> makeBox(const glm::dvec3& size) {
  if (!(size.x > 0 && size.y > 0 && size.z > 0)) throw std::invalid_argument("box size must be positive");
  auto s = std::make_shared<Shape>();
  s->type = ShapeType::Box;
  s->halfExtents = size * 0.5;
  const glm::dvec3 h = s->halfExtents;
  // Corners, edge midpoints and points inside each face. Guendelman's bodies
  // test mesh vertices only, but a box's vertices all lie on its side planes:
  // resting squarely on an identical box they sit exactly on the lower box's
  // edges, where inside/outside is decided by rounding. Face points give
  // aligned stacks a support polygon that is unambiguously inside.
  const int edgeSamples = 1;
  for (int axis = 0; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (double side : {-1.0, 1.0}) {
      for (const glm::dvec2 f : {glm::dvec2(0, 0), glm::dvec2(-0.6, -0.6), glm::dvec2(0.6, -0.6), glm::dvec2(-0.6, 0.6),
                                 glm::dvec2(0.6, 0.6)}) {
        glm::dvec3 p;
        p[axis] = side * h[axis];
        p[a1] = f.x * h[a1];
        p[a2] = f.y * h[a2];
        s->samples.push_back(p);
      }
    }
  }
  for (int c = 0; c < 8; ++c) s->samples.push_back(h * glm::dvec3(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1));
  for (int axis = 0; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (int corner = 0; corner < 4; ++corner) {
      for (int k = 1; k <= edgeSamples; ++k) {
        glm::dvec3 p;
        p[axis] = -h[axis] + 2 * h[axis] * k / (edgeSamples + 1);
        p[a1] = corner & 1 ? h[a1] : -h[a1];
        p[a2] = corner & 2 ? h[a2] : -h[a2];
        s->samples.push_back(p);
      }
    }
  }
  for (const glm::dvec3& p : s->samples) {
    glm::dvec3 n(0);
    for (int i = 0; i < 3; ++i)
      if (std::abs(std::abs(p[i]) - h[i]) < 1e-12 * (1 + h[i])) n[i] = p[i] > 0 ? 1 : -1;
    s->sampleNormals.push_back(glm::normalize(n));
  }
  s->boundsMin = -h;
  s->boundsMax = h;
  s->polytope = boxPolytope(h);
  const double v = size.x * size.y * size.z;
  s->unitMass.volume = v;
  s->unitMass.inertia =
      glm::dmat3(v / 12 * (size.y * size.y + size.z * size.z), 0, 0, 0, v / 12 * (size.x * size.x + size.z * size.z), 0,
                 0, 0, v / 12 * (size.x * size.x + size.y * size.y));
  finishBounds(*s);
  return s;
}

std::shared_ptr<Shape> makeSphere(double radius) {
  if (!(radius > 0)) throw std::invalid_argument("sphere radius must be positive");
  auto s = std::make_shared<Shape>();
  s->type = ShapeType::Sphere;
  s->radius = radius;
  s->samples = {glm::dvec3(0)};
  s->sampleRadius = radius;
  s->boundsMin = glm::dvec3(-radius);
  s->boundsMax = glm::dvec3(radius);
  const double v = 4.0 / 3.0 * glm::pi<double>() * radius * radius * radius;
  s->unitMass.volume = v;
  s->unitMass.inertia = glm::dmat3(0.4 * v * radius * radius);
  finishBounds(*s);
  return s;
}

std::shared_ptr<Shape> makeCapsule(double radius, double height) {
  if (!(radius > 0) || !(height >= 0))
    throw std::invalid_argument("capsule radius must be positive and height non-negative");
  auto s = std::make_shared<Shape>();
  s->type = ShapeType::Capsule;
  s->radius = radius;
  s->halfHeight = height * 0.5;
  // Sphere samples along the axis, one radius apart; at most 4097 of them (a capsule 10^8 radii long would
  // otherwise take gigabytes): beyond 4096 radii the samples stand further apart than a radius, and the
  // capsule's exact distance function (which the other body's samples meet) keeps its surface whole.
  const double perRadius = std::ceil(std::min(height / radius, 4096.0));
  const int n = std::max(2, static_cast<int>(perRadius) + 1);
  for (int i = 0; i < n; ++i) s->samples.push_back({0, -s->halfHeight + height * i / (n - 1), 0});
  s->sampleRadius = radius;
  s->boundsMin = glm::dvec3(-radius, -s->halfHeight - radius, -radius);
  s->boundsMax = -s->boundsMin;
  const double pi = glm::pi<double>();
  const double r2 = radius * radius;
  const double vc = pi * r2 * height, vh = 2.0 / 3.0 * pi * r2 * radius;  // cylinder, one hemisphere
  s->unitMass.volume = vc + 2 * vh;
  const double iy = vc * r2 / 2 + 2 * vh * 2 * r2 / 5;
  const double ix =
      vc * (3 * r2 + height * height) / 12 + 2 * vh * (2 * r2 / 5 + height * height / 4 + 3 * height * radius / 8);
  s->unitMass.inertia = glm::dmat3(ix, 0, 0, 0, iy, 0, 0, 0, ix);
  finishBounds(*s);
  return s;
}

std::shared_ptr<Shape> makeCylinder(double radius, double height) {
  if (!(radius > 0) || !(height > 0)) throw std::invalid_argument("cylinder radius and height must be positive");
  auto s = std::make_shared<Shape>();
  s->type = ShapeType::Cylinder;
  s->radius = radius;
  s->halfHeight = height * 0.5;
  const int rim = 24;
  for (int i = 0; i < rim; ++i) {
    const double a = 2 * glm::pi<double>() * i / rim;
    for (double y : {-s->halfHeight, s->halfHeight}) {
      s->samples.push_back({radius * std::cos(a), y, radius * std::sin(a)});
      s->sampleNormals.push_back(glm::normalize(glm::dvec3(std::cos(a), y > 0 ? 1 : -1, std::sin(a))));
    }
  }
  s->boundsMin = glm::dvec3(-radius, -s->halfHeight, -radius);
  s->boundsMax = -s->boundsMin;
  const double v = glm::pi<double>() * radius * radius * height;
  s->unitMass.volume = v;
  const double ix = v * (3 * radius * radius + height * height) / 12;
  s->unitMass.inertia = glm::dmat3(ix, 0, 0, 0, v * radius * radius / 2, 0, 0, 0, ix);
  finishBounds(*s);
  return s;
}

namespace {
// The thinnest local half thickness of a mesh (the shape diameter function's least value, halved): from the
// centre of each triangle, straight in against its normal, half the way to where the ray leaves the body
// (sphere tracing through the field); the least over the triangles. A torus: its tube's radius.
double localHalfThickness(const SdfGrid& grid, const TriangleMesh& mesh, const glm::dvec3& extent) {
  const double reach = glm::length(extent);
  const double tol = 1e-4 * reach;
  double thinnest = reach;
  for (const glm::uvec3& t : mesh.triangles) {
    const glm::dvec3 a(mesh.positions[t.x]), b(mesh.positions[t.y]), c(mesh.positions[t.z]);
    const glm::dvec3 cross = glm::cross(b - a, c - a);
    const double area2 = glm::length(cross);
    if (!(area2 > 1e-12 * reach * reach)) continue;  // degenerate
    const glm::dvec3 n = cross / area2;
    const glm::dvec3 start = (a + b + c) / 3.0;
    double t0 = 2 * tol;
    for (int k = 0; k < 256 && t0 < 2 * thinnest; ++k) {
      const double phi = grid.distance(start - n * t0, nullptr);
      if (phi > -tol) break;  // out (or on the far side)
      t0 += std::max(-phi, tol);
    }
    thinnest = std::min(thinnest, 0.5 * t0);
  }
  return thinnest;
}
}  // namespace

std::shared_ptr<Shape> makeMeshShape(const TriangleMesh& mesh, int gridResolution) {
  if (mesh.triangles.empty()) throw std::invalid_argument("mesh has no triangles");
  auto s = std::make_shared<Shape>();
  s->type = ShapeType::Mesh;
  s->unitMass = polyhedralMassProperties(mesh);
  if (!(s->unitMass.volume > 0)) {
    throw std::invalid_argument("mesh encloses no volume (open, inside-out or flat): cannot compute mass properties");
  }
  // Vertices, and the midpoints of edges: vertex samples alone let two tubes
  // that cross edge to edge slide through each other between vertices.
  std::map<std::tuple<float, float, float>, bool> seen;
  auto add = [&](const glm::vec3& p) {
    if (seen.try_emplace({p.x, p.y, p.z}, true).second) s->samples.push_back(glm::dvec3(p));
  };
  for (const auto& p : mesh.positions) add(p);
  for (const auto& t : mesh.triangles) {
    const glm::vec3 a = mesh.positions[t.x], b = mesh.positions[t.y], c = mesh.positions[t.z];
    // The same edge from both sides rounds identically only if the endpoints are ordered.
    auto mid = [&](const glm::vec3& p, const glm::vec3& q) {
      const bool less = std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z);
      add(less ? (p + q) * 0.5f : (q + p) * 0.5f);
    };
    mid(a, b);
    mid(b, c);
    mid(c, a);
  }
  s->boundsMin = glm::dvec3(mesh.boundsMin());
  s->boundsMax = glm::dvec3(mesh.boundsMax());
  s->grid = std::make_shared<SdfGrid>(mesh, gridResolution);
  s->polytope = convexPolytope(mesh);
  for (const glm::dvec3& p : s->samples) {
    glm::dvec3 g;
    s->grid->distance(p, &g);
    s->sampleNormals.push_back(g);
  }
  s->localHalfThickness = localHalfThickness(*s->grid, mesh, s->boundsMax - s->boundsMin);
  finishBounds(*s);
  return s;
}

}  // namespace crumple
