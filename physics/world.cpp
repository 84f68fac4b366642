#include "physics/world.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <stdexcept>

#include "physics/impulse.h"

namespace crumple {

namespace {

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

Aabb worldBounds(const Shape& s, const glm::dvec3& localCom, const Pose& pose) {
  const glm::dvec3 c = (s.boundsMin + s.boundsMax) * 0.5, e = (s.boundsMax - s.boundsMin) * 0.5;
  const glm::dmat3 r = glm::mat3_cast(pose.orientation);
  const glm::dvec3 wc = pose.position + r * (c - localCom);
  glm::dvec3 we(0);
  for (int col = 0; col < 3; ++col) we += glm::abs(r[col]) * e[col];
  return {wc - we, wc + we};
}

Aabb merge(const Aabb& a, const Aabb& b) { return {glm::min(a.lo, b.lo), glm::max(a.hi, b.hi)}; }

glm::dquat integrateOrientation(const glm::dquat& q, const glm::dvec3& w, double h) {
  const glm::dquat spin(0, w.x, w.y, w.z);
  glm::dquat r = q + (0.5 * h) * (spin * q);
  return glm::normalize(r);
}

}  // namespace

World::World(const WorldSettings& settings) : settings_(settings) {}

int World::addBody(const BodyDef& def) {
  if (!def.shape) throw std::invalid_argument("body has no shape");
  if (!finite(def.origin) || !finite(def.linearVelocity) || !finite(def.angularVelocity) ||
      !std::isfinite(def.orientation.w) || !std::isfinite(def.orientation.x) || !std::isfinite(def.orientation.y) ||
      !std::isfinite(def.orientation.z)) {
    throw std::invalid_argument("body state is not finite");
  }
  if (!(def.restitution >= 0 && def.restitution <= 1)) throw std::invalid_argument("restitution outside [0, 1]");
  if (!(def.friction >= 0) || !std::isfinite(def.friction)) throw std::invalid_argument("friction must be >= 0");
  RigidBody b;
  b.shape = def.shape;
  b.restitution = def.restitution;
  b.friction = def.friction;
  b.isStatic = def.isStatic;
  b.q = glm::normalize(def.orientation);
  const MassProperties& mp = def.shape->unitMass;
  b.localCom = mp.centerOfMass;
  b.x = def.origin + glm::mat3_cast(b.q) * b.localCom;
  if (!def.isStatic) {
    if (def.mass > 0) {
      b.mass = def.mass;
    } else {
      if (!(def.density > 0)) throw std::invalid_argument("density must be positive");
      b.mass = def.density * mp.volume;
    }
    if (!(b.mass > 0) || !std::isfinite(b.mass)) throw std::invalid_argument("mass must be positive and finite");
    b.invMass = 1.0 / b.mass;
    b.inertiaBody = mp.inertia * (b.mass / mp.volume);
    b.invInertiaBody = glm::inverse(b.inertiaBody);
    for (int c = 0; c < 3; ++c)
      if (!finite(b.invInertiaBody[c]) || !finite(b.inertiaBody[c]) || !(b.inertiaBody[c][c] > 0))
        throw std::invalid_argument("inertia is degenerate (a body too thin or too light)");
    b.v = def.linearVelocity;
    b.w = def.angularVelocity;
  }
  bodies_.push_back(b);
  force_.emplace_back(0);
  torque_.emplace_back(0);
  minHalfThickness_ = std::min(minHalfThickness_, def.shape->halfThickness());
  return static_cast<int>(bodies_.size() - 1);
}

void World::setReportContacts(int body, bool on) {
  reportContacts_.resize(bodies_.size(), 0);
  reportContacts_.at(static_cast<size_t>(body)) = on;
}

void World::setBumpNormals(int body, bool on) {
  bumpNormals_.resize(bodies_.size(), 0);
  bumpNormals_.at(static_cast<size_t>(body)) = on;
}

void World::wake(int i) {
  RigidBody& b = body(i);
  if (b.isStatic) return;
  b.asleep = false;
  b.stillTime = 0;
}

void World::addForce(int i, const glm::dvec3& f) {
  force_.at(static_cast<size_t>(i)) += f;
  if (glm::dot(f, f) > 0) wake(i);
}
void World::addTorque(int i, const glm::dvec3& t) {
  torque_.at(static_cast<size_t>(i)) += t;
  if (glm::dot(t, t) > 0) wake(i);
}
void World::addForceAtPoint(int i, const glm::dvec3& f, const glm::dvec3& p) {
  addForce(i, f);
  addTorque(i, glm::cross(p - body(i).x, f));
}

uint64_t World::stateHash() const {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](const void* data, size_t n) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ bytes[i]) * 1099511628211ull;
  };
  for (const auto& b : bodies_) {
    mix(&b.x, sizeof b.x);
    mix(&b.q, sizeof b.q);
    mix(&b.v, sizeof b.v);
    mix(&b.w, sizeof b.w);
  }
  return h;
}

glm::dvec3 World::acceleration(int i) const {
  const RigidBody& b = bodies_[static_cast<size_t>(i)];
  return settings_.gravity + force_[static_cast<size_t>(i)] * b.invMass;
}

// Within a substep: the world inverse inertia is invInertia_ (orientations
// stay put until the position update).
glm::dvec3 World::angularAcceleration(int i) const {
  const RigidBody& b = bodies_[static_cast<size_t>(i)];
  const glm::dmat3 r = b.rotation();
  const glm::dvec3 l = r * (b.inertiaBody * (glm::transpose(r) * b.w));  // angular momentum
  return invInertia_[static_cast<size_t>(i)] * (torque_[static_cast<size_t>(i)] - glm::cross(b.w, l));
}

Pose World::predict(const RigidBody& b, double h, bool withForces) const {
  if (!b.movable()) return {b.x, b.q};
  const int i = static_cast<int>(&b - bodies_.data());
  glm::dvec3 v = b.v, w = b.w;
  if (withForces) {
    v += h * acceleration(i);
    w += h * angularAcceleration(i);
  }
  return {b.x + h * v, integrateOrientation(b.q, w, h)};
}

