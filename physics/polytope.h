// Convex polytopes: boxes and convex meshes as vertices, planar faces and
// edges, and the contact manifold of two of them (separating axes, then the
// incident face clipped against the reference face: Gottschalk's SAT and
// Sutherland-Hodgman clipping, as game engines build box-box manifolds).
//
// Why not the samples: two faces that lie on each other (the joints of an
// arch's voussoirs, a block on a block of the same size) share their corners
// and edges, and a sample on a shared edge sits exactly on the other body's
// surface, neither in nor out; a mesh's distance grid rounds those edges off as
// well. The samples then find one point, the face's centre, and the joint
// turns about it like a pin. Clipping finds the overlap polygon itself: its
// corners are contacts at the depth of the faces' overlap, and the face can
// hold a moment.
#pragma once
#include <glm/glm.hpp>

#include <memory>
#include <vector>

#include <crumple/physics/mesh.h>

namespace crumple {

struct ConvexPolytope {
  struct Face {
    glm::dvec3 normal{0};  // unit, outward
    double offset = 0;     // normal . x = offset on the face
    std::vector<int> loop;  // vertex indices, counter-clockwise seen from outside
  };
  std::vector<glm::dvec3> vertices;
  std::vector<Face> faces;
  std::vector<glm::ivec2> edges;          // each edge once
  std::vector<glm::dvec3> edgeDirections;  // unit, each direction once (up to sign)
  glm::dvec3 centroid{0};                  // of the vertices
  double size = 0;                         // the largest extent

  // Signed distance to the nearest face plane: exact inside, a lower bound of
  // the distance outside. `face` (if given) receives that face's index; where
  // faces tie within `tie`, the one whose normal agrees best with `hint` wins.
  double planeDistance(const glm::dvec3& p, int* face = nullptr, const glm::dvec3* hint = nullptr,
                       double tie = 0) const;
};

// A box of the given half extents about the origin.
std::shared_ptr<const ConvexPolytope> boxPolytope(const glm::dvec3& halfExtents);
// The mesh as a convex polytope (coplanar triangles merged into faces), or
// nullptr when it is not convex (a vertex beyond a face plane by more than
// 1e-5 of its size plus 1e-6 m), or has more than `maxFaces` faces (the
// separating-axis test is quadratic in edges).
std::shared_ptr<const ConvexPolytope> convexPolytope(const TriangleMesh& mesh, int maxFaces = 64);

// A rigid map from B's frame into A's: x_A = rotation x_B + translation.
struct RigidMap {
  glm::dmat3 rotation{1};
  glm::dvec3 translation{0};
  glm::dvec3 operator()(const glm::dvec3& x) const { return rotation * x + translation; }
};

// One contact point of a manifold, in A's frame: on the surface of the body
// that does not own the normal, the normal unit and out of its owner, depth < 0.
struct PolytopeContact {
  bool normalOfA = true;  // the normal belongs to A (else to B)
  glm::dvec3 point{0}, normal{0};
  double depth = 0;
};

// The contact manifold of A and B (B placed in A's frame by `bToA`): empty when
// a separating axis shows them apart; else the penetrating points of the
// incident face clipped against the reference face (the face of least
// penetration, preferring A's), or one point where two edges cross.
void polytopeContacts(const ConvexPolytope& a, const ConvexPolytope& b, const RigidMap& bToA,
                      std::vector<PolytopeContact>& out);

// The same manifold for two boxes (half extents ha, hb, centred on their frames'
// origins): the 15 separating axes from the boxes' extents, and the incident
// face clipped against the reference rectangle, without the polytopes' vertex
// and edge lists (a pile's pairs are nearly all box on box). The same choices
// and tolerances as polytopeContacts; the points may come in another order. `separation`, where given: the gap
// along the separating axis that ended the test (a lower bound on the boxes' distance), -1 where none did.
void boxContacts(const glm::dvec3& ha, const glm::dvec3& hb, const RigidMap& bToA, std::vector<PolytopeContact>& out,
                 double* separation = nullptr);

}  // namespace crumple
