// Position step: x += h v, q integrated from omega, then a positional
// projection of the penetration left.
//
// Guarantees:
// - endOfStepDepths (before the update): each contact group's depth is its
//   depth at the contact step's last look plus h times the change of its
//   normal relative speed since: its depth at the new positions, to first order
//   in h (exact for translations).
// - integratePositions: every movable body moves with its velocities; a
//   dynamic body turns torque-free (rotation.h: its angular momentum and
//   kinetic energy kept, its angular velocity following its orientation); the
//   orientation stays a unit quaternion.
// - projectPositions: `projectionIterations` iterations over the groups push
//   the two bodies apart along the normal by `penetrationCorrection` of the
//   depth beyond `penetrationSlop`, split by inverse mass, no body further
//   than maxCorrectionSpeed x h in all (deep overlaps part over several
//   steps, gaining no energy). Translations only:
//   no velocity changes, except that a group still approaching at the first
//   iteration loses its approach (an inelastic, frictionless normal impulse;
//   it never adds energy). Each iteration ends with projectJoints: what it
//   moved apart, the joints' anchors, is brought together again (translations).
// - A dynamic body pinned between a static body and a kinematic one that drives
//   it straight at the static one (their normals within 25 degrees of opposite)
//   is held by the static one: the projection leaves the kinematic pair alone
//   (its overlap grows: the kinematic body passes into the pinned one) rather
//   than push the pinned body through the static one.
// - On several threads and without joints to bring together, the projection
//   runs by runs of whole islands (islands.cpp): each body gets the same
//   corrections in the same order as over all pairs.
#include <algorithm>

#include <crumple/physics/step_context.h>

namespace crumple::detail {

// The contact step's last look saw the positions predicted with the
// velocities of that moment; the step ends with others. Each group's depth at
// the new positions is its depth then plus h times the change of its normal
// relative speed since (first order in h; exact for translations). Called
// between the contact step and the position update, it spares the projection
// a look of its own.
void endOfStepDepths(StepContext& ctx, double h) {
  const size_t pairs = std::min(ctx.groups.size(), ctx.pairs.size());
  ctx.parallelRange(pairs, 256, [&](size_t begin, size_t end, int) {
    for (size_t pi = begin; pi < end; ++pi)
      for (ContactGroup& g : ctx.groups[pi]) {
        Contact& c = g.contact;
        c.phi += h * (glm::dot(ctx.relativeVelocity(c.a, c.b, g.levers), c.normal) - g.speed);
      }
  });
}

void integratePositions(StepContext& ctx, double h) {
  ctx.parallelRange(ctx.bodies.size(), 256, [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      RigidBody& b = ctx.bodies[i];
      if (!b.movable()) continue;
      b.x += h * b.v;
      const FreeRotation r = ctx.turnOf(b, b.w, h);
      b.q = r.q;
      b.w = r.w;
    }
  });
}

