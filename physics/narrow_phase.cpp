// Narrow phase: contact points between two bodies at given poses, and rays.
//
// Guarantees:
// - pairContacts / World::findContacts return every sample of either body that
//   penetrates the other's distance field (phi < 0, the sample radius
//   subtracted): point on the sampled body's surface, unit normal out of the
//   field's owner (a), depth phi. A sphere against a convex shape: only its
//   centre in the other's field (sampleSides), the one deepest point exactly;
//   a capsule: its core samples and its segment's deepest point there.
//   pairContacts tests only the pair's candidate samples (broad_phase.cpp
//   guarantees they hold every sample that can touch), and of a long list
//   only its near samples while the bodies stay close to the poses of the
//   look that made them (Pair::NearSamples): the same contacts either way.
//   Two convex polytopes (boxes, convex meshes) that neither sweep nor bend
//   their normals give instead the penetrating corners of their contact
//   manifold (polytope.h), on the incident body's surface, normal out of the
//   reference face's body.
// - Where one body moves, relative to the other, by more than the other's half
//   thickness within the substep (a plate thinner than the substeps can
//   cover), each of its samples not penetrating at the end, or penetrating
//   past the other's middle (its gradient there pointing out of the far side),
//   is also marched along its path from the substep's start (conservative
//   advancement through the other's field): one that crosses the surface is a
//   contact on the side it came from, as deep as its path went past the
//   surface (continuous collision against thin bodies, no tunnelling).
// - The list is sorted deepest first; equal depths keep the order found
//   (samples of b in a first, then of a in b, each in sample order).
// - On a body flagged with setBumpNormals (and with a normal modifier set), the
//   normal is the modifier's, normalised.
// - World::raycast returns the nearest surface along the ray within the
//   distance, to the sphere tracer's tolerance (1e-4 m); on a dented body
//   (World::setDented), the dented surface and its normal.
#include <algorithm>
#include <cmath>
#include <limits>

#include <crumple/physics/step_context.h>
#include <crumple/physics/world.h>