namespace {
// Tests samples of `other` (all, or the listed ones) against the field of `owner`.
void contactsOneWay(int iOwner, const RigidBody& owner, const Pose& po, int iOther, const RigidBody& other,
                    const Pose& pother, const std::vector<uint32_t>* list, std::vector<Contact>& out,
                    const World::NormalModifier* modifier = nullptr) {
    const Shape& so = *owner.shape;
    const Shape& st = *other.shape;
    const double r = st.sampleRadius;
    const glm::dvec3 lo = so.boundsMin - r, hi = so.boundsMax + r;
    const glm::dmat3 ro = glm::mat3_cast(po.orientation);
    const glm::dmat3 rot = glm::transpose(ro);
    const glm::dmat3 rt = glm::mat3_cast(pother.orientation);
    glm::dvec3 hint = rot * (pother.position - po.position);
    const double hintLen = glm::length(hint);
    hint = hintLen > 1e-12 ? hint / hintLen : glm::dvec3(0, 1, 0);
    const size_t n = list ? list->size() : st.samples.size();
    if (n == 0) return;
    const bool normals = !st.sampleNormals.empty();
    // One rigid map from the other's shape frame to the owner's: local = M s + t.
    const glm::dmat3 otherToOwner = rot * rt;
    const glm::dvec3 offset = rot * (pother.position - po.position - rt * other.localCom) + owner.localCom;
    for (size_t k = 0; k < n; ++k) {
      const size_t index = list ? (*list)[k] : k;
      const glm::dvec3& s = st.samples[index];
      const glm::dvec3 local = otherToOwner * s + offset;
      if (local.x < lo.x || local.y < lo.y || local.z < lo.z || local.x > hi.x || local.y > hi.y || local.z > hi.z)
        continue;
      glm::dvec3 g;
      glm::dvec3 sampleHint = hint;
      if (normals && glm::dot(st.sampleNormals[index], st.sampleNormals[index]) > 0.5)
        sampleHint = -(otherToOwner * st.sampleNormals[index]);
      const double phi = so.distance(local, &g, &sampleHint) - r;
      if (phi >= 0) continue;
      if (modifier) g = glm::normalize((*modifier)(iOwner, local - (phi + r) * g, g));
      Contact c;
      c.a = iOwner;
      c.b = iOther;
      c.normal = ro * g;  // unit: every shape's distance gradient is normalised
      c.point = pother.position + rt * (s - other.localCom) - r * c.normal;
      c.phi = phi;
      out.push_back(c);
    }
}
// Deepest first; equal depths keep the order they were found in (a stable
// insertion sort: the lists are short, and it allocates nothing).
void sortContacts(std::vector<Contact>& out) {
  if (out.size() > 64) {
    std::stable_sort(out.begin(), out.end(), [](const Contact& x, const Contact& y) { return x.phi < y.phi; });
    return;
  }
  for (size_t i = 1; i < out.size(); ++i) {
    if (!(out[i].phi < out[i - 1].phi)) continue;
    const Contact c = out[i];
    size_t j = i;
    for (; j > 0 && c.phi < out[j - 1].phi; --j) out[j] = out[j - 1];
    out[j] = c;
  }
}
}  // namespace

void World::pairContacts(const Pair& pair, const Pose& pa, const Pose& pb, std::vector<Contact>& out) const {
  out.clear();
  const RigidBody& A = bodies_[static_cast<size_t>(pair.a)];
  const RigidBody& B = bodies_[static_cast<size_t>(pair.b)];
  const bool bump = normalModifier_ && !bumpNormals_.empty();
  contactsOneWay(pair.a, A, pa, pair.b, B, pb, &pair.bInA, out,
                 bump && bumpNormals_[static_cast<size_t>(pair.a)] ? &normalModifier_ : nullptr);
  contactsOneWay(pair.b, B, pb, pair.a, A, pa, &pair.aInB, out,
                 bump && bumpNormals_[static_cast<size_t>(pair.b)] ? &normalModifier_ : nullptr);
  sortContacts(out);
}

bool World::raycast(const glm::dvec3& origin, const glm::dvec3& dir, double maxDistance, int ignore, RayHit& hit) const {
  bool found = false;
  hit.distance = maxDistance;
  const glm::dvec3 end = origin + dir * maxDistance;
  const glm::dvec3 rlo = glm::min(origin, end), rhi = glm::max(origin, end);
  for (size_t i = 0; i < bodies_.size(); ++i) {
    if (static_cast<int>(i) == ignore) continue;
    const RigidBody& b = bodies_[i];
    const Pose pose{b.x, b.q};
    const Aabb box = worldBounds(*b.shape, b.localCom, pose);
    if (box.lo.x > rhi.x || box.lo.y > rhi.y || box.lo.z > rhi.z || box.hi.x < rlo.x || box.hi.y < rlo.y || box.hi.z < rlo.z)
      continue;
    const glm::dmat3 rt = glm::transpose(b.rotation());
    const glm::dvec3 o = rt * (origin - b.x) + b.localCom, d = rt * dir;
    double t = 0;
    for (int it = 0; it < 128 && t <= hit.distance; ++it) {
      const double phi = b.shape->distance(o + d * t);
      if (phi < 1e-4) {
        if (t < hit.distance || !found) {
          glm::dvec3 g;
          b.shape->distance(o + d * t, &g);
          hit.body = static_cast<int>(i);
          hit.distance = t;
          hit.point = origin + dir * t;
          hit.normal = glm::normalize(b.rotation() * g);
          found = true;
        }
        break;
      }
      t += std::max(phi, 1e-4);
    }
  }
  return found;
}

namespace {
// The angle of the rotation from one orientation to another.
double rotationAngle(const glm::dquat& from, const glm::dquat& to) {
  return 2 * std::acos(std::min(1.0, std::abs(glm::dot(from, to))));
}
// How far B's points near A can have moved in A's frame between two pairs of
// poses: the change of B's offset from A, plus each rotation angle times the
// reach about that body's centre (A's turn moves the points near A by at most
// its angle times ra; B's turn moves its own points by its angle times rb).
double relativeDisplacementBound(const Pose& fromA, const Pose& toA, double ra, const Pose& fromB, const Pose& toB,
                                 double rb) {
  const glm::dvec3 offsetChange = (toB.position - toA.position) - (fromB.position - fromA.position);
  return glm::length(offsetChange) + rotationAngle(fromA.orientation, toA.orientation) * ra +
         rotationAngle(fromB.orientation, toB.orientation) * rb;
}
}  // namespace