// ctx.squeezed: per pair, 1 for a kinematic body's pair with a dynamic body that some group of a static body's
// pair pushes back the other way (normals into the dynamic body within 25 degrees of opposite); empty where no
// pair joins a kinematic body to a dynamic one.
void squeezedPairs(StepContext& ctx) {
  std::vector<char>& squeezed = ctx.squeezed;
  squeezed.clear();
  const size_t np = std::min(ctx.groups.size(), ctx.pairs.size());
  auto kinematicPair = [&](const Pair& p) {
    const RigidBody &a = ctx.body(p.a), &b = ctx.body(p.b);
    return (a.kinematic && b.dynamic()) || (b.kinematic && a.dynamic());
  };
  size_t pi = 0;
  while (pi < np && (ctx.groups[pi].empty() || !kinematicPair(ctx.pairs[pi]))) ++pi;
  if (pi == np) return;
  // The static bodies' normals into each dynamic body, by body.
  std::vector<std::pair<int, glm::dvec3>>& held = ctx.squeezeStatic;
  held.clear();
  for (size_t k = 0; k < np; ++k) {
    const Pair& p = ctx.pairs[k];
    const RigidBody &a = ctx.body(p.a), &b = ctx.body(p.b);
    if (!((!a.movable() && b.dynamic()) || (!b.movable() && a.dynamic()))) continue;
    for (const ContactGroup& g : ctx.groups[k]) {
      const bool aHolds = !ctx.body(g.contact.a).movable();
      held.emplace_back(aHolds ? g.contact.b : g.contact.a, aHolds ? g.contact.normal : -g.contact.normal);
    }
  }
  if (held.empty()) return;
  std::stable_sort(held.begin(), held.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  squeezed.assign(np, 0);
  for (; pi < np; ++pi) {
    if (ctx.groups[pi].empty() || !kinematicPair(ctx.pairs[pi])) continue;
    for (const ContactGroup& g : ctx.groups[pi]) {
      const bool aDrives = ctx.body(g.contact.a).kinematic;
      const int d = aDrives ? g.contact.b : g.contact.a;
      const glm::dvec3 into = aDrives ? g.contact.normal : -g.contact.normal;  // the kinematic body's push on d
      auto it = std::lower_bound(held.begin(), held.end(), d, [](const auto& x, int body) { return x.first < body; });
      for (; it != held.end() && it->first == d && !squeezed[pi]; ++it)
        squeezed[pi] = glm::dot(into, it->second) < -0.9;  // 25 degrees
    }
  }
}

// Positional projection on the contact step's groups (depths at the new
// positions from endOfStepDepths). The projection only translates bodies, so
// from one iteration to the next each group's depth moves by the two bodies'
// translations along its normal (exact for flat contact).
void projectPositions(StepContext& ctx, double h) {
  const WorldSettings& settings = ctx.settings;
  if (settings.projectionIterations <= 0) return;
  // No body is translated further than this by the projection in a substep (maxCorrectionSpeed).
  const double reach = settings.maxCorrectionSpeed * h;
  std::vector<glm::dvec3>& moved = ctx.projected;
  moved.assign(ctx.bodies.size(), glm::dvec3(0));
  squeezedPairs(ctx);
  const std::vector<char>& squeezed = ctx.squeezed;
  auto skipped = [&](size_t pi) { return !squeezed.empty() && squeezed[pi]; };
  // One group's correction in iteration `it` (a body that cannot move is not written: islands share them).
  auto project = [&](const ContactGroup& g, int it) {
    const Contact& c = g.contact;
    const size_t ia = static_cast<size_t>(c.a), ib = static_cast<size_t>(c.b);
    const double depth = -(c.phi + glm::dot(moved[ib] - moved[ia], c.normal)) - settings.penetrationSlop;
    if (depth <= 0) return;
    RigidBody& ca = ctx.bodies[ia];
    RigidBody& cb = ctx.bodies[ib];
    const double wa = ca.movable() ? ca.invMass : 0, wb = cb.movable() ? cb.invMass : 0;
    if (wa + wb <= 0) return;
    if (it == 0) {
      // A contact still sinking after the contact step would sink again
      // next step and be pushed out again: the approach goes too
      // (inelastic, normal only: it never adds energy).
      const glm::dvec3 j = frictionlessImpulse(g.matrix.K, ctx.relativeVelocity(c.a, c.b, g.levers), c.normal, 0.0);
      if (glm::dot(j, j) > 0) ctx.applyImpulse(c.a, c.b, g.levers, j);
    }
    const double corr = settings.penetrationCorrection * depth / (wa + wb);
    if (wa > 0) {
      const glm::dvec3 d = withinReach(moved[ia], -(c.normal * corr * wa), reach);
      ca.x += d;
      moved[ia] += d;
    }
    if (wb > 0) {
      const glm::dvec3 d = withinReach(moved[ib], c.normal * corr * wb, reach);
      cb.x += d;
      moved[ib] += d;
    }
  };
  // (On one thread, in pair order: the islands' order walks the groups out of memory order, 50% slower.)
  if (!anyJointActive(ctx) && ctx.workers() > 1 && ctx.groups.size() >= ctx.pairs.size()) {
    ctx.forEachIslandRun(256, [&](size_t k0, size_t k1, size_t, int) {
      const uint32_t* first = ctx.islandPairs.data() + ctx.islandStart[k0];
      const uint32_t* last = ctx.islandPairs.data() + ctx.islandStart[k1];
      for (int it = 0; it < settings.projectionIterations; ++it)
        for (const uint32_t* p = first; p != last; ++p)
          if (!skipped(*p))
            for (const ContactGroup& g : ctx.groups[*p]) project(g, it);
    });
    return;
  }
  for (int it = 0; it < settings.projectionIterations; ++it) {
    for (size_t pi = 0; pi < ctx.groups.size() && pi < ctx.pairs.size(); ++pi)
      if (!skipped(pi))
        for (const ContactGroup& g : ctx.groups[pi]) project(g, it);
    // The translations above pulled joined bodies apart: the joints' anchors
    // are brought together again, translations only (joint_step.cpp).
    projectJoints(ctx, moved, reach, it == 0);
  }
}

}  // namespace crumple::detail
