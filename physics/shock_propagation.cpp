// Shock propagation (Guendelman et al. 2003, section 7.3), on the contact
// step's last groups.
//
// Guarantees:
// - Levels: static, kinematic and sleeping bodies are level 0; every other body touching
//   one (through a pair with groups) is one more than the lowest level it
//   touches (breadth-first, so cycles collapse into one level and it never
//   loops); then a body resting on another of its own level (their groups'
//   normals within 45 degrees of up) goes one level above it (restingLevels);
//   bodies touching nothing stay unlevelled and untouched. Bodies
//   joined by a joint (both dynamic) always share a level: an articulated
//   body is one unit in the contact graph (Weinstein et al. 2006).
// - Level by level from 1 up, with every lower level frozen (infinite mass):
//   Jacobi passes over the level's groups, each group's impulse computed from
//   the same velocities and each body taking the mean of its groups'
//   (restitution 0, friction), part by part (the level's groups joined through
//   the bodies they move: a part shares no moving body with another) until a pass
//   changes no group's relative velocity by more than `shockTolerance` (at most
//   `shockPasses`). A body resting on one patch of the
//   frozen level below is held against tilting by that patch; on two, the
//   patches hold only the tilt about the line through them.
// - An island no kinematic body drives gains no kinetic energy here beyond
//   resting contact's own scale (its bodies at g h): where the passes raised it
//   more (a frozen light body shoving a heavy one), its bodies' velocities are
//   put back as the contact step left them.
// - Afterwards no body is frozen. ctx.shockPush holds each pair's normal impulse
//   from the passes, ctx.shockAbsorbed what each dynamic body took while frozen
//   (zero for an island undone), for collisionsCarried.
// - The levels are found by runs of islands (in parallel; over all bodies at
//   once when there are joints): the same levels, as a path from level 0 to a
//   dynamic body runs through that body's island only. The passes run island
//   by island (islands.cpp; in parallel on the World's threads), each island's levels
//   from 1 up: a level's groups in pair order within each island, so every
//   body gets the same impulses in the same order as level by level over all
//   pairs (static, kinematic and sleeping bodies are frozen throughout and
//   never written).
#include <algorithm>
#include <cmath>

#include <crumple/physics/step_context.h>