void World::findCandidates(double h) {
  const double g = glm::length(settings_.gravity);
  for (Pair& pair : pairs_) {
    const RigidBody& A = bodies_[static_cast<size_t>(pair.a)];
    const RigidBody& B = bodies_[static_cast<size_t>(pair.b)];
    // What matters is B's motion relative to A: two bodies falling side by
    // side do not approach each other however fast they fall.
    auto spin = [&](const RigidBody& b) { return b.movable() ? glm::length(b.w) * b.shape->boundingRadius + 2 * g * h : 0.0; };
    const glm::dvec3 va = A.movable() ? A.v : glm::dvec3(0), vb = B.movable() ? B.v : glm::dvec3(0);
    // Twice the bound on the relative motion this step, plus a little.
    const double margin = 2 * h * (glm::length(vb - va) + spin(A) + spin(B)) + 0.005;
    // The skin: a tenth of the smaller body's thinnest half thickness.
    const double skin = 0.1 * std::min(A.shape->halfThickness(), B.shape->halfThickness());
    if (pair.builtMargin >= 0) {
      const double ra = A.shape->boundingRadius + glm::length(A.localCom) + pair.builtMargin;
      const double rb = B.shape->boundingRadius + glm::length(B.localCom) + pair.builtMargin;
      const double moved = relativeDisplacementBound(pair.builtA, {A.x, A.q}, ra, pair.builtB, {B.x, B.q}, rb);
      if (moved + margin <= pair.builtMargin) continue;  // the lists still hold every sample that can touch
    }
    const double built = margin + skin;
    auto collect = [&](const RigidBody& owner, const RigidBody& other, std::vector<uint32_t>& list) {
      list.clear();
      const Shape& so = *owner.shape;
      const Shape& st = *other.shape;
      const double r = st.sampleRadius;
      const glm::dvec3 lo = so.boundsMin - r - built, hi = so.boundsMax + r + built;
      const glm::dmat3 rot = glm::transpose(owner.rotation());
      const glm::dmat3 rt = other.rotation();
      const glm::dmat3 m = rot * rt;
      const glm::dvec3 offset = rot * (other.x - owner.x - rt * other.localCom) + owner.localCom;
      for (size_t k = 0; k < st.samples.size(); ++k) {
        const glm::dvec3 local = m * st.samples[k] + offset;
        if (local.x < lo.x || local.y < lo.y || local.z < lo.z || local.x > hi.x || local.y > hi.y || local.z > hi.z)
          continue;
        if (so.distance(local) - r > built) continue;
        list.push_back(static_cast<uint32_t>(k));
      }
    };
    collect(A, B, pair.bInA);
    collect(B, A, pair.aInB);
    pair.builtA = {A.x, A.q};
    pair.builtB = {B.x, B.q};
    pair.builtMargin = built;
  }
}

void World::findContacts(int ia, int ib, const Pose& pa, const Pose& pb, std::vector<Contact>& out) const {
  out.clear();
  const RigidBody& A = bodies_[static_cast<size_t>(ia)];
  const RigidBody& B = bodies_[static_cast<size_t>(ib)];
  contactsOneWay(ia, A, pa, ib, B, pb, nullptr, out);
  contactsOneWay(ib, B, pb, ia, A, pa, nullptr, out);
  sortContacts(out);
}


// Resting contact treats a pair's penetrating points in groups: points whose
// normals agree (within about 35 degrees of the group's deepest) make one
// impulse at their centre of pressure (weighted by depth) along their mean
// normal. Processing points one by one (Guendelman's deepest point) makes a box
// resting on a face rock from corner to corner and walk; one averaged contact
// per face is the face's resultant and leaves no spurious torque. Grouping by
// normal keeps the separate touching places of nonconvex bodies apart.
namespace {
// Normals within about 35 degrees of a group's deepest make one group.
constexpr double kSameGroup = 0.82;
// A group's resultant: its members' points and normals (oriented as the
// seed's, out of the seed's body a) weighted by depth.
struct GroupSum {
  const Contact& seed;
  glm::dvec3 point{0}, normal{0};
  double weight = 0;
  glm::dvec3 oriented(const Contact& c) const { return c.a == seed.a ? c.normal : -c.normal; }
  bool agrees(const Contact& c) const { return glm::dot(oriented(c), seed.normal) >= kSameGroup; }
  void add(const Contact& c) {
    const double w = -c.phi + 1e-6;
    point += w * c.point;
    normal += w * oriented(c);
    weight += w;
  }
  Contact result() const {
    Contact m = seed;
    m.point = point / weight;
    const double len = glm::length(normal);
    m.normal = len > 1e-12 ? normal / len : seed.normal;
    return m;
  }
};
}  // namespace

void World::manifolds(const std::vector<Contact>& contacts, std::vector<Contact>& out, std::vector<PatchExtent>* patches) {
  out.clear();
  if (patches) patches->clear();
  thread_local std::vector<char> used;
  thread_local std::vector<size_t> members;
  used.assign(contacts.size(), 0);
  for (size_t seed = 0; seed < contacts.size(); ++seed) {
    if (used[seed]) continue;
    GroupSum group{contacts[seed]};  // sorted deepest first
    members.clear();
    for (size_t i = seed; i < contacts.size(); ++i) {
      if (used[i] || !group.agrees(contacts[i])) continue;
      used[i] = 1;
      group.add(contacts[i]);
      members.push_back(i);
    }
    out.push_back(group.result());
    if (!patches) continue;
    // The patch: the members' extent about the group's point in its tangent plane.
    const Contact& m = out.back();
    PatchExtent e;
    const glm::dvec3& n = m.normal;
    const glm::dvec3 axis = std::abs(n.x) < 0.57 ? glm::dvec3(1, 0, 0) : (std::abs(n.y) < 0.57 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1));
    e.n = n;
    e.t1 = glm::normalize(glm::cross(n, axis));
    e.t2 = glm::cross(n, e.t1);
    for (size_t i : members) {
      const glm::dvec3 d = contacts[i].point - m.point;
      const double d1 = glm::dot(d, e.t1), d2 = glm::dot(d, e.t2);
      e.lo1 = std::min(e.lo1, d1);
      e.hi1 = std::max(e.hi1, d1);
      e.lo2 = std::min(e.lo2, d2);
      e.hi2 = std::max(e.hi2, d2);
    }
    patches->push_back(e);
  }
}

World::Levers World::levers(const Contact& c, const Pose& poseA, const Pose& poseB) {
  return {c.point - poseA.position, c.point - poseB.position};
}

glm::dvec3 World::relativeVelocity(int a, int b, const Levers& l) const {
  const RigidBody& A = bodies_[static_cast<size_t>(a)];
  const RigidBody& B = bodies_[static_cast<size_t>(b)];
  return (B.v + glm::cross(B.w, l.rb)) - (A.v + glm::cross(A.w, l.ra));
}

void World::applyImpulse(int a, int b, const Levers& l, const glm::dvec3& j) {
  RigidBody& A = bodies_[static_cast<size_t>(a)];
  RigidBody& B = bodies_[static_cast<size_t>(b)];
  if (A.movable() && !frozen_[static_cast<size_t>(a)]) {
    A.v -= j * A.invMass;
    A.w -= invInertia_[static_cast<size_t>(a)] * glm::cross(l.ra, j);
  }
  if (B.movable() && !frozen_[static_cast<size_t>(b)]) {
    B.v += j * B.invMass;
    B.w += invInertia_[static_cast<size_t>(b)] * glm::cross(l.rb, j);
  }
}

glm::dmat3 World::collisionMatrixAt(int a, int b, const Levers& l, bool frozenA, bool frozenB) const {
  ImpulseSide sa, sb;
  sidesAt(a, b, l, frozenA, frozenB, sa, sb);
  return collisionMatrix(sa, sb);
}