namespace crumple {

namespace {
using detail::PoseFrame;
// Tests samples of `other` (all, or the listed ones) against the field of `owner`.
// With `segment` (other is a capsule, owner convex: detail::sampleSides), also the point of the capsule's core
// segment deepest in the owner's field, where it is deeper than every sample: the samples stand a radius apart,
// and a capsule across a box's edge sank between two of them.
// Dents: `depth` (World::setSurfaceDepth) where the owner (`dentOwner`) or the other (`dentOther`) is dented, the
// surfaces rising at most `rise` in all: a sample within that of the undented owner is measured against the
// dented surfaces, the owner's at the surface point nearest to it, the other's at the sample's own surface point.
// `otherSamples`: the other's answers at its surface samples, where made (StepContext::sampleDents).
struct Dents {
  const SurfaceDepth* depth = nullptr;
  bool owner = false, other = false;
  double rise = 0;
  const detail::StepContext::SampleDents* otherSamples = nullptr;
};

// A look that makes a side's near samples (Pair::NearSamples): every sample within `box2` (squared) of the owner's
// bounds box, and of those inside it every one whose distance less the sample radius is below `phi`.
struct NearBuild {
  std::vector<uint32_t>* samples = nullptr;
  double phi = 0, box2 = 0;
};

// Where one side's look may test its near samples (Pair::NearSamples) instead of its whole list: `list` is set to
// them and false returned; true where this look makes them (`make` says how). A sample not near when they were made
// lay at least `phi` = slope * within from the owner's surface (or `within` outside its bounds box): at poses that
// have moved its points by at most `within` since, it cannot touch (a distance changes by at most slope times the
// distance moved), so the look finds the same contacts in the same order (the near samples are the list's, in its
// order). Where the look sweeps or dents are near, a sample's depth is not its distance: no near samples. The bound
// on the points' travel counts the owner's turn at the farthest corner of its bounds box (sample radius added)
// from its centre of mass, where a touching sample lies, and the other's turn at its reach.
constexpr size_t kNearMinSamples = 8;  // (shorter lists are tested whole)
constexpr double kNearWithin = 0.025;  // of the thinner body's half thickness
// Whether a side's near samples still hold at poses po (owner) and pother: made from these lists, the bodies
// within `within` of where they were made. (The reaches, like the lists' generation, stay what they were then.)
bool nearHolds(const detail::Pair::NearSamples& near, const detail::Pair& pair, const Pose& po, const Pose& pother) {
  return near.within > 0 && near.lists == pair.listGeneration &&
         !detail::displacementExceeds(near.owner, po, near.reachOwner, near.other, pother, near.reachOther,
                                      [&](double moved) { return moved > near.within; });
}

bool nearSamples(const RigidBody& owner, const Pose& po, const RigidBody& other, const Pose& pother,
                 const detail::Pair& pair, detail::Pair::NearSamples& near, bool usable,
                 const std::vector<uint32_t>*& list, NearBuild& make) {
  if (usable && nearHolds(near, pair, po, pother)) {
    list = &near.samples;
    return false;
  }
  const Shape& so = *owner.shape;
  const double slope = so.distanceSlope();
  if (!usable || !(slope > 0) || !std::isfinite(slope)) {
    near.within = -1;
    return false;
  }
  const double r = other.shape->sampleRadius;
  const glm::dvec3 corner =
      glm::max(glm::abs(so.boundsMin - r - owner.localCom), glm::abs(so.boundsMax + r - owner.localCom));
  near.reachOwner = glm::length(corner);
  near.reachOther = detail::reachAboutCom(other);
  const double within = kNearWithin * std::min(so.halfThickness(), other.shape->halfThickness());
  near.samples.clear();
  near.owner = po;
  near.other = pother;
  near.within = within;
  near.lists = pair.listGeneration;
  // (A hair wider than the bound: the distances' and the travel's rounding.)
  const double wide = within * (1 + 1e-9) + 1e-12;
  make = {&near.samples, slope * wide, wide * wide};
  return true;
}

// Whether sample k of s is a point of its surface with its outward normal (not a core sample a radius inside).
bool surfaceSample(const Shape& s, size_t k) {
  return s.sampleRadius == 0 && k < s.sampleNormals.size() && glm::dot(s.sampleNormals[k], s.sampleNormals[k]) > 0.5;
}

// A body's kept answers at its surface samples, where it keeps them (else each contact asks).
const detail::StepContext::SampleDents* keptAnswers(const detail::StepContext& ctx, int body, bool dented) {
  if (!dented || static_cast<size_t>(body) >= ctx.sampleDents.size()) return nullptr;
  const detail::StepContext::SampleDents& kept = ctx.sampleDents[static_cast<size_t>(body)];
  return kept.stale || kept.depth.empty() ? nullptr : &kept;
}

// The depth of body `body`'s dented surface below its surface sample k (`bent`: its normal there): the kept
// answer, else asked and kept (by the first thread to ask; any other asking meanwhile gets the same answer).
double sampleDepth(const detail::StepContext::SampleDents& kept, const SurfaceDepth& depth, int body,
                   const Shape& shape, size_t k, glm::dvec3& bent) {
  std::atomic<uint8_t>& state = kept.state[k];
  if (state.load(std::memory_order_acquire) == 2) {
    bent = kept.bent[k];
    return kept.depth[k];
  }
  const glm::dvec3& n = shape.sampleNormals[k];
  bent = n;
  const double d = depth(body, shape.samples[k] + shape.sampleRadius * n, n, bent);
  uint8_t expected = 0;
  if (state.compare_exchange_strong(expected, 1, std::memory_order_acq_rel)) {
    kept.depth[k] = d;
    kept.bent[k] = bent;
    state.store(2, std::memory_order_release);
  }
  return d;
}

void contactsOneWay(int iOwner, const RigidBody& owner, const PoseFrame& frameOwner, int iOther, const RigidBody& other,
                    const PoseFrame& frameOther, const std::vector<uint32_t>* list, std::vector<Contact>& out,
                    const NormalModifier* modifier = nullptr, const Pose* startOwner = nullptr,
                    const Pose* startOther = nullptr, bool segment = false, const Dents& dents = {},
                    const NearBuild* near = nullptr, double* clear = nullptr) {
  const Shape& so = *owner.shape;
  const Shape& st = *other.shape;
  const size_t n = list ? list->size() : st.samples.size();
  // `clear` (asked where nothing sweeps, bends normals or feels dents): how far, in the owner's frame, each tested
  // point may move before it can make a contact: a sample outside the owner's box by its distance to the box, one
  // inside by its phi over the field's slope, the segment by its least bound less half the samples' spacing (< 0:
  // no such bound).
  if (clear) *clear = std::numeric_limits<double>::infinity();
  if (n == 0 && !segment) return;  // (before any turning: most looks at a pair have one side with nothing listed)
  const double fieldSlope = clear ? so.distanceSlope() : 0.0;
  if (clear && !(fieldSlope > 0 && std::isfinite(fieldSlope))) {
    *clear = -1;
    clear = nullptr;
  }
  double leastPhi = std::numeric_limits<double>::infinity();  // the tested samples' least phi
  double outside2 = std::numeric_limits<double>::infinity();  // the least squared distance to the box, outside it
  const double r = st.sampleRadius;
  const glm::dvec3 lo = so.boundsMin - r - dents.rise, hi = so.boundsMax + r + dents.rise;
  const Pose& po = frameOwner.pose;
  const Pose& pother = frameOther.pose;
  const glm::dmat3& ro = frameOwner.rotation;
  const glm::dmat3 rot = glm::transpose(ro);
  const glm::dmat3& rt = frameOther.rotation;
  // (Only a box and a convex mesh read the hint; the other shapes' gradients are unique where they are asked.)
  const bool hinted = so.type == ShapeType::Box || so.polytope;
  glm::dvec3 hint(0, 1, 0);
  if (hinted) {
    hint = rot * (pother.position - po.position);
    const double hintLen = glm::length(hint);
    hint = hintLen > 1e-12 ? hint / hintLen : glm::dvec3(0, 1, 0);
  }
  const bool normals = !st.sampleNormals.empty() && hinted;
  const size_t first = out.size();
  // One rigid map from the other's shape frame to the owner's: local = M s + t.
  const glm::dmat3 otherToOwner = rot * rt;
  const glm::dvec3 offset = rot * (pother.position - po.position - rt * other.localCom) + owner.localCom;
  // Swept test (thin owners): the same map at the substep's start. A sample whose path from there crosses more
  // than the owner's half thickness is marched along it through the owner's field (conservative advancement).
  const bool swept = startOwner && startOther;
  glm::dmat3 otherToOwner0(1);
  glm::dvec3 offset0(0);
  if (swept) {
    const glm::dmat3 rot0 = glm::transpose(glm::mat3_cast(startOwner->orientation));
    const glm::dmat3 rt0 = glm::mat3_cast(startOther->orientation);
    otherToOwner0 = rot0 * rt0;
    offset0 = rot0 * (startOther->position - startOwner->position - rt0 * other.localCom) + owner.localCom;
  }
  const double thin = so.halfThickness();
  const double tol = std::min(1e-4, 0.25 * thin);
  // Where the gradient is needed: every sample of a swept test or near dents, else only a contact's (phi < 0:
  // the owner's distance below r, exactly).
  const double gradientBelow = swept || dents.owner || dents.other ? std::numeric_limits<double>::infinity() : r;
  for (size_t k = 0; k < n; ++k) {
    const size_t index = list ? (*list)[k] : k;
    const glm::dvec3& s = st.samples[index];
    const glm::dvec3 local = otherToOwner * s + offset;
    if (local.x < lo.x || local.y < lo.y || local.z < lo.z || local.x > hi.x || local.y > hi.y || local.z > hi.z) {
      if (near) {
        const glm::dvec3 out = glm::max(glm::max(lo - local, local - hi), glm::dvec3(0));
        if (glm::dot(out, out) <= near->box2) near->samples->push_back(static_cast<uint32_t>(index));
      }
      if (clear) {
        const glm::dvec3 out = glm::max(glm::max(lo - local, local - hi), glm::dvec3(0));
        outside2 = std::min(outside2, glm::dot(out, out));
      }
      if (!swept) continue;
      // Outside the owner's bounds at the end: the path may still have crossed it.
      const glm::dvec3 local0 = otherToOwner0 * s + offset0;
      const glm::dvec3 plo = glm::min(local0, local), phi_ = glm::max(local0, local);
      if (plo.x > hi.x || plo.y > hi.y || plo.z > hi.z || phi_.x < lo.x || phi_.y < lo.y || phi_.z < lo.z) continue;
    }
    glm::dvec3 g;
    glm::dvec3 sampleHint = hint;
    if (normals && glm::dot(st.sampleNormals[index], st.sampleNormals[index]) > 0.5)
      sampleHint = -(otherToOwner * st.sampleNormals[index]);
    double phi = detail::fieldDistance(so, local, &g, &sampleHint, gradientBelow) - r;
    if (near && !(phi >= near->phi)) near->samples->push_back(static_cast<uint32_t>(index));
    if (clear) leastPhi = std::min(leastPhi, phi);
    double otherSinks = 0;  // how far the other's surface lies below its undented one at this sample
    if ((dents.owner || dents.other) && phi < dents.rise) {
      glm::dvec3 bent = g;
      double sinks = 0;
      if (dents.owner) sinks += (*dents.depth)(iOwner, local - (phi + r) * g, g, bent);
      if (dents.other) {
        // The other's surface point here and its outward normal: a surface sample's own (a fixed point and normal
        // of the other: the same question each time, which the answer's owner may keep), else the core sample
        // pushed out against the owner's gradient.
        const bool onSurface = surfaceSample(st, index);
        const glm::dvec3 n = onSurface ? st.sampleNormals[index] : -(glm::transpose(otherToOwner) * g);
        glm::dvec3 bentOther = n;
        if (onSurface && dents.otherSamples) {
          otherSinks = sampleDepth(*dents.otherSamples, *dents.depth, iOther, st, index, bentOther);
        } else {
          otherSinks = (*dents.depth)(iOther, s + r * n, n, bentOther);
        }
        sinks += otherSinks;
        if (!dents.owner) bent = -(otherToOwner * bentOther);
      }
      phi += sinks;
      const double len = glm::length(bent);
      if (len > 1e-12) g = bent / len;
    }
    if (swept) {
      // Did the sample pass through the owner during the substep, or go into it from outside so far that it ends
      // past the middle (its gradient there pointing out of the far side)? Marched along its path from the
      // substep's start, the first point within tol of the surface is where it came in.
      const glm::dvec3 local0 = otherToOwner0 * s + offset0, path = local - local0;
      const double len = glm::length(path);
      double t = 0, phiT = len > thin ? so.distance(local0) - r : 0.0;
      bool hit = false;
      if (phiT > 0) {  // (touching at the start, or a short path: the discrete test's business)
        for (int it = 0; it < 256 && t < 1; ++it) {
          if (phiT < tol) {
            hit = true;
            break;
          }
          t += std::max(phiT, tol) / len;
          phiT = so.distance(local0 + path * std::min(t, 1.0)) - r;
        }
      }
      if (hit) {
        // A contact at the end pose, on the side it came from, as deep as the path went past the surface (where
        // it ends inside, only past the middle: its gradient there points the other way).
        const glm::dvec3 at = local0 + path * std::min(t, 1.0);
        glm::dvec3 in(0);
        so.distance(at, &in);
        if (phi >= 0 || glm::dot(in, g) <= 0) {
          g = in;
          phi = std::min(glm::dot(local - at, g), -tol);
        }
      } else if (phi >= 0) {
        continue;
      }
    } else if (phi >= 0) {
      continue;
    }
    if (modifier) g = glm::normalize((*modifier)(iOwner, local - (phi + r) * g, g));
    Contact c;
    c.a = iOwner;
    c.b = iOther;
    c.normal = ro * g;  // unit: every shape's distance gradient is normalised
    c.point = pother.position + rt * (s - other.localCom) - r * c.normal + otherSinks * c.normal;
    c.phi = phi;
    out.push_back(c);
  }
  const double clearance = clear ? std::min(leastPhi / fieldSlope, std::sqrt(outside2)) : 0.0;
  if (clear) *clear = clearance;
  if (!segment) return;
  if (clear) *clear = -1;  // (the segment's points: unbounded, but where a bound below is found)
  // The distance to a convex shape along a segment is convex: its least lies between the neighbours of the
  // nearest core sample (the samples split the segment evenly), where a golden-section search finds it. The
  // distance changes by at most the distance moved: where the nearest sample is farther than r plus half the
  // samples' spacing, nothing between them reaches.
  const glm::dvec3 s0(0, -st.halfHeight, 0), s1(0, st.halfHeight, 0);
  auto at = [&](double t) { return otherToOwner * (s0 + t * (s1 - s0)) + offset; };
  auto f = [&](double t) { return so.distance(at(t)); };
  const size_t ns = st.samples.size();
  if (ns < 2) return;
  double t0 = 0, t1 = 1;
  if (ns <= 33) {  // (a longer capsule: the search runs over the whole segment, a few more steps than 33 looks)
    // The owner's exact distance (analytic shapes) is convex along the segment, so its tangent at each sample
    // bounds it from below everywhere: where the bound between the nearest sample's neighbours cannot beat what
    // the search would have to beat (no contact, or the samples' deepest contact), no search is made. A capsule
    // lying on a face has flat tangents: its samples hold the contact.
    const bool analytic = so.type != ShapeType::Mesh;
    const glm::dvec3 along = otherToOwner * (s1 - s0);
    double value[33], slope[33];
    size_t best = 0;
    for (size_t k = 0; k < ns; ++k) {
      glm::dvec3 g;
      value[k] = analytic ? so.distance(at(static_cast<double>(k) / static_cast<double>(ns - 1)), &g)
                          : f(static_cast<double>(k) / static_cast<double>(ns - 1));
      slope[k] = analytic ? glm::dot(g, along) : 0.0;
      if (value[k] < value[best]) best = k;
    }
    const double bestD = value[best];
    const double spacing = 2 * st.halfHeight / static_cast<double>(ns - 1);
    if (bestD - 0.5 * spacing >= r) {
      if (clear) *clear = std::min(clearance, (bestD - r) / fieldSlope - 0.5 * spacing);
      return;
    }
    const size_t k0 = best == 0 ? 0 : best - 1, k1 = std::min(best + 1, ns - 1);
    t0 = static_cast<double>(k0) / static_cast<double>(ns - 1);
    t1 = static_cast<double>(k1) / static_cast<double>(ns - 1);
    if (analytic) {
      double beat = 0;  // the depth a segment point must be below: none, or every listed sample's less 1e-9
      for (size_t k = first; k < out.size(); ++k) beat = std::min(beat, out[k].phi - 1e-9);
      auto bound = [&](double t) {
        double b = -1e300;
        for (size_t k = k0; k <= k1; ++k)
          b = std::max(b, value[k] + slope[k] * (t - static_cast<double>(k) / static_cast<double>(ns - 1)));
        return b;
      };
      // The least of the tangents' upper envelope over [t0, t1]: at an end or where two tangents cross.
      double least = std::min(bound(t0), bound(t1));
      for (size_t i = k0; i <= k1; ++i)
        for (size_t j = i + 1; j <= k1; ++j) {
          const double ds = slope[i] - slope[j];
          if (!(std::abs(ds) > 1e-300)) continue;
          const double ti = static_cast<double>(i) / static_cast<double>(ns - 1),
                       tj = static_cast<double>(j) / static_cast<double>(ns - 1);
          const double t = (value[j] - slope[j] * tj - value[i] + slope[i] * ti) / ds;
          if (t > t0 && t < t1) least = std::min(least, bound(t));
        }
      if (least - r >= beat) {
        if (clear && beat == 0) *clear = std::min(clearance, (least - r) / fieldSlope);
        return;
      }
    }
  }
  const double golden = 0.5 * (std::sqrt(5.0) - 1);
  double x1 = t1 - golden * (t1 - t0), x2 = t0 + golden * (t1 - t0), f1 = f(x1), f2 = f(x2);
  // (to a thousandth of a spacing: the depth is then within a thousandth of a radius)
  for (int it = 0; it < 60 && t1 - t0 > 1e-3 / static_cast<double>(ns - 1); ++it) {
    if (f1 <= f2) {
      t1 = x2, x2 = x1, f2 = f1;
      x1 = t1 - golden * (t1 - t0), f1 = f(x1);
    } else {
      t0 = x1, x1 = x2, f1 = f2;
      x2 = t0 + golden * (t1 - t0), f2 = f(x2);
    }
  }
  const double t = f1 <= f2 ? x1 : x2;
  const glm::dvec3 local = at(t);
  glm::dvec3 g;
  const double phi = so.distance(local, &g, &hint) - r;
  if (!(phi < 0)) return;
  for (size_t k = first; k < out.size(); ++k)
    if (!(phi < out[k].phi - 1e-9)) return;  // a sample is as deep: it stands there already
  if (modifier) g = glm::normalize((*modifier)(iOwner, local - (phi + r) * g, g));
  Contact c;
  c.a = iOwner;
  c.b = iOther;
  c.normal = ro * g;
  c.point = pother.position + rt * (s0 + t * (s1 - s0) - other.localCom) - r * c.normal;
  c.phi = phi;
  out.push_back(c);
}
// Two convex polytopes (boxes, convex meshes): their contact manifold (polytope.h)
// instead of the samples, which cannot hold a face lying on a face of the same
// size (an arch's joints) and give a box resting on a box 26 points where its
// overlap has 4 corners. Box on box by boxContacts. False when the pair is not such a pair.
bool manifoldContacts(int ia, const RigidBody& A, const PoseFrame& frameA, int ib, const RigidBody& B,
                      const PoseFrame& frameB, std::vector<Contact>& out, double* separation = nullptr) {
  if (separation) *separation = -1;
  const Shape& sa = *A.shape;
  const Shape& sb = *B.shape;
  if (!sa.polytope || !sb.polytope) return false;
  const Pose& pa = frameA.pose;
  const Pose& pb = frameB.pose;
  const glm::dmat3& ra = frameA.rotation;
  const glm::dmat3 rat = glm::transpose(ra);
  const glm::dmat3& rb = frameB.rotation;
  // B's shape frame into A's: x_A = rat (pb + rb (x_B - comB) - pa) + comA.
  RigidMap map;
  map.rotation = rat * rb;
  map.translation = rat * (pb.position - pa.position - rb * B.localCom) + A.localCom;
  thread_local std::vector<PolytopeContact> found;
  if (sa.type == ShapeType::Box && sb.type == ShapeType::Box)
    boxContacts(sa.halfExtents, sb.halfExtents, map, found, separation);
  else
    polytopeContacts(*sa.polytope, *sb.polytope, map, found);
  for (const PolytopeContact& f : found) {
    Contact c;
    c.a = f.normalOfA ? ia : ib;
    c.b = f.normalOfA ? ib : ia;
    c.normal = ra * f.normal;
    c.point = pa.position + ra * (f.point - A.localCom);
    c.phi = f.depth;
    out.push_back(c);
  }
  return true;
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

// A manifold's contacts between A (index ia) and B where either is dented (dentA, dentB): each point's depth
// measured against the dented surfaces (the owner's at the point on its surface, the other's at the point on
// its own); those the dents part are dropped. A manifold has its points at the polytopes' features, its normal
// the face's: a face over a crater wider than it rests on its corners there, on the crater's slopes, and a
// wall of dented blocks keeps its faces' normals (a texel's slope under a corner would push it sideways).
void dentManifold(const SurfaceDepth& depth, int ia, const RigidBody& A, const Pose& pa, bool dentA,
                  const RigidBody& B, const Pose& pb, bool dentB, std::vector<Contact>& out) {
  size_t kept = 0;
  for (Contact c : out) {
    const bool ownerIsA = c.a == ia;
    const RigidBody& O = ownerIsA ? A : B;
    const RigidBody& T = ownerIsA ? B : A;
    const Pose& po = ownerIsA ? pa : pb;
    const Pose& pt = ownerIsA ? pb : pa;
    const bool dentO = ownerIsA ? dentA : dentB, dentT = ownerIsA ? dentB : dentA;
    glm::dvec3 bent;
    double otherSinks = 0;
    if (dentO) {
      const glm::dmat3 ro = glm::mat3_cast(po.orientation);
      c.phi += depth(c.a, toShape(po, O.localCom, c.point - c.phi * c.normal), glm::transpose(ro) * c.normal, bent);
    }
    if (dentT) {
      const glm::dmat3 rt = glm::mat3_cast(pt.orientation);
      otherSinks = depth(c.b, toShape(pt, T.localCom, c.point), -(glm::transpose(rt) * c.normal), bent);
      c.phi += otherSinks;
    }
    c.point += otherSinks * c.normal;
    if (c.phi < 0) out[kept++] = c;
  }
  out.resize(kept);
}

namespace detail {
void forgetSurfaceAnswers(StepContext& ctx) {
  for (size_t i = 0; i < ctx.sampleDents.size() && i < ctx.bodies.size(); ++i) {
    StepContext::SampleDents& kept = ctx.sampleDents[i];
    if (!kept.stale) continue;
    kept.stale = false;
    const Shape& shape = *ctx.bodies[i].shape;
    const size_t n = ctx.dented(static_cast<int>(i)) && shape.sampleRadius == 0 ? shape.sampleNormals.size() : 0;
    if (n == 0) {
      kept = {};
      kept.stale = false;
      continue;
    }
    if (kept.depth.size() != n) {
      kept.state = std::make_unique<std::atomic<uint8_t>[]>(n);
      kept.depth.assign(n, 0.0);
      kept.bent.assign(n, glm::dvec3(0));
    }
    for (size_t k = 0; k < n; ++k) kept.state[k].store(0, std::memory_order_relaxed);
  }
}

SampleSides sampleSides(const Shape& a, bool bumpA, const Shape& b, bool bumpB) {
  auto convex = [](const Shape& s) { return s.type != ShapeType::Mesh || s.polytope != nullptr; };
  SampleSides sides;
  // A sphere first (its centre is exact alone), then a capsule (its core samples and its segment's deepest point).
  for (ShapeType rounded : {ShapeType::Sphere, ShapeType::Capsule}) {
    if (b.type == rounded && !bumpB && convex(a)) {
      sides.aInB = false;  // (two alike: B's core in A's field)
      sides.segmentB = rounded == ShapeType::Capsule;
      return sides;
    }
    if (a.type == rounded && !bumpA && convex(b)) {
      sides.bInA = false;
      sides.segmentA = rounded == ShapeType::Capsule;
      return sides;
    }
  }
  return sides;
}

bool pairContacts(const StepContext& ctx, Pair& pair, const PoseFrame& frameA, const PoseFrame& frameB,
                  std::vector<Contact>& out, double* clear) {
  out.clear();
  if (clear) *clear = -1;
  const Pose& pa = frameA.pose;
  const Pose& pb = frameB.pose;
  const RigidBody& A = ctx.body(pair.a);
  const RigidBody& B = ctx.body(pair.b);
  const bool bumpA = ctx.bentNormals(pair.a), bumpB = ctx.bentNormals(pair.b);
  // The poses at the substep's start (the bodies have not moved yet): swept tests where a body moves past more
  // than the other's half thickness in the substep (a thin plate the substeps cannot cover).
  // Uncapped substeps keep every body's travel under half the thinnest half thickness: no sweep is needed then.
  const Pose sa{A.x, A.q}, sb{B.x, B.q};
  const double moved = ctx.substepsCapped ? relativeDisplacementBound(sa, pa, A.shape->boundingRadius, sb, pb,
                                                                      B.shape->boundingRadius)
                                          : 0.0;
  const bool sweepA = moved > A.shape->halfThickness(), sweepB = moved > B.shape->halfThickness();
  if (!sweepA && !sweepB && !bumpA && !bumpB && manifoldContacts(pair.a, A, frameA, pair.b, B, frameB, out, clear)) {
    if (pair.dentsA || pair.dentsB)
      dentManifold(ctx.surfaceDepth, pair.a, A, pa, pair.dentsA, B, pb, pair.dentsB, out);
    sortContacts(out);
    return true;
  }
  // (findCandidates leaves the list of a side sampleSides skips empty)
  const SampleSides sides = sampleSides(*A.shape, bumpA || pair.dentsA, *B.shape, bumpB || pair.dentsB);
  const bool dentA = pair.dentsA, dentB = pair.dentsB;
  const double rise = (dentA ? ctx.rise(pair.a) : 0.0) + (dentB ? ctx.rise(pair.b) : 0.0);
  const Dents dentsA{&ctx.surfaceDepth, dentA, dentB, rise, keptAnswers(ctx, pair.b, dentB)},
      dentsB{&ctx.surfaceDepth, dentB, dentA, rise, keptAnswers(ctx, pair.a, dentA)};
  // (A list is made again with its near samples: a short one has none kept.)
  const std::vector<uint32_t>* listA = &pair.bInA;
  const std::vector<uint32_t>* listB = &pair.aInB;
  NearBuild makeA, makeB;
  const bool nearA = pair.bInA.size() >= kNearMinSamples &&
                     nearSamples(A, pa, B, pb, pair, pair.nearBInA, !sweepA && !dentA && !dentB, listA, makeA);
  const bool nearB = pair.aInB.size() >= kNearMinSamples &&
                     nearSamples(B, pb, A, pa, pair, pair.nearAInB, !sweepB && !dentA && !dentB, listB, makeB);
  // (Only where each side tests few samples, its whole short list or its near samples: a long list's every sample
  // would pay for the bound. A side that tested only its near samples has the others out of reach only while its
  // near samples hold: lookAtPair asks that too before it answers by the clearance.)
  double clearA = -1, clearB = -1;
  const bool clearing = clear && (nearA ? pair.bInA.size() : listA->size()) < kNearMinSamples &&
                        (nearB ? pair.aInB.size() : listB->size()) < kNearMinSamples;
  contactsOneWay(pair.a, A, frameA, pair.b, B, frameB, listA, out,
                 ctx.bentNormals(pair.a) ? &ctx.normalModifier : nullptr, sweepA ? &sa : nullptr,
                 sweepA ? &sb : nullptr, sides.segmentB && pair.bSegmentNear, dentsA, nearA ? &makeA : nullptr,
                 clearing && sides.bInA ? &clearA : nullptr);
  contactsOneWay(pair.b, B, frameB, pair.a, A, frameA, listB, out,
                 ctx.bentNormals(pair.b) ? &ctx.normalModifier : nullptr, sweepB ? &sb : nullptr,
                 sweepB ? &sa : nullptr, sides.segmentA && pair.aSegmentNear, dentsB, nearB ? &makeB : nullptr,
                 clearing && sides.aInB ? &clearB : nullptr);
  if (clearing) {
    const double inf = std::numeric_limits<double>::infinity();
    clearA = sides.bInA ? clearA : inf;
    clearB = sides.aInB ? clearB : inf;
    *clear = clearA < 0 || clearB < 0 ? -1.0 : std::min(clearA, clearB);
  }
  sortContacts(out);
  return false;
}

namespace {
// R in lookAtPair's reaches: a point (a sample's centre, radius r) whose gap to body b a look measured as D lies
// within R + D of b's centre of mass. A primitive's distance is the true one, and its surface lies within its
// reach: R = reach + r. A mesh's field only bounds it (its grid's slope), and inside its bounds box a point may be
// anywhere in it: R is also at least the corner of that box widened by r (outside it, D is the distance to it).
double clearReach(const RigidBody& b, double r) {
  const Shape& s = *b.shape;
  if (s.type != ShapeType::Mesh) return reachAboutCom(b) + r;
  const glm::dvec3 corner = glm::max(glm::abs(s.boundsMin - r - b.localCom), glm::abs(s.boundsMax + r - b.localCom));
  return std::max(reachAboutCom(b) + r, glm::length(corner));
}
}  // namespace

void lookAtPair(const StepContext& ctx, Pair& pair, const PoseFrame& frameA, const PoseFrame& frameB,
                std::vector<Contact>& out) {
  const double tolerance = ctx.settings.contactRefreshTolerance;
  const Pose& pa = frameA.pose;
  const Pose& pb = frameB.pose;
  ++pair.looks;
  const RigidBody& A = ctx.body(pair.a);
  const RigidBody& B = ctx.body(pair.b);
  // (Capped substeps may sweep (pairContacts), bent normals are the samples' own, dents change depths: all look
  // afresh.)
  const bool keepable = !ctx.substepsCapped && !ctx.bentNormals(pair.a) && !ctx.bentNormals(pair.b) &&
                        !pair.dentsA && !pair.dentsB;
  if (pair.hasKept && tolerance > 0 && keepable) {
    if (!displacementExceeds(pair.keptA, pa, reachAboutCom(A), pair.keptB, pb, reachAboutCom(B),
                             [&](double m) { return m > tolerance; })) {
      const glm::dmat3& rotA = frameA.rotation;
      const glm::dmat3& rotB = frameB.rotation;
      out.clear();
      for (const Pair::KeptContact& k : pair.kept) {
        const glm::dmat3& ro = k.ownerIsA ? rotA : rotB;
        const glm::dmat3& rt = k.ownerIsA ? rotB : rotA;
        const Pose& po = k.ownerIsA ? pa : pb;
        const Pose& pt = k.ownerIsA ? pb : pa;
        Contact c;
        c.a = k.ownerIsA ? pair.a : pair.b;
        c.b = k.ownerIsA ? pair.b : pair.a;
        c.normal = ro * k.normal;
        c.point = pt.position + rt * k.onOther;
        c.phi = glm::dot(c.point - (po.position + ro * k.onOwner), c.normal);
        if (c.phi < 0) out.push_back(c);
      }
      sortContacts(out);
      ++pair.keptLooks;
      return;
    }
  }
  // A look that found nothing, at poses from which the bodies' points have moved less than its clearance: nothing
  // again (each tested point's distance changes by no more than it moves, over the field's slope; the samples
  // left out of the lists stay out of reach while the lists hold).
  const bool clearing = keepable && ctx.settings.keepClearLooks;
  if (clearing && pair.clearance > 0 && pair.clearLists == pair.listGeneration &&
      (pair.bInA.size() < kNearMinSamples || nearHolds(pair.nearBInA, pair, pa, pb)) &&
      (pair.aInB.size() < kNearMinSamples || nearHolds(pair.nearAInB, pair, pb, pa))) {
    // (The reaches: a tested point of B whose gap to A is D >= clearance c lies within R + D of A's centre
    // (clearReach), so A's turn by a chord factor k moves it in A's frame by at most k (R + c) + k (D - c); where
    // the bound below keeps the whole move under c with the reach R + c, this one stays under c + k (D - c) <= D.
    // Likewise the other way; each body's own points lie within its reach.)
    const double c = pair.clearance;
    const double reachA = clearReach(A, B.shape->sampleRadius) + c;
    const double reachB = clearReach(B, A.shape->sampleRadius) + c;
    if (!displacementExceeds(pair.keptA, pa, reachA, pair.keptB, pb, reachB,
                             [&](double moved) { return !(moved < c); })) {
      out.clear();
      ++pair.clearLooks;
      return;
    }
  }
  pair.clearance = -1;
  // What a look that finds nothing keeps: its clearance less a hair (the distances' and the bound's rounding; a
  // turn under about 3e-8 rad rounds to none in displacementExceeds).
  auto keepClear = [&](double clear) {
    if (!clearing || !out.empty() || !(clear > 0) || !std::isfinite(clear)) return;
    const double kept = clear * (1 - 1e-6) - 1e-9 - 1e-7 * (reachAboutCom(A) + reachAboutCom(B));
    if (!(kept > 0)) return;
    pair.hasKept = false;
    pair.keptA = pa;
    pair.keptB = pb;
    pair.clearance = kept;
    pair.clearLists = pair.listGeneration;
  };
  // A ball against a convex shape where nothing sweeps, bends normals or feels dents: pairContacts would test the
  // ball's one core sample (its centre, when listed) in the other's field and nothing else; it is tested so here,
  // without what the general look prepares first (the same contact, bit for bit).
  if (keepable && (A.shape->type == ShapeType::Sphere || B.shape->type == ShapeType::Sphere)) {
    // (sampleSides' choice, as pairContacts makes it here: one side left out and no segment is a ball's centre.)
    const SampleSides sides = sampleSides(*A.shape, false, *B.shape, false);
    const bool ballB = !sides.aInB && !sides.segmentB, ballA = !sides.bInA && !sides.segmentA;
    if (ballA || ballB) {
      out.clear();
      double clear = -1;
      if (ballB)
        contactsOneWay(pair.a, A, frameA, pair.b, B, frameB, &pair.bInA, out, nullptr, nullptr, nullptr, false, {},
                       nullptr, clearing ? &clear : nullptr);
      else
        contactsOneWay(pair.b, B, frameB, pair.a, A, frameA, &pair.aInB, out, nullptr, nullptr, nullptr, false, {},
                       nullptr, clearing ? &clear : nullptr);
      sortContacts(out);
      pair.hasKept = false;
      keepClear(clear);
      return;
    }
  }
  // (Not a look with no points: two bodies a hair apart would close that gap unseen.) The samples' contacts are
  // kept as a manifold's points are where such a look could use them (no sweep, no bent normals, no dents), but
  // not with a ball: its one sample is cheap to look at again, and its contact's normal through both centres
  // (two frictionless balls that hit stay without spin) would not stay so as the kept points move with the bodies.
  double clear = -1;
  const bool manifold = pairContacts(ctx, pair, frameA, frameB, out, clearing ? &clear : nullptr);
  keepClear(clear);
  const bool samplesKept = keepable && A.shape->type != ShapeType::Sphere && B.shape->type != ShapeType::Sphere;
  pair.hasKept = (manifold || samplesKept) && tolerance > 0 && !out.empty();
  if (!pair.hasKept) return;
  pair.keptA = pa;
  pair.keptB = pb;
  pair.kept.resize(out.size());
  const glm::dmat3 toA = glm::transpose(frameA.rotation);
  const glm::dmat3 toB = glm::transpose(frameB.rotation);
  for (size_t i = 0; i < out.size(); ++i) {
    const Contact& c = out[i];
    Pair::KeptContact& k = pair.kept[i];
    k.ownerIsA = c.a == pair.a;
    const glm::dmat3& to = k.ownerIsA ? toA : toB;
    const glm::dmat3& tt = k.ownerIsA ? toB : toA;
    const Pose& po = k.ownerIsA ? pa : pb;
    const Pose& pt = k.ownerIsA ? pb : pa;
    k.normal = to * c.normal;
    k.onOwner = to * (c.point - c.phi * c.normal - po.position);
    k.onOther = tt * (c.point - pt.position);
  }
}
}  // namespace detail

void World::findContacts(int ia, int ib, const Pose& pa, const Pose& pb, std::vector<Contact>& out) const {
  out.clear();
  const RigidBody& A = ctx_->body(ia);
  const RigidBody& B = ctx_->body(ib);
  const bool dentA = ctx_->dentsReach(ia, ib, 0.005), dentB = ctx_->dentsReach(ib, ia, 0.005);
  const detail::PoseFrame frameA(pa), frameB(pb);
  if (manifoldContacts(ia, A, frameA, ib, B, frameB, out)) {
    if (dentA || dentB) dentManifold(ctx_->surfaceDepth, ia, A, pa, dentA, B, pb, dentB, out);
    sortContacts(out);
    return;
  }
  const detail::SampleSides sides = detail::sampleSides(*A.shape, ctx_->bentNormals(ia) || dentA, *B.shape,
                                                        ctx_->bentNormals(ib) || dentB);
  const double rise = (dentA ? ctx_->rise(ia) : 0.0) + (dentB ? ctx_->rise(ib) : 0.0);
  const Dents dentsA{&ctx_->surfaceDepth, dentA, dentB, rise, keptAnswers(*ctx_, ib, dentB)},
      dentsB{&ctx_->surfaceDepth, dentB, dentA, rise, keptAnswers(*ctx_, ia, dentA)};
  if (sides.bInA)
    contactsOneWay(ia, A, frameA, ib, B, frameB, nullptr, out, nullptr, nullptr, nullptr, sides.segmentB, dentsA);
  if (sides.aInB)
    contactsOneWay(ib, B, frameB, ia, A, frameA, nullptr, out, nullptr, nullptr, nullptr, sides.segmentA, dentsB);
  sortContacts(out);
}

bool World::raycast(const glm::dvec3& origin, const glm::dvec3& dir, double maxDistance, int ignore,
                    RayHit& hit) const {
  bool found = false;
  hit.distance = maxDistance;
  const glm::dvec3 end = origin + dir * maxDistance;
  const glm::dvec3 rlo = glm::min(origin, end), rhi = glm::max(origin, end);
  const std::vector<RigidBody>& bodies = ctx_->bodies;
  for (size_t i = 0; i < bodies.size(); ++i) {
    if (static_cast<int>(i) == ignore) continue;
    const RigidBody& b = bodies[i];
    const Pose pose{b.x, b.q};
    const Aabb box = detail::worldBounds(*b.shape, b.localCom, pose);
    if (box.lo.x > rhi.x || box.lo.y > rhi.y || box.lo.z > rhi.z || box.hi.x < rlo.x || box.hi.y < rlo.y ||
        box.hi.z < rlo.z)
      continue;
    const glm::dmat3 rt = glm::transpose(b.rotation());
    const glm::dvec3 o = rt * (origin - b.x) + b.localCom, d = rt * dir;
    // A dented body's surface lies surfaceDepth below the undented one near it (no further than its rise above):
    // there the trace measures the dented surface, so a wheel's ray reaches a rut's floor.
    const bool dented = ctx_->dented(static_cast<int>(i));
    const double rise = ctx_->rise(static_cast<int>(i));
    double t = 0;
    for (int it = 0; it < 128 && t <= hit.distance; ++it) {
      const glm::dvec3 p = o + d * t;
      glm::dvec3 g(0);
      double phi = b.shape->distance(p, dented ? &g : nullptr);
      glm::dvec3 normal = g;
      if (dented && phi < rise + 1e-4) phi += ctx_->surfaceDepth(static_cast<int>(i), p - phi * g, g, normal);
      if (phi < 1e-4) {
        if (t < hit.distance || !found) {
          if (!dented) b.shape->distance(p, &normal);
          hit.body = static_cast<int>(i);
          hit.distance = t;
          hit.point = origin + dir * t;
          hit.normal = glm::normalize(b.rotation() * normal);
          found = true;
        }
        break;
      }
      t += std::max(phi, 1e-4);
    }
  }
  return found;
}

}  // namespace crumple