namespace crumple::detail {

namespace {

// One group of the level being processed, with what its impulses need.
struct LevelContact {
  Contact c;
  Levers l;
  ImpulseMatrix m;  // K with this level's frozen bodies (made by withMatrix where a solve needs it)
  bool hasMatrix = false;
  double mu = 0;
  ImpulseSide sa, sb;
  const PatchExtent* extent = nullptr;
  size_t pair = 0;
  PatchMatrix patch;     // valid only for a body's one or two support patches
  bool follows = false;  // a body's one support: followSupport first, its patch matrix made only if that fails
};

// One island's work, on one worker: its pairs and bodies by level.
struct alignas(64) IslandScratch {  // (a cache line of its own: see ContactScratch)
  std::vector<size_t> pairs;         // by level (levelStart), in pair order within a level
  std::vector<uint32_t> levelStart;  // pairs[levelStart[l], levelStart[l + 1]): level l's
  std::vector<int> bodies, byLevel;  // its levelled dynamic bodies, and the same by level (bodyStart)
  std::vector<uint32_t> bodyStart, fill;
  std::vector<LevelContact> lc;
  std::vector<uint32_t> order, partStart, key;  // levelParts: lc's indices by part (partStart), each part's in lc order
  std::vector<std::pair<int, size_t>> supports;
  std::vector<glm::dvec3> dj, dt;
  std::vector<uint32_t> adjStart, adj;  // islandLevels: the dynamic bodies' neighbours, compressed rows
  std::vector<int> queue;
  // The energy guard: per levelled body its island in the run and its velocities before the passes; per island
  // of the run, whether a kinematic body drives it and its kinetic energy before and after.
  std::vector<int> bodyIsland;
  std::vector<std::pair<glm::dvec3, glm::dvec3>> velocities;
  std::vector<char> driven;
  std::vector<double> energyBefore, energyAfter, slack;
};

// Working arrays kept from one substep to the next (no allocation per substep).
struct Scratch {
  std::vector<uint32_t> start, neighbours;  // the contact graph, compressed rows: body i's are [start[i], start[i+1])
  std::vector<int> queue, stack;
  std::vector<std::vector<int>> joined;
  std::vector<uint32_t> fill;
  std::vector<int> share;              // per body: its groups on the level under way
  std::vector<int> root, part;         // per body on the level under way: levelParts' sets and their parts
  std::vector<uint32_t> stamp;          // per body: the island (+1) that last counted it
  std::vector<uint32_t> local, seen;    // per dynamic body: its index among its run's, and the run (+1) (islandLevels)
  std::vector<IslandScratch> islands;  // per worker
};
constexpr double kRestingCos = 0.70710678118654752;  // cos 45 degrees
constexpr int kRestingSweeps = 8;

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

// Which of a pair of bodies rests on the other: +1 when b rests on a (its groups' normals, out of a, lie within
// 45 degrees of up on average), -1 when a rests on b, 0 when neither (side by side, or no gravity).
int restsOn(const StepContext& ctx, size_t pi, const glm::dvec3& up) {
  const std::vector<ContactGroup>& groups = ctx.groups[pi];
  if (groups.empty()) return 0;
  double sum = 0;
  for (const ContactGroup& g : groups)
    sum += (g.contact.a == ctx.pairs[pi].a ? 1.0 : -1.0) * glm::dot(g.contact.normal, up);
  const double mean = sum / static_cast<double>(groups.size());
  return mean > kRestingCos ? 1 : mean < -kRestingCos ? -1 : 0;
}

// Levels by support within a level: a body resting on another of its own level (a plank leaning on a brick
// with its other end on the ground: both touch the ground, both are level 1) goes above it, so that the
// lower one is frozen when the upper one is processed. Jacobi passes over two bodies of one level converge
// at the pace of their mass ratio (a 1350 kg slab on a 29 kg brick: 12 passes left it sinking at 5 cm/s a
// step and shoving the brick out); one level above the other, the slab stops on the frozen brick at once.
// Relaxed over the pairs [first, last) until nothing moves (a chain of such supports moves one link a
// sweep), at most kRestingSweeps sweeps; bodies of a joined unit keep their unit's level.
template <class Pairs>
void restingLevels(const StepContext& ctx, const Pairs& pairs, std::vector<int>& level,
                   const std::vector<std::vector<int>>* joined) {
  const double g = glm::length(ctx.settings.gravity);
  if (!(g > 0)) return;
  const glm::dvec3 up = -ctx.settings.gravity / g;
  auto free = [&](int b) {
    return level[static_cast<size_t>(b)] >= 1 &&
           (joined == nullptr || joined->size() <= static_cast<size_t>(b) || (*joined)[static_cast<size_t>(b)].empty());
  };
  for (int sweep = 0; sweep < kRestingSweeps; ++sweep) {
    bool moved = false;
    pairs([&](size_t pi) {
      const int a = ctx.pairs[pi].a, b = ctx.pairs[pi].b;
      if (level[static_cast<size_t>(a)] < 1 || level[static_cast<size_t>(b)] < 1) return;
      const int on = restsOn(ctx, pi, up);
      if (on == 0) return;
      const int lower = on > 0 ? a : b, upper = on > 0 ? b : a;
      if (level[static_cast<size_t>(upper)] > level[static_cast<size_t>(lower)] || !free(upper)) return;
      level[static_cast<size_t>(upper)] = level[static_cast<size_t>(lower)] + 1;
      moved = true;
    });
    if (!moved) break;
  }
}

// The contact graph of the contact step's last look (positions moved with the
// velocities of then); levels from the static (and sleeping) bodies up by
// breadth-first search (ctx.level; -1: touching nothing).
void computeLevels(StepContext& ctx, Scratch& s, bool flat) {
  const size_t n = ctx.bodies.size();
  const size_t pairs = std::min(ctx.pairs.size(), ctx.groups.size());
  // Each body's neighbours, in pair order.
  s.start.assign(n + 1, 0);
  for (size_t pi = 0; pi < pairs; ++pi) {
    if (ctx.groups[pi].empty()) continue;
    ++s.start[static_cast<size_t>(ctx.pairs[pi].a) + 1];
    ++s.start[static_cast<size_t>(ctx.pairs[pi].b) + 1];
  }
  for (size_t i = 0; i < n; ++i) s.start[i + 1] += s.start[i];
  s.neighbours.resize(s.start[n]);
  {
    std::vector<uint32_t>& fill = s.fill;
    fill.assign(s.start.begin(), s.start.end() - 1);
    for (size_t pi = 0; pi < pairs; ++pi) {
      if (ctx.groups[pi].empty()) continue;
      const Pair& pair = ctx.pairs[pi];
      s.neighbours[fill[static_cast<size_t>(pair.a)]++] = static_cast<uint32_t>(pair.b);
      s.neighbours[fill[static_cast<size_t>(pair.b)]++] = static_cast<uint32_t>(pair.a);
    }
  }
  std::vector<int>& level = ctx.level;
  level.assign(n, -1);
  std::vector<int>& queue = s.queue;
  queue.clear();
  for (size_t i = 0; i < n; ++i) {
    if (!ctx.bodies[i].dynamic()) {
      level[i] = 0;
      queue.push_back(static_cast<int>(i));
    }
  }
  // Articulated bodies (joined, both dynamic) act as one unit: a body's level
  // goes at once to every body joined to it.
  std::vector<std::vector<int>>& joined = s.joined;  // (its lists keep their memory from call to call)
  for (std::vector<int>& list : joined) list.clear();
  bool anyJoined = false;
  for (const Joint& jt : ctx.joints) {
    if (jt.removed || jt.broken || jt.def.a < 0) continue;
    if (!ctx.body(jt.def.a).dynamic() || !ctx.body(jt.def.b).dynamic()) continue;
    if (joined.size() < n) joined.resize(n);
    anyJoined = true;
    joined[static_cast<size_t>(jt.def.a)].push_back(jt.def.b);
    joined[static_cast<size_t>(jt.def.b)].push_back(jt.def.a);
  }
  auto assign = [&](int j, int l) {
    level[static_cast<size_t>(j)] = l;
    queue.push_back(j);
    if (!anyJoined) return;
    // The joined unit, depth first, all at level l.
    std::vector<int>& stack = s.stack;
    stack.assign(1, j);
    while (!stack.empty()) {
      const int k = stack.back();
      stack.pop_back();
      for (int m : joined[static_cast<size_t>(k)]) {
        if (level[static_cast<size_t>(m)] >= 0) continue;
        level[static_cast<size_t>(m)] = l;
        queue.push_back(m);
        stack.push_back(m);
      }
    }
  };
  for (size_t head = 0; head < queue.size(); ++head) {
    const int i = queue[head];
    for (uint32_t k = s.start[static_cast<size_t>(i)]; k < s.start[static_cast<size_t>(i) + 1]; ++k) {
      const int j = static_cast<int>(s.neighbours[k]);
      if (level[static_cast<size_t>(j)] < 0) assign(j, level[static_cast<size_t>(i)] + 1);
    }
  }
  if (flat) {  // every dynamic body on level 1, whether or not a path leads to level 0 (a bridge hung on hinges)
    for (size_t i = 0; i < n; ++i)
      if (level[i] != 0) level[i] = 1;
    return;
  }
  restingLevels(
      ctx,
      [&](auto&& f) {
        for (size_t pi = 0; pi < pairs; ++pi) f(pi);
      },
      level, anyJoined ? &joined : nullptr);
}

// computeLevels for a run of islands [first, last) of pairs (without joints): the same levels, as every path
// from a level 0 body to a dynamic one runs through the dynamic body's island only. ctx.level holds 0 for
// the bodies that are not dynamic and -1 for the rest; the run's dynamic bodies get theirs.
void islandLevels(StepContext& ctx, const uint32_t* first, const uint32_t* last, uint32_t mark, IslandScratch& w,
                  std::vector<uint32_t>& stamp, std::vector<uint32_t>& local) {
  std::vector<int>& level = ctx.level;
  std::vector<int>& bodies = w.bodies;  // (scratch here: shockIslands fills it again)
  bodies.clear();
  auto dynamicBody = [&](int b) { return level[static_cast<size_t>(b)] != 0; };
  for (const uint32_t* p = first; p != last; ++p) {
    if (ctx.groups[*p].empty()) continue;
    for (int b : {ctx.pairs[*p].a, ctx.pairs[*p].b})
      if (dynamicBody(b) && stamp[static_cast<size_t>(b)] != mark) {
        stamp[static_cast<size_t>(b)] = mark;
        local[static_cast<size_t>(b)] = static_cast<uint32_t>(bodies.size());
        bodies.push_back(b);
      }
  }
  if (bodies.empty()) return;
  // Neighbours among the run's dynamic bodies, in pair order; a body touching level 0 starts at level 1.
  w.adjStart.assign(bodies.size() + 1, 0);
  w.queue.clear();
  for (const uint32_t* p = first; p != last; ++p) {
    if (ctx.groups[*p].empty()) continue;
    const int a = ctx.pairs[*p].a, b = ctx.pairs[*p].b;
    if (dynamicBody(a) && dynamicBody(b)) {
      ++w.adjStart[local[static_cast<size_t>(a)] + 1];
      ++w.adjStart[local[static_cast<size_t>(b)] + 1];
    } else if (dynamicBody(a) || dynamicBody(b)) {
      const int d = dynamicBody(a) ? a : b;
      if (level[static_cast<size_t>(d)] < 0) {
        level[static_cast<size_t>(d)] = 1;
        w.queue.push_back(d);
      }
    }
  }
  for (size_t k = 0; k < bodies.size(); ++k) w.adjStart[k + 1] += w.adjStart[k];
  w.adj.resize(w.adjStart[bodies.size()]);
  std::vector<uint32_t>& fill = w.fill;
  fill.assign(w.adjStart.begin(), w.adjStart.end() - 1);
  for (const uint32_t* p = first; p != last; ++p) {
    if (ctx.groups[*p].empty()) continue;
    const int a = ctx.pairs[*p].a, b = ctx.pairs[*p].b;
    if (!dynamicBody(a) || !dynamicBody(b)) continue;
    w.adj[fill[local[static_cast<size_t>(a)]]++] = static_cast<uint32_t>(b);
    w.adj[fill[local[static_cast<size_t>(b)]]++] = static_cast<uint32_t>(a);
  }
  for (size_t head = 0; head < w.queue.size(); ++head) {
    const int i = w.queue[head];
    const uint32_t li = local[static_cast<size_t>(i)];
    for (uint32_t k = w.adjStart[li]; k < w.adjStart[li + 1]; ++k) {
      const int j = static_cast<int>(w.adj[k]);
      if (level[static_cast<size_t>(j)] < 0) {
        level[static_cast<size_t>(j)] = level[static_cast<size_t>(i)] + 1;
        w.queue.push_back(j);
      }
    }
  }
  restingLevels(
      ctx,
      [&](auto&& f) {
        for (const uint32_t* p = first; p != last; ++p) f(*p);
      },
      level, nullptr);
}

// This level's contact groups (a pair whose upper body is on this level), with
// K for the frozen bodies of the levels below, and each body's count of them.
void levelContacts(const StepContext& ctx, const size_t* first, const size_t* last, std::vector<LevelContact>& lc,
                   std::vector<int>& share) {
  // The elements lc already holds are reused (a kilobyte each, zeroed for nothing when made anew): every field
  // is written here but the patch, which only supportPatches makes valid.
  size_t count = 0;
  for (const size_t* t = first; t != last; ++t) {
    const size_t pi = *t;
    const Pair& pair = ctx.pairs[pi];
    const double mu = std::sqrt(ctx.body(pair.a).friction * ctx.body(pair.b).friction);
    for (const ContactGroup& g : ctx.groups[pi]) {
      const Contact& c = g.contact;
      const bool fa = ctx.frozen[static_cast<size_t>(c.a)] != 0, fb = ctx.frozen[static_cast<size_t>(c.b)] != 0;
      LevelContact& x = count < lc.size() ? lc[count] : lc.emplace_back();
      ++count;
      x.patch.valid = false;
      x.pair = pi;
      x.follows = false;
      x.c = c;
      x.l = g.levers;
      x.mu = mu;
      x.extent = &g.patchMatrix.patch;
      ctx.sidesAt(c.a, c.b, g.levers, fa, fb, x.sa, x.sb);
      x.hasMatrix = false;
      if (!fa) ++share[static_cast<size_t>(c.a)];  // frozen bodies do not move
      if (!fb) ++share[static_cast<size_t>(c.b)];
    }
  }
  lc.resize(count);
}

// x with its K (a body on one support that follows it needs none).
LevelContact& withMatrix(LevelContact& x) {
  if (!x.hasMatrix) x.m = ImpulseMatrix(collisionMatrix(x.sa, x.sb));
  x.hasMatrix = true;
  return x;
}

// A body resting on one patch of the level below is held against tilting by
// that patch (its torque). On two supports, the couple of their point
// impulses holds the tilt across the line through them and each support's
// patch keeps only the torque about that line (lineMatrix): full patch
// torques would each ask for their own support's tilt, and the body would
// jitter between them. On more, the couples hold every tilt.
void supportPatches(const StepContext& ctx, const std::vector<int>& share, std::vector<LevelContact>& lc,
                    std::vector<std::pair<int, size_t>>& supports) {
  // (body, level contact) for each support from the frozen level below, by body.
  supports.clear();
  for (size_t k = 0; k < lc.size(); ++k) {
    const bool fa = ctx.frozen[static_cast<size_t>(lc[k].c.a)] != 0,
               fb = ctx.frozen[static_cast<size_t>(lc[k].c.b)] != 0;
    if (fa != fb) supports.push_back({fa ? lc[k].c.b : lc[k].c.a, k});
  }
  std::sort(supports.begin(), supports.end());
  for (size_t first = 0, last; first < supports.size(); first = last) {
    const int body = supports[first].first;
    for (last = first; last < supports.size() && supports[last].first == body; ++last) {
    }
    const size_t count = last - first;
    if (static_cast<size_t>(share[static_cast<size_t>(body)]) != count) continue;  // touches its own level too
    if (count == 1) {
      LevelContact& x = lc[supports[first].second];
      x.patch.patch = *x.extent;
      x.follows = true;  // (its matrix: jacobiPasses, where followSupport cannot do)
    } else if (count == 2) {
      const size_t k0 = supports[first].second, k1 = supports[first + 1].second;
      const glm::dvec3 line = lc[k1].c.point - lc[k0].c.point;
      for (size_t k : {k0, k1}) lc[k].patch = lineMatrix(lc[k].sa, lc[k].sb, withMatrix(lc[k]).m, *lc[k].extent, line);
    }
  }
}

// The level's parts: its groups joined through the bodies they move (this level's; the levels below are
// frozen), in lc's indices, part by part (partStart), each part's in lc order. Parts share no moving body, so
// each converges on its own: a pyramid's level is one island, but each box on its two frozen supports is a part
// of its own, and a slow one no longer keeps the others passing.
void levelParts(const StepContext& ctx, const std::vector<LevelContact>& lc, std::vector<int>& root,
                std::vector<int>& part, IslandScratch& w) {
  auto moving = [&](int b) { return ctx.frozen[static_cast<size_t>(b)] == 0; };
  auto find = [&](int b) {
    while (root[static_cast<size_t>(b)] != b) {
      root[static_cast<size_t>(b)] = root[static_cast<size_t>(root[static_cast<size_t>(b)])];
      b = root[static_cast<size_t>(b)];
    }
    return b;
  };
  for (const LevelContact& x : lc)
    for (int b : {x.c.a, x.c.b})
      if (moving(b)) {
        root[static_cast<size_t>(b)] = b;
        part[static_cast<size_t>(b)] = -1;
      }
  for (const LevelContact& x : lc) {
    if (!moving(x.c.a) || !moving(x.c.b)) continue;
    const int ra = find(x.c.a), rb = find(x.c.b);
    if (ra != rb) root[static_cast<size_t>(std::max(ra, rb))] = std::min(ra, rb);
  }
  // Parts numbered by their first group; counted, then filled in lc order.
  w.key.resize(lc.size());
  w.partStart.assign(1, 0);
  for (size_t k = 0; k < lc.size(); ++k) {
    const int r = find(moving(lc[k].c.a) ? lc[k].c.a : lc[k].c.b);
    int& p = part[static_cast<size_t>(r)];
    if (p < 0) {
      p = static_cast<int>(w.partStart.size()) - 1;
      w.partStart.push_back(0);
    }
    w.key[k] = static_cast<uint32_t>(p);
    ++w.partStart[static_cast<size_t>(p) + 1];
  }
  for (size_t p = 1; p < w.partStart.size(); ++p) w.partStart[p] += w.partStart[p - 1];
  w.fill.assign(w.partStart.begin(), w.partStart.end() - 1);
  w.order.resize(lc.size());
  for (size_t k = 0; k < lc.size(); ++k) w.order[w.fill[w.key[k]]++] = static_cast<uint32_t>(k);
}

// A body on one frozen support, its only group on the level: the support's patch impulse, where it can act
// whole, leaves the body no motion relative to the support (the patch solve's six targets: the point's
// velocity, no relative tilt, no relative twist). Here that impulse is found from the body's own mass and
// inertia (its velocities set to follow the support rigidly) instead of the patch's Schur complement, and
// checked as patchImpulse checks its own: a push (jn > 0), friction within mu jn, the twist within torsional
// friction, the centre of pressure inside the patch, no energy gained. False where any fails, or where the
// patch is flat: the patch solve decides then. Where the pair does not approach, no impulse (as the patch
// solve's). (J, T) in the pair's convention: J and T on b, -J and -T on a.
bool followSupport(const StepContext& ctx, const LevelContact& x, glm::dvec3& J, glm::dvec3& T) {
  const PatchExtent& e = x.patch.patch;
  if (e.flat()) return false;
  const Contact& c = x.c;
  const glm::dvec3 u = ctx.relativeVelocity(c.a, c.b, x.l), omega = ctx.relativeSpin(c.a, c.b);
  if (!(glm::dot(u, c.normal) < 0)) {
    J = T = glm::dvec3(0);
    return true;
  }
  const bool movesB = ctx.frozen[static_cast<size_t>(c.b)] == 0;
  const int mi = movesB ? c.b : c.a, fi = movesB ? c.a : c.b;
  const RigidBody& m = ctx.body(mi);
  const RigidBody& f = ctx.body(fi);
  const glm::dvec3& rm = movesB ? x.l.rb : x.l.ra;
  const glm::dvec3& rf = movesB ? x.l.ra : x.l.rb;
  // The body's velocities following the support: the same spin, the same velocity at the point.
  const glm::dvec3 dv = f.v + glm::cross(f.w, rf - rm) - m.v, dw = f.w - m.w;
  const glm::dmat3 R = ctx.invInertiaNow ? ctx.rotation[static_cast<size_t>(mi)] : m.rotation();
  const glm::dvec3 onM = m.mass * dv,
                   angular = m.angularMomentumAt(R, dw);  // the impulse on the body, about its centre
  J = movesB ? onM : -onM;
  T = movesB ? angular - glm::cross(rm, J) : -angular - glm::cross(rm, J);
  const glm::dvec3& n = c.normal;
  const double jn = glm::dot(J, n);
  if (!(jn > 0) || !(glm::length(J - jn * n) <= x.mu * jn)) return false;
  const double y0 = glm::dot(T, e.t1), y1 = glm::dot(T, e.t2), y2 = glm::dot(T, n);
  if (!(std::abs(y2) <= x.mu * jn * e.twistRadius())) return false;
  // The centre of pressure's offset, n x T / jn = (-y1 t1 + y0 t2) / jn, inside the patch.
  const double num[2] = {-y1, y0}, lo[2] = {e.lo1, e.lo2}, hi[2] = {e.hi1, e.hi2};
  for (int k = 0; k < 2; ++k) {
    const double bound = num[k] > 0 ? hi[k] : lo[k];
    if (num[k] != 0 && !(std::abs(num[k]) <= std::abs(bound) * jn)) return false;
  }
  // The kinetic energy of the relative motion changes by half of J.u + T.omega (the targets met exactly).
  const double ju = glm::dot(J, u), tw = glm::dot(T, omega);
  return 0.5 * (ju + tw) <= 1e-12 * (std::abs(ju) + std::abs(tw)) + 1e-15;
}

// Jacobi passes: every group's impulse from the same velocities, each body
// taking the mean of its groups' (a body on two supports follows neither
// alone: in order, the last one processed would win). Part by part (levelParts:
// they share no body that moves), each until a
// pass changes no group's relative velocity by more than shockTolerance, at
// most shockPasses: a box on the box below settles in one pass (where its
// support's patch impulse holds it whole, nothing is left for a second to
// confirm), two cards leaning on each other need a few dozen (the mean halves
// what each gets).
void jacobiPasses(StepContext& ctx, std::vector<LevelContact>& lc, const std::vector<int>& share,
                  const IslandScratch& w, std::vector<glm::dvec3>& dj, std::vector<glm::dvec3>& dt) {
  dj.resize(lc.size());
  dt.resize(lc.size());
  const double tolerance = ctx.settings.shockTolerance;
  auto apply = [&](size_t k, int m) {
    const Contact& c = lc[k].c;
    if (glm::dot(dj[k], dj[k]) > 0) {
      ctx.applyImpulse(c.a, c.b, lc[k].l, dj[k] / double(m));
      const double push = glm::dot(dj[k], c.normal) / double(m);
      ctx.shockPush[lc[k].pair] += push;
      // A frozen dynamic body (of this island: level 0 is shared and never written) takes it whole.
      for (int f : {c.a, c.b})
        if (ctx.frozen[static_cast<size_t>(f)] && ctx.level[static_cast<size_t>(f)] >= 1)
          ctx.shockAbsorbed[static_cast<size_t>(f)] += push;
    }
    if (glm::dot(dt[k], dt[k]) > 0) ctx.applyTorqueImpulse(c.a, c.b, dt[k] / double(m));
  };
  for (size_t p = 0; p + 1 < w.partStart.size(); ++p) {
    const uint32_t* begin = w.order.data() + w.partStart[p];
    const uint32_t* end = w.order.data() + w.partStart[p + 1];
    if (lc[*begin].follows) {  // (a part of its own: one group, m is 1)
      LevelContact& x = lc[*begin];
      if (followSupport(ctx, x, dj[*begin], dt[*begin])) {
        apply(*begin, 1);
        continue;
      }
      setPatchMatrix(x.patch, x.sa, x.sb, withMatrix(x).m);
    }
    for (const uint32_t* i = begin; i != end; ++i) withMatrix(lc[*i]);
    // A part of one group whose first impulse met every target whole (m is 1) is settled: a second pass would
    // see only rounding.
    bool settled = false;
    for (int pass = 0; pass < ctx.settings.shockPasses && !settled; ++pass) {
      double change = 0;
      for (const uint32_t* i = begin; i != end; ++i) {
        const size_t k = *i;
        const Contact& c = lc[k].c;
        const glm::dvec3 u = ctx.relativeVelocity(c.a, c.b, lc[k].l);
        if (!patchImpulse(lc[k].patch, lc[k].m, u, ctx.relativeSpin(c.a, c.b), c.normal, 0.0, lc[k].mu, nullptr, dj[k],
                          dt[k], end - begin == 1 ? &settled : nullptr)) {
          dj[k] = frictionImpulse(lc[k].m, u, c.normal, 0.0, lc[k].mu);
          dt[k] = glm::dvec3(0);
        }
        change = std::max(change, glm::length(lc[k].m.K * dj[k]));
      }
      for (const uint32_t* i = begin; i != end; ++i) {
        const Contact& c = lc[*i].c;
        apply(*i, std::max({1, share[static_cast<size_t>(c.a)], share[static_cast<size_t>(c.b)]}));
      }
      if (!(change > tolerance)) break;
    }
  }
}

// Islands [k0, k1) (their pairs lie side by side in ctx.islandPairs), level by level: bodies of different
// islands share nothing, so each body's impulses come in its own island's pair order as over all pairs.
void shockIslands(StepContext& ctx, double h, size_t k0, size_t k1, uint32_t mark, IslandScratch& w, Scratch& s,
                  bool levelsHere) {
  std::vector<int>& share = s.share;
  std::vector<uint32_t>& stamp = s.stamp;
  if (levelsHere)
    islandLevels(ctx, ctx.islandPairs.data() + ctx.islandStart[k0], ctx.islandPairs.data() + ctx.islandStart[k1], mark,
                 w, s.seen, s.local);
  const std::vector<int>& level = ctx.level;
  auto pairLevel = [&](size_t pi) {
    const int la = level[static_cast<size_t>(ctx.pairs[pi].a)], lb = level[static_cast<size_t>(ctx.pairs[pi].b)];
    return std::min(la, lb) < 0 ? -1 : std::max(la, lb);
  };
  const uint32_t* first = ctx.islandPairs.data() + ctx.islandStart[k0];
  const uint32_t* last = ctx.islandPairs.data() + ctx.islandStart[k1];
  // Its pairs with groups by level, and its levelled dynamic bodies (each in some such pair) by level.
  int top = 0;
  for (const uint32_t* p = first; p != last; ++p)
    if (!ctx.groups[*p].empty()) top = std::max(top, pairLevel(*p));
  if (top < 1) return;
  const size_t levels = static_cast<size_t>(top) + 1;
  w.levelStart.assign(levels + 1, 0);
  w.bodyStart.assign(levels + 1, 0);
  auto levelled = [&](int b) {  // a dynamic body of this island not yet counted
    return level[static_cast<size_t>(b)] >= 1 && stamp[static_cast<size_t>(b)] != mark;
  };
  w.bodies.clear();
  w.bodyIsland.clear();
  w.driven.assign(k1 - k0, 0);
  for (const uint32_t* p = first; p != last; ++p) {
    if (ctx.groups[*p].empty() || pairLevel(*p) < 0) continue;
    ++w.levelStart[static_cast<size_t>(pairLevel(*p)) + 1];
    const size_t island = static_cast<size_t>(ctx.islandOfPair[*p]) - k0;
    for (int b : {ctx.pairs[*p].a, ctx.pairs[*p].b}) {
      if (ctx.body(b).kinematic && ctx.body(b).movable()) w.driven[island] = 1;
      if (levelled(b)) {
        stamp[static_cast<size_t>(b)] = mark;
        w.bodies.push_back(b);
        w.bodyIsland.push_back(static_cast<int>(island));
        ++w.bodyStart[static_cast<size_t>(level[static_cast<size_t>(b)]) + 1];
      }
    }
  }
  for (size_t l = 0; l < levels; ++l) {
    w.levelStart[l + 1] += w.levelStart[l];
    w.bodyStart[l + 1] += w.bodyStart[l];
  }
  w.pairs.resize(w.levelStart[levels]);
  std::vector<uint32_t>& fill = w.fill;
  fill.assign(w.levelStart.begin(), w.levelStart.end() - 1);
  for (const uint32_t* p = first; p != last; ++p)
    if (!ctx.groups[*p].empty() && pairLevel(*p) >= 0) w.pairs[fill[static_cast<size_t>(pairLevel(*p))]++] = *p;
  std::vector<int>& byLevel = w.byLevel;
  byLevel.resize(w.bodies.size());
  fill.assign(w.bodyStart.begin(), w.bodyStart.end() - 1);
  for (int b : w.bodies) byLevel[fill[static_cast<size_t>(level[static_cast<size_t>(b)])]++] = b;
  // The energy guard's "before", and its slack: resting contact's own scale, every body at the speed gravity adds
  // in the substep (the Jacobi passes' means move resting stacks by that much either way).
  w.velocities.resize(w.bodies.size());
  w.energyBefore.assign(k1 - k0, 0.0);
  w.slack.assign(k1 - k0, 0.0);
  for (size_t k = 0; k < w.bodies.size(); ++k) {
    const RigidBody& b = ctx.body(w.bodies[k]);
    w.velocities[k] = {b.v, b.w};
    w.energyBefore[static_cast<size_t>(w.bodyIsland[k])] += ctx.kineticEnergy(w.bodies[k]);
    w.slack[static_cast<size_t>(w.bodyIsland[k])] += ctx.restingSlack(b, h);
  }
  for (int l = 1; l <= top; ++l) {
    // Frozen: every level below this one (the one just below joins the frozen; level 0 always was).
    for (uint32_t k = w.bodyStart[static_cast<size_t>(l) - 1]; k < w.bodyStart[static_cast<size_t>(l)]; ++k)
      ctx.frozen[static_cast<size_t>(byLevel[k])] = 1;
    levelContacts(ctx, w.pairs.data() + w.levelStart[static_cast<size_t>(l)],
                  w.pairs.data() + w.levelStart[static_cast<size_t>(l) + 1], w.lc, share);
    supportPatches(ctx, share, w.lc, w.supports);
    levelParts(ctx, w.lc, s.root, s.part, w);
    jacobiPasses(ctx, w.lc, share, w, w.dj, w.dt);
    // (Level 0 bodies are shared by the islands and never counted: only this island's are written.)
    for (const LevelContact& x : w.lc)
      for (int b : {x.c.a, x.c.b})
        if (level[static_cast<size_t>(b)] >= 1) share[static_cast<size_t>(b)] = 0;
  }
  // A frozen body is moved as if nothing could stop it: a light body squeezed between the ground and a heavy one
  // leaves the contact step fast, and frozen it shoves the heavy one as a kinematic body would (a 439 kg plate
  // spinning onto a 64 g capsule gained 4 kJ a step). Without a kinematic body to drive it an island has no
  // source of energy here: where the passes raised its bodies' kinetic energy, they are undone.
  w.energyAfter.assign(k1 - k0, 0.0);
  for (size_t k = 0; k < w.bodies.size(); ++k)
    w.energyAfter[static_cast<size_t>(w.bodyIsland[k])] += ctx.kineticEnergy(w.bodies[k]);
  bool undone = false;
  for (size_t k = 0; k < w.bodies.size(); ++k) {
    const size_t island = static_cast<size_t>(w.bodyIsland[k]);
    if (w.driven[island] || !(w.energyAfter[island] > w.energyBefore[island] + w.slack[island])) continue;
    RigidBody& b = ctx.body(w.bodies[k]);
    b.v = w.velocities[k].first;
    b.w = w.velocities[k].second;
    ctx.shockAbsorbed[static_cast<size_t>(w.bodies[k])] = 0;
    undone = true;
  }
  // (An island undone pushed nothing apart.)
  if (undone)
    for (const uint32_t* p = first; p != last; ++p) {
      const size_t island = static_cast<size_t>(ctx.islandOfPair[*p]) - k0;
      if (!w.driven[island] && w.energyAfter[island] > w.energyBefore[island] + w.slack[island]) ctx.shockPush[*p] = 0;
    }
}

}  // namespace

void shockPropagation(StepContext& ctx, double h, bool flat) {
  ctx.shockPush.assign(ctx.pairs.size(), 0.0);
  ctx.shockAbsorbed.assign(ctx.bodies.size(), 0.0);
  if (ctx.settings.shockPasses <= 0) return;
  const size_t n = ctx.bodies.size();
  Scratch& s = scratch();
  // With joints the levels are found over all bodies (a joined unit can span islands); without, each run of
  // islands finds its own (islandLevels) on its thread.
  const bool levelsHere = ctx.joints.empty() && !flat;
  if (levelsHere) {
    ctx.level.resize(n);
    s.local.resize(n);
    s.seen.resize(n);
  } else {
    computeLevels(ctx, s, flat);
  }
  s.share.resize(n);
  s.stamp.resize(n);
  s.root.resize(n);
  s.part.resize(n);
  // Level 0 (static, kinematic and sleeping bodies, shared by islands) is frozen before the islands start.
  ctx.parallelRange(n, ctx.grainFor(n, 1024), [&](size_t begin, size_t end, int) {
    for (size_t i = begin; i < end; ++i) {
      if (levelsHere) ctx.level[i] = ctx.bodies[i].dynamic() ? -1 : 0;
      ctx.frozen[i] = ctx.level[i] == 0;
      s.share[i] = 0;
      s.stamp[i] = 0;
      if (levelsHere) s.seen[i] = 0;
    }
  });
  s.islands.resize(static_cast<size_t>(ctx.workers()));
  // Runs of whole islands (a pile's columns are islands of a few pairs: one at a time, the per-level work
  // of each cost more than its impulses).
  ctx.forEachIslandRun(256, [&](size_t first, size_t last, size_t run, int worker) {
    shockIslands(ctx, h, first, last, static_cast<uint32_t>(run) + 1, s.islands[static_cast<size_t>(worker)], s,
                 levelsHere);
  });
  ctx.parallelRange(n, ctx.grainFor(n, 1024), [&](size_t begin, size_t end, int) { std::fill(&ctx.frozen[begin], &ctx.frozen[end - 1] + 1, 0); });
}

}  // namespace crumple::detail