void World::sidesAt(int a, int b, const Levers& l, bool frozenA, bool frozenB, ImpulseSide& sa, ImpulseSide& sb) const {
  const RigidBody& A = bodies_[static_cast<size_t>(a)];
  const RigidBody& B = bodies_[static_cast<size_t>(b)];
  sa = {};
  sb = {};
  if (A.movable() && !frozenA) {
    sa.invMass = A.invMass;
    sa.invInertia = invInertia_[static_cast<size_t>(a)];
  }
  if (B.movable() && !frozenB) {
    sb.invMass = B.invMass;
    sb.invInertia = invInertia_[static_cast<size_t>(b)];
  }
  sa.r = l.ra;
  sb.r = l.rb;
}

glm::dvec3 World::relativeSpin(int a, int b) const {
  return bodies_[static_cast<size_t>(b)].w - bodies_[static_cast<size_t>(a)].w;
}

void World::applyTorqueImpulse(int a, int b, const glm::dvec3& t) {
  RigidBody& A = bodies_[static_cast<size_t>(a)];
  RigidBody& B = bodies_[static_cast<size_t>(b)];
  if (A.movable() && !frozen_[static_cast<size_t>(a)]) A.w -= invInertia_[static_cast<size_t>(a)] * t;
  if (B.movable() && !frozen_[static_cast<size_t>(b)]) B.w += invInertia_[static_cast<size_t>(b)] * t;
}

glm::dvec3 World::contactImpulse(int a, int b, const Contact& c, const Levers& l, double eps, bool frozenA, bool frozenB,
                                 double* elastic, bool withFriction) const {
  const RigidBody& A = bodies_[static_cast<size_t>(a)];
  const RigidBody& B = bodies_[static_cast<size_t>(b)];
  const glm::dmat3 K = collisionMatrixAt(a, b, l, frozenA, frozenB);
  const glm::dvec3 u = relativeVelocity(a, b, l);
  if (elastic) *elastic = glm::length(frictionlessImpulse(K, u, c.normal, 1.0));
  const double mu = withFriction ? std::sqrt(A.friction * B.friction) : 0.0;
  return frictionImpulse(K, u, c.normal, eps, mu);
}

void World::findPairs(double h) {
  const size_t n = bodies_.size();
  // Each body's bounds now and at its predicted pose; the prediction is kept
  // for the collision step's first look (predictedVersion_ 0).
  boxes_.resize(n);
  predicted_.resize(n);
  predictedVersion_.assign(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const RigidBody& b = bodies_[i];
    predicted_[i] = predict(b, h, true);
    boxes_[i] = worldBounds(*b.shape, b.localCom, {b.x, b.q});
    if (b.movable()) {
      Aabb& box = boxes_[i];
      box = merge(box, worldBounds(*b.shape, b.localCom, predicted_[i]));
      const double margin = 0.005 + 2 * h * glm::length(b.v);
      box.lo -= margin;
      box.hi += margin;
    }
  }
  // Sweep and prune along x. The order of the last substep is nearly right:
  // insertion sort, unless too much has moved (then a full sort). Ties go by
  // index, so the order is unique whichever sort made it.
  auto before = [&](int x, int y) {
    const double bx = boxes_[static_cast<size_t>(x)].lo.x, by = boxes_[static_cast<size_t>(y)].lo.x;
    return bx != by ? bx < by : x < y;
  };
  if (sweepOrder_.size() != n) {
    sweepOrder_.resize(n);
    std::iota(sweepOrder_.begin(), sweepOrder_.end(), 0);
    std::sort(sweepOrder_.begin(), sweepOrder_.end(), before);
  } else {
    size_t shifts = 0;
    for (size_t i = 1; i < n && shifts <= 8 * n; ++i) {
      const int v = sweepOrder_[i];
      size_t j = i;
      for (; j > 0 && before(v, sweepOrder_[j - 1]); --j) sweepOrder_[j] = sweepOrder_[j - 1];
      sweepOrder_[j] = v;
      shifts += i - j;
    }
    if (shifts > 8 * n) std::sort(sweepOrder_.begin(), sweepOrder_.end(), before);
  }
  pairKeys_.clear();
  std::vector<int> wakeList;
  for (size_t oi = 0; oi < n; ++oi) {
    const int i = sweepOrder_[oi];
    const Aabb& bi = boxes_[static_cast<size_t>(i)];
    const RigidBody& A = bodies_[static_cast<size_t>(i)];
    for (size_t oj = oi + 1; oj < n; ++oj) {
      const int j = sweepOrder_[oj];
      const Aabb& bj = boxes_[static_cast<size_t>(j)];
      if (bj.lo.x > bi.hi.x) break;
      if (bj.lo.y > bi.hi.y || bi.lo.y > bj.hi.y || bj.lo.z > bi.hi.z || bi.lo.z > bj.hi.z) continue;
      const RigidBody& B = bodies_[static_cast<size_t>(j)];
      if (!A.movable() && !B.movable()) continue;
      if (A.asleep) wakeList.push_back(i);
      if (B.asleep) wakeList.push_back(j);
      pairKeys_.push_back(static_cast<uint64_t>(std::min(i, j)) << 32 | static_cast<uint64_t>(std::max(i, j)));
    }
  }
  for (int i : wakeList) wake(i);
  std::sort(pairKeys_.begin(), pairKeys_.end());
  // Pairs that already existed keep their candidate lists (both sorted by a, b).
  std::swap(pairs_, previousPairs_);
  pairs_.resize(pairKeys_.size());
  size_t k = 0;
  for (size_t pi = 0; pi < pairKeys_.size(); ++pi) {
    Pair& p = pairs_[pi];
    p.a = static_cast<int>(pairKeys_[pi] >> 32);
    p.b = static_cast<int>(pairKeys_[pi] & 0xffffffffu);
    while (k < previousPairs_.size() &&
           (previousPairs_[k].a < p.a || (previousPairs_[k].a == p.a && previousPairs_[k].b < p.b)))
      ++k;
    if (k < previousPairs_.size() && previousPairs_[k].a == p.a && previousPairs_[k].b == p.b) {
      std::swap(p.bInA, previousPairs_[k].bInA);
      std::swap(p.aInB, previousPairs_[k].aInB);
      p.builtA = previousPairs_[k].builtA;
      p.builtB = previousPairs_[k].builtB;
      p.builtMargin = previousPairs_[k].builtMargin;
    } else {
      p.bInA.clear();
      p.aInB.clear();
      p.builtMargin = -1;
    }
  }
}

bool World::collide(double h) {
  const double restingSpeed = glm::length(settings_.gravity) * h;
  std::vector<int> eventOfPair(pairs_.size(), -1);
  // A pair whose two bodies kept their velocities since it was last checked
  // would find the same (no) collision again: skip it. Exact, so runs stay
  // bit-identical; it saves the repeated passes most of their work.
  std::vector<uint32_t>& version = version_;
  version.assign(bodies_.size(), 0);
  std::vector<std::pair<uint32_t, uint32_t>>& seen = foundVersion_;
  seen.assign(pairs_.size(), {UINT32_MAX, UINT32_MAX});
  found_.resize(pairs_.size());
  // Each body's predicted pose (findPairs made the first), kept while no
  // impulse has changed its velocity.
  auto predicted = [&](int i) -> const Pose& {
    const size_t k = static_cast<size_t>(i);
    if (predictedVersion_[k] != version[k]) {
      predicted_[k] = predict(bodies_[k], h, true);
      predictedVersion_[k] = version[k];
    }
    return predicted_[k];
  };
  bool any = false;
  for (int pass = 0; pass < settings_.collisionPasses; ++pass) {
    bool passAny = false;
    for (size_t pi = 0; pi < pairs_.size(); ++pi) {
      const int ia = pairs_[pi].a, ib = pairs_[pi].b;
      const std::pair<uint32_t, uint32_t> now{version[static_cast<size_t>(ia)], version[static_cast<size_t>(ib)]};
      if (seen[pi] == now) continue;
      for (int it = 0; it < settings_.collisionIterations; ++it) {
        const RigidBody& A = bodies_[static_cast<size_t>(ia)];
        const RigidBody& B = bodies_[static_cast<size_t>(ib)];
        const Pose pa = predicted(ia), pb = predicted(ib);
        std::vector<Contact>& contacts = found_[pi];
        pairContacts(pairs_[pi], pa, pb, contacts);
        seen[pi] = {version[static_cast<size_t>(ia)], version[static_cast<size_t>(ib)]};
        const Contact* hit = nullptr;
        double approach = 0;
        // Levers from the centres of mass at the poses the contacts were found at.
        auto leversOf = [&](const Contact& c) { return levers(c, c.a == ia ? pa : pb, c.b == ib ? pb : pa); };
        for (const Contact& c : contacts) {
          const glm::dvec3 u = relativeVelocity(c.a, c.b, leversOf(c));
          // Approaches slower than gravity adds in one step are resting contact:
          // the contact step handles them (no restitution, no event).
          if (glm::dot(u, c.normal) < -restingSpeed) {
            hit = &c;
            approach = -glm::dot(u, c.normal);
            break;
          }
        }
        if (!hit) break;
        // The impulse acts at the centre of the hit's group: the approaching
        // points whose normals agree with the hit's, weighted by depth (as the
        // contact step's groups). A box landing flat on another presses with
        // its whole face; an impulse at whichever equally deep corner sorts
        // first would spin it, and a tower of such landings leans and falls.
        Contact at = *hit;
        {
          GroupSum group{*hit};
          for (const Contact& c : contacts)
            if (group.agrees(c) && glm::dot(relativeVelocity(c.a, c.b, leversOf(c)), c.normal) < 0) group.add(c);
          if (group.weight > 0) {
            at = group.result();
            if (glm::dot(relativeVelocity(at.a, at.b, leversOf(at)), at.normal) >= 0) at = *hit;
          }
        }
        const double eps = std::min(A.restitution, B.restitution);
        double elastic = 0;
        const Levers hitLevers = leversOf(at);
        const glm::dvec3 j = contactImpulse(at.a, at.b, at, hitLevers, eps, false, false, &elastic);
        if (glm::dot(j, j) == 0) break;
        applyImpulse(at.a, at.b, hitLevers, j);
        ++version[static_cast<size_t>(ia)];
        ++version[static_cast<size_t>(ib)];
        passAny = true;
        int& ev = eventOfPair[pi];
        if (ev < 0 && approach >= settings_.eventMinApproachSpeed) {
          CollisionEvent e;
          e.time = time_;
          e.a = hit->a;
          e.b = hit->b;
          e.point = hit->point;
          e.normal = hit->normal;
          e.penetration = -hit->phi;
          e.elasticImpulse = elastic;
          e.poseA = hit->a == ia ? pa : pb;
          e.poseB = hit->a == ia ? pb : pa;
          ev = static_cast<int>(events_.size());
          events_.push_back(e);
        }
        if (ev < 0) continue;
        CollisionEvent& e = events_[static_cast<size_t>(ev)];
        e.impulseVector += hit->a == e.a ? j : -j;
        e.impulse = glm::length(e.impulseVector);
      }
    }
    any = any || passAny;
    if (!passAny) break;
  }
  for (int ev : eventOfPair) stats_.collisions += ev >= 0;
  return any;
}

void World::contact(double h) {
  std::vector<Contact> fresh;
  // Contact geometry on the positions predicted with the current velocities.
  // Re-finding it costs most of the step; it changes little from one pass to
  // the next, so it is refreshed every `contactRefresh` passes, and then only
  // for pairs whose predicted poses moved (impulses always use the current
  // velocities).
  // The groups and levers of each pair's last look stay for shock propagation.
  std::vector<std::vector<Contact>>& grouped = groups_;
  // Per pair, per group: K (and its inverse) and the patch matrix (the points
  // and inertias stay put until the geometry is found again, so only the
  // relative velocity changes between passes), the impulses each group has had
  // in this step (Coulomb's cone bounds their totals; a group found again
  // inherits the totals of the group it replaces).
  std::vector<std::vector<ImpulseMatrix>>& matrices = groupMatrices_;
  std::vector<std::vector<Levers>>& leverArms = groupLevers_;
  std::vector<std::vector<FrictionTotals>>& totals = groupTotals_;
  std::vector<std::vector<PatchMatrix>>& patchMatrices = groupPatchMatrices_;
  auto reset = [count = pairs_.size()](auto& perPair) {
    perPair.resize(count);
    for (auto& v : perPair) v.clear();
  };
  reset(grouped);
  reset(matrices);
  reset(leverArms);
  reset(groupSpeed_);
  reset(totals);
  reset(groupPatches_);
  reset(patchMatrices);
  lookPoses_.resize(pairs_.size());
  lookCount_.assign(pairs_.size(), 0);
  std::vector<Contact> oldGroups;
  std::vector<FrictionTotals> oldTotals;
  std::vector<char> inherited;
  std::vector<double> pushed(reportContacts_.empty() ? 0 : pairs_.size(), 0.0);
  const int n = std::max(1, settings_.contactPasses);
  const int refresh = std::max(1, settings_.contactRefresh);
  for (int pass = 1; pass <= n; ++pass) {
    const double eps = -1.0 + static_cast<double>(pass) / n;
    const bool find = (pass - 1) % refresh == 0;
    // Alternate sweeps (forward, then backward): a one-way order pushes every
    // stack the same way, a little each pass.
    for (size_t k = 0; k < pairs_.size(); ++k) {
      const size_t pi = pass % 2 ? k : pairs_.size() - 1 - k;
      const Pair& pair = pairs_[pi];
      bool look = find;
      bool reuse = false;
      Pose pa, pb;
      if (look) {
        // The collision step's last look at this pair was at the poses the
        // first pass predicts now (x + h (v + h a) either way) if no impulse
        // has touched either body since: its contacts are reused, with the
        // poses they were found at (levers must match the geometry). Fresh
        // contacts are found at the poses the current velocities predict.
        const std::pair<uint32_t, uint32_t> now{version_[static_cast<size_t>(pair.a)], version_[static_cast<size_t>(pair.b)]};
        reuse = pass == 1 && pi < foundVersion_.size() && foundVersion_[pi] == now;
        pa = reuse ? predicted_[static_cast<size_t>(pair.a)] : predict(bodies_[static_cast<size_t>(pair.a)], h, false);
        pb = reuse ? predicted_[static_cast<size_t>(pair.b)] : predict(bodies_[static_cast<size_t>(pair.b)], h, false);
        if (pass > 1) {
          // A refresh re-finds the geometry only where the predicted poses have
          // moved since the last look; resting contact keeps its groups (their
          // depths follow to first order, endOfStepDepths).
          const RigidBody& A = bodies_[static_cast<size_t>(pair.a)];
          const RigidBody& B = bodies_[static_cast<size_t>(pair.b)];
          const double ra = A.shape->boundingRadius + glm::length(A.localCom);
          const double rb = B.shape->boundingRadius + glm::length(B.localCom);
          look = relativeDisplacementBound(lookPoses_[pi].first, pa, ra, lookPoses_[pi].second, pb, rb) >
                 settings_.contactRefreshTolerance;
        }
      }
      if (look) {
        const std::vector<Contact>* contacts = &fresh;
        lookPoses_[pi] = {pa, pb};
        lookCount_[pi] = static_cast<int>((reuse ? found_[pi] : fresh).size());
        if (reuse) {
          contacts = &found_[pi];
        } else {
          pairContacts(pair, pa, pb, fresh);
        }
        oldGroups.swap(grouped[pi]);
        oldTotals.swap(totals[pi]);
        manifolds(*contacts, grouped[pi], &groupPatches_[pi]);
        totals[pi].assign(grouped[pi].size(), FrictionTotals{});
        inherited.assign(oldGroups.size(), 0);
        for (size_t gi = 0; gi < grouped[pi].size(); ++gi) {
          const Contact& g = grouped[pi][gi];
          size_t best = oldGroups.size();
          double bestDot = kSameGroup;
          for (size_t k = 0; k < oldGroups.size(); ++k) {
            const double d = glm::dot(g.normal, oldGroups[k].a == g.a ? oldGroups[k].normal : -oldGroups[k].normal);
            if (!inherited[k] && d >= bestDot) {
              best = k;
              bestDot = d;
            }
          }
          if (best == oldGroups.size()) continue;
          inherited[best] = 1;
          FrictionTotals t = oldTotals[best];
          if (oldGroups[best].a != g.a) t.tangential = -t.tangential;  // impulses are on b
          totals[pi][gi] = t;
        }
        matrices[pi].clear();
        leverArms[pi].clear();
        groupSpeed_[pi].clear();
        patchMatrices[pi].clear();
        for (size_t gi = 0; gi < grouped[pi].size(); ++gi) {
          const Contact& c = grouped[pi][gi];
          // The levers at the poses the geometry was found at: measured from the
          // current centres, a point found ahead by h v would turn sliding into
          // a spurious normal velocity (a rolling ball would brake).
          leverArms[pi].push_back(levers(c, c.a == pair.a ? pa : pb, c.b == pair.b ? pb : pa));
          ImpulseSide sa, sb;
          sidesAt(c.a, c.b, leverArms[pi].back(), false, false, sa, sb);
          matrices[pi].push_back(ImpulseMatrix(collisionMatrix(sa, sb)));
          patchMatrices[pi].push_back(patchMatrix(sa, sb, matrices[pi].back(), groupPatches_[pi][gi]));
          groupSpeed_[pi].push_back(glm::dot(relativeVelocity(c.a, c.b, leverArms[pi].back()), c.normal));
        }
      }
      const bool report = !reportContacts_.empty() &&
                          (reportContacts_[static_cast<size_t>(pair.a)] || reportContacts_[static_cast<size_t>(pair.b)]);
      const RigidBody& A = bodies_[static_cast<size_t>(pair.a)];
      const RigidBody& B = bodies_[static_cast<size_t>(pair.b)];
      const double mu = std::sqrt(A.friction * B.friction);
      for (size_t gi = 0; gi < grouped[pi].size(); ++gi) {
        const Contact& c = grouped[pi][gi];
        const Levers& l = leverArms[pi][gi];
        const glm::dvec3 u = relativeVelocity(c.a, c.b, l);
        glm::dvec3 j, torque;
        if (patchImpulse(patchMatrices[pi][gi], matrices[pi][gi], u, relativeSpin(c.a, c.b), c.normal, eps, mu, &totals[pi][gi], j,
                         torque)) {
          applyImpulse(c.a, c.b, l, j);
          applyTorqueImpulse(c.a, c.b, torque);
        } else {
          j = frictionImpulse(matrices[pi][gi], u, c.normal, eps, mu, &totals[pi][gi]);
          if (glm::dot(j, j) > 0) applyImpulse(c.a, c.b, l, j);
        }
        if (report && &c == &grouped[pi].front()) pushed[pi] += glm::dot(j, c.normal);
      }
    }
  }
  for (int c : lookCount_) stats_.contacts += c;  // each pair's last look
  if (reportContacts_.empty()) return;
  for (size_t pi = 0; pi < pairs_.size(); ++pi) {
    if (grouped[pi].empty() || !(pushed[pi] > 0)) continue;
    const Contact& c = grouped[pi].front();
    CollisionEvent e;
    e.time = time_;
    e.a = c.a;
    e.b = c.b;
    e.point = c.point;
    e.normal = c.normal;
    e.penetration = -c.phi;
    e.impulse = pushed[pi];
    e.impulseVector = c.normal * pushed[pi];
    e.elasticImpulse = 2 * pushed[pi];
    const RigidBody& A = bodies_[static_cast<size_t>(c.a)];
    const RigidBody& B = bodies_[static_cast<size_t>(c.b)];
    e.poseA = {A.x, A.q};
    e.poseB = {B.x, B.q};
    contactReports_.push_back(e);
  }
}

void World::shockPropagation() {
  if (settings_.shockPasses <= 0) return;
  const size_t n = bodies_.size();
  // The contact graph of the contact step's last look (positions moved with the
  // velocities of then); levels from the static (and sleeping) bodies up by
  // breadth-first search, which collapses cycles into one level and never loops.
  std::vector<std::vector<int>> adjacency(n);
  std::vector<size_t> touching;
  for (size_t pi = 0; pi < pairs_.size() && pi < groups_.size(); ++pi) {
    if (groups_[pi].empty()) continue;
    const Pair& pair = pairs_[pi];
    adjacency[static_cast<size_t>(pair.a)].push_back(pair.b);
    adjacency[static_cast<size_t>(pair.b)].push_back(pair.a);
    touching.push_back(pi);
  }
  level_.assign(n, -1);
  std::vector<int> queue;
  for (size_t i = 0; i < n; ++i) {
    if (!bodies_[i].movable()) {
      level_[i] = 0;
      queue.push_back(static_cast<int>(i));
    }
  }
  int maxLevel = 0;
  for (size_t head = 0; head < queue.size(); ++head) {
    const int i = queue[head];
    for (int j : adjacency[static_cast<size_t>(i)]) {
      if (level_[static_cast<size_t>(j)] < 0) {
        level_[static_cast<size_t>(j)] = level_[static_cast<size_t>(i)] + 1;
        maxLevel = std::max(maxLevel, level_[static_cast<size_t>(j)]);
        queue.push_back(j);
      }
    }
  }
  for (int level = 1; level <= maxLevel; ++level) {
    for (size_t i = 0; i < n; ++i) frozen_[i] = level_[i] >= 0 && level_[i] < level;
    // This level's contact groups (a pair whose upper body is on this level).
    struct LevelContact {
      Contact c;
      Levers l;
      ImpulseMatrix m;  // K with this level's frozen bodies
      double mu;
      ImpulseSide sa, sb;
      const PatchExtent* extent;
      PatchMatrix patch;  // valid only for a body's one support patch
    };
    std::vector<LevelContact> lc;
    std::vector<int> share(n, 0);
    for (size_t pi : touching) {
      const Pair& pair = pairs_[pi];
      const int la = level_[static_cast<size_t>(pair.a)], lb = level_[static_cast<size_t>(pair.b)];
      if (std::max(la, lb) != level || std::min(la, lb) < 0) continue;
      const double mu = std::sqrt(bodies_[static_cast<size_t>(pair.a)].friction * bodies_[static_cast<size_t>(pair.b)].friction);
      for (size_t gi = 0; gi < groups_[pi].size(); ++gi) {
        const Contact& c = groups_[pi][gi];
        const Levers& l = groupLevers_[pi][gi];
        const bool fa = frozen_[static_cast<size_t>(c.a)] != 0, fb = frozen_[static_cast<size_t>(c.b)] != 0;
        LevelContact x{c, l, {}, mu, {}, {}, &groupPatches_[pi][gi], {}};
        sidesAt(c.a, c.b, l, fa, fb, x.sa, x.sb);
        x.m = ImpulseMatrix(collisionMatrix(x.sa, x.sb));
        lc.push_back(x);
        if (!fa) ++share[static_cast<size_t>(c.a)];  // frozen bodies do not move
        if (!fb) ++share[static_cast<size_t>(c.b)];
      }
    }
    // Jacobi passes: every group's impulse from the same velocities, each
    // body taking the mean of its groups' (a body on two supports follows
    // neither alone: in order, the last one processed would win).
    // A body resting on one patch of the level below is held against tilting
    // by that patch (its torque). On two supports, the couple of their point
    // impulses holds the tilt across the line through them and each support's
    // patch keeps only the torque about that line (lineMatrix): full patch
    // torques would each ask for their own support's tilt, and the body would
    // jitter between them. On more, the couples hold every tilt.
    // (body, level contact) for each support from the frozen level below, by body.
    std::vector<std::pair<int, size_t>> supports;
    for (size_t k = 0; k < lc.size(); ++k) {
      const bool fa = frozen_[static_cast<size_t>(lc[k].c.a)] != 0, fb = frozen_[static_cast<size_t>(lc[k].c.b)] != 0;
      if (fa != fb) supports.push_back({fa ? lc[k].c.b : lc[k].c.a, k});
    }
    std::sort(supports.begin(), supports.end());
    for (size_t first = 0, last; first < supports.size(); first = last) {
      const int body = supports[first].first;
      for (last = first; last < supports.size() && supports[last].first == body; ++last) {}
      const size_t count = last - first;
      if (static_cast<size_t>(share[static_cast<size_t>(body)]) != count) continue;  // touches its own level too
      if (count == 1) {
        LevelContact& x = lc[supports[first].second];
        x.patch = patchMatrix(x.sa, x.sb, x.m, *x.extent);
      } else if (count == 2) {
        const size_t k0 = supports[first].second, k1 = supports[first + 1].second;
        const glm::dvec3 line = lc[k1].c.point - lc[k0].c.point;
        for (size_t k : {k0, k1}) lc[k].patch = lineMatrix(lc[k].sa, lc[k].sb, lc[k].m, *lc[k].extent, line);
      }
    }
    std::vector<glm::dvec3> dj(lc.size()), dt(lc.size());
    for (int pass = 0; pass < settings_.shockPasses; ++pass) {
      for (size_t k = 0; k < lc.size(); ++k) {
        const Contact& c = lc[k].c;
        const glm::dvec3 u = relativeVelocity(c.a, c.b, lc[k].l);
        if (!patchImpulse(lc[k].patch, lc[k].m, u, relativeSpin(c.a, c.b), c.normal, 0.0, lc[k].mu, nullptr, dj[k], dt[k])) {
          dj[k] = frictionImpulse(lc[k].m, u, c.normal, 0.0, lc[k].mu);
          dt[k] = glm::dvec3(0);
        }
      }
      for (size_t k = 0; k < lc.size(); ++k) {
        const Contact& c = lc[k].c;
        const int m = std::max({1, share[static_cast<size_t>(c.a)], share[static_cast<size_t>(c.b)]});
        if (glm::dot(dj[k], dj[k]) > 0) applyImpulse(c.a, c.b, lc[k].l, dj[k] / double(m));
        if (glm::dot(dt[k], dt[k]) > 0) applyTorqueImpulse(c.a, c.b, dt[k] / double(m));
      }
    }
  }
  std::fill(frozen_.begin(), frozen_.end(), 0);
}

void World::integratePositions(double h) {
  for (RigidBody& b : bodies_) {
    if (!b.movable()) continue;
    b.x += h * b.v;
    b.q = integrateOrientation(b.q, b.w, h);
  }
}

// The contact step's last look saw the positions predicted with the
// velocities of that moment; the step ends with others. Each group's depth at
// the new positions is its depth then plus h times the change of its normal
// relative speed since (first order in h; exact for translations). Called
// between the contact step and the position update, it spares the projection
// a look of its own.
void World::endOfStepDepths(double h) {
  for (size_t pi = 0; pi < groups_.size() && pi < pairs_.size(); ++pi)
    for (size_t gi = 0; gi < groups_[pi].size(); ++gi) {
      Contact& c = groups_[pi][gi];
      c.phi += h * (glm::dot(relativeVelocity(c.a, c.b, groupLevers_[pi][gi]), c.normal) - groupSpeed_[pi][gi]);
    }
}

// Positional projection on the contact step's groups (depths at the new
// positions from endOfStepDepths). The projection only translates bodies, so
// from one iteration to the next each group's depth moves by the two bodies'
// translations along its normal (exact for flat contact).
void World::projectPositions() {
  if (settings_.projectionIterations <= 0) return;
  std::vector<glm::dvec3> moved(bodies_.size(), glm::dvec3(0));
  for (int it = 0; it < settings_.projectionIterations; ++it) {
    for (size_t pi = 0; pi < groups_.size() && pi < pairs_.size(); ++pi) {
      for (size_t gi = 0; gi < groups_[pi].size(); ++gi) {
        const Contact& c = groups_[pi][gi];
        const size_t ia = static_cast<size_t>(c.a), ib = static_cast<size_t>(c.b);
        const double depth = -(c.phi + glm::dot(moved[ib] - moved[ia], c.normal)) - settings_.penetrationSlop;
        if (depth <= 0) continue;
        RigidBody& ca = bodies_[ia];
        RigidBody& cb = bodies_[ib];
        const double wa = ca.movable() ? ca.invMass : 0, wb = cb.movable() ? cb.invMass : 0;
        if (wa + wb <= 0) continue;
        if (it == 0) {
          // A contact still sinking after the contact step would sink again
          // next step and be pushed out again: the approach goes too
          // (inelastic, normal only: it never adds energy).
          const Levers& l = groupLevers_[pi][gi];
          const glm::dvec3 j = frictionlessImpulse(groupMatrices_[pi][gi].K, relativeVelocity(c.a, c.b, l), c.normal, 0.0);
          if (glm::dot(j, j) > 0) applyImpulse(c.a, c.b, l, j);
        }
        const double corr = settings_.penetrationCorrection * depth / (wa + wb);
        ca.x -= c.normal * corr * wa;
        cb.x += c.normal * corr * wb;
        moved[ia] -= c.normal * corr * wa;
        moved[ib] += c.normal * corr * wb;
      }
    }
  }
}

void World::updateSleep(double h) {
  const size_t n = bodies_.size();
  // Still: the body hardly moved over the step. Its velocity would not do: a
  // body resting on another ends each step still approaching it by about g h
  // (the contact step stops penetration at the predicted positions, the
  // projection the rest), which at 60 Hz is more than any sleep threshold.
  for (size_t i = 0; i < n; ++i) {
    RigidBody& b = bodies_[i];
    if (!b.movable() || i >= stepStart_.size()) continue;
    const Pose& start = stepStart_[i];
    const double speed = glm::length(b.x - start.position) / h, spin = rotationAngle(start.orientation, b.q) / h;
    const bool still = speed < settings_.sleepLinear && spin < settings_.sleepAngular;
    b.stillTime = still ? b.stillTime + h : 0;
  }
  if (!settings_.sleeping) return;
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[static_cast<size_t>(x)] != x) x = parent[static_cast<size_t>(x)] = parent[static_cast<size_t>(parent[static_cast<size_t>(x)])];
    return x;
  };
  for (const Pair& p : pairs_) {
    if (bodies_[static_cast<size_t>(p.a)].isStatic || bodies_[static_cast<size_t>(p.b)].isStatic) continue;
    const int ra = find(p.a), rb = find(p.b);
    if (ra != rb) parent[static_cast<size_t>(std::max(ra, rb))] = std::min(ra, rb);
  }
  std::vector<char> islandStill(n, 1), supported(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const RigidBody& b = bodies_[i];
    if (b.isStatic) continue;
    if (b.movable() && b.stillTime < settings_.sleepTime) islandStill[static_cast<size_t>(find(static_cast<int>(i)))] = 0;
  }
  // Only an island that rests on something (a static or sleeping body near
  // one of its bodies) sleeps: a slow body in free flight (zero gravity, say)
  // keeps its momentum.
  for (const Pair& p : pairs_) {
    const RigidBody& A = bodies_[static_cast<size_t>(p.a)];
    const RigidBody& B = bodies_[static_cast<size_t>(p.b)];
    if (!A.movable()) supported[static_cast<size_t>(find(p.b))] = 1;
    if (!B.movable()) supported[static_cast<size_t>(find(p.a))] = 1;
  }
  for (size_t i = 0; i < n; ++i) {
    RigidBody& b = bodies_[i];
    const size_t root = static_cast<size_t>(find(static_cast<int>(i)));
    if (!b.movable() || !islandStill[root] || !supported[root]) continue;
    b.asleep = true;
    b.v = glm::dvec3(0);
    b.w = glm::dvec3(0);
  }
}

void World::substep(double h) {
  // World inverse inertias: orientations stay fixed until the position update.
  invInertia_.resize(bodies_.size());
  for (size_t i = 0; i < bodies_.size(); ++i) invInertia_[i] = bodies_[i].invInertiaWorld();
  findPairs(h);
  findCandidates(h);
  stats_.pairs += static_cast<int>(pairs_.size());
  // 1. collision with restitution on predicted positions (emits events)
  collide(h);
  // 2. velocities
  for (size_t i = 0; i < bodies_.size(); ++i) {
    RigidBody& b = bodies_[i];
    if (!b.movable()) continue;
    const glm::dvec3 a = acceleration(static_cast<int>(i));
    const glm::dvec3 alpha = angularAcceleration(static_cast<int>(i));
    b.v += h * a;
    b.w += h * alpha;
  }
  // 3. contact with the restitution ramp, 4. shock propagation
  contact(h);
  shockPropagation();
  // 5. positions, then the positional projection
  stepStart_.resize(bodies_.size());
  for (size_t i = 0; i < bodies_.size(); ++i) stepStart_[i] = {bodies_[i].x, bodies_[i].q};
  endOfStepDepths(h);
  integratePositions(h);
  projectPositions();
  // 6. sleeping
  updateSleep(h);
  time_ += h;
}

void World::step(double h) {
  if (!(h > 0) || !std::isfinite(h)) throw std::invalid_argument("time step must be positive and finite");
  events_.clear();
  contactReports_.clear();
  reportContacts_.resize(bodies_.size(), 0);
  if (!bumpNormals_.empty()) bumpNormals_.resize(bodies_.size(), 0);
  stats_ = {};
  frozen_.assign(bodies_.size(), 0);
  // Substeps: no body may move more than a fraction of the thinnest half thickness.
  double maxTravel = 0;
  for (const RigidBody& b : bodies_) {
    if (!b.movable()) continue;
    const double speed = glm::length(b.v) + glm::length(settings_.gravity) * h + glm::length(b.w) * b.shape->boundingRadius;
    maxTravel = std::max(maxTravel, speed * h);
  }
  const double allowed = settings_.substepFraction * std::max(minHalfThickness_, 1e-4);
  const int n = std::clamp(static_cast<int>(std::ceil(maxTravel / allowed)), 1, std::max(1, settings_.maxSubsteps));
  for (int s = 0; s < n; ++s) substep(h / n);
  stats_.substeps = n;
  for (size_t i = 0; i < bodies_.size(); ++i) {
    force_[i] = glm::dvec3(0);
    torque_[i] = glm::dvec3(0);
    stats_.awake += bodies_[i].movable();
  }
}

}  // namespace crumple
