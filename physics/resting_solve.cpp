// Small islands solved to convergence (the end of the contact step).
//
// Guarantees:
// - restingSolve: for each island of dynamic bodies joined by contact groups
//   (no joints, at most settings.restingSolveRows rows: 3 per group, plus one
//   per axis its patch can hold a torque about) that holds a convex mesh block
//   or a plate (loadBearing) and that the contact step left approaching faster than restingSolveTrigger
//   somewhere (or that was solved the substep before), the contact step's velocities
//   are replaced by those of a projected Gauss-Seidel solve of the same groups
//   (Catto's sequential impulses: accumulated totals, each clamped to what the
//   contact can give: a push, Coulomb's cone, the centre of pressure inside the
//   patch, the twist within torsional friction), begun from the velocities the
//   contact step began with plus last substep's totals of the same groups
//   (matched by pair and normal: a warm start), and swept back and forth until no row's velocity
//   changes by more than restingSolveTolerance. Its totals become the groups'
//   totals. An island not converged within restingSolveIterations sweeps
//   (its last sweep changed a row's velocity by more than 10 x the tolerance)
//   keeps the contact step's velocities (stiff mass ratios converge slowly), as
//   does one that ends with more kinetic energy than the island began with
//   (beyond every body at g h; its totals are not kept for the warm start).
// Why: the contact step's passes are a few sweeps, enough for a stack whose
// load goes straight down, not for a ring: an arch carries each voussoir's
// weight round to both springings, and with ten passes a residual approach
// is left every step and the crown sags without end; cards leaning on each
// other carry their loads sideways too (a house of two storeys spread and fell
// in 5 s). Iterating to convergence costs little on a small island.
#include <algorithm>
#include <cmath>

#include <crumple/physics/disjoint_sets.h>
#include <crumple/physics/step_context.h>

namespace crumple::detail {

namespace {

struct Slot {
  int body = -1;
  bool dof = false;          // a dynamic body (its velocities change)
  glm::dvec3 jl{0}, ja{0};   // Jacobian: linear, angular
  glm::dvec3 ml{0}, ma{0};   // M^-1 J^T
};
struct Row {
  size_t group;  // index into the island's group list
  int kind;      // 0 normal, 1 t1, 2 t2, 3 torque t1, 4 torque t2, 5 twist
  Slot s[2];
};
struct IslandGroup {
  size_t pair, index;
  int rowStart = 0, rows = 0;
  bool torque1 = false, torque2 = false, twist = false;
  double mu = 0, twistRadius = 0;
};

uint64_t pairKey(const Pair& p) { return static_cast<uint64_t>(p.a) << 32 | static_cast<uint32_t>(p.b); }

// One worker's solve of the islands it is handed (restingSolve shares them out): its scratch, and the warm-start
// totals and solve count it leaves for the merge. An island writes only its own bodies and groups.
struct alignas(64) IslandSolver {  // (a cache line of its own per worker)
  StepContext* ctx = nullptr;
  const std::vector<glm::dvec3>* v0 = nullptr;
  const std::vector<glm::dvec3>* w0 = nullptr;
  const std::vector<RestingWarm>* previous = nullptr;  // last substep's totals, by pair key
  double h = 0;                                        // the substep
  std::vector<IslandGroup> groups;
  std::vector<Row> rows;
  std::vector<double> lambda, diag;
  std::vector<std::pair<int, std::pair<glm::dvec3, glm::dvec3>>> kept;
  std::vector<RestingWarm> warm;
  int solves = 0;

  // The first of last substep's groups of pair key pk.
  std::vector<RestingWarm>::const_iterator firstWarm(uint64_t pk) const {
    return std::lower_bound(previous->begin(), previous->end(), pk,
                            [](const RestingWarm& x, uint64_t k2) { return x.key < k2; });
  }
  void solve(const size_t* pairs, size_t count);
  bool needed(const size_t* pairs, size_t count) const;
  void buildRows(const size_t* pairs, size_t count);
  void startFromContactStep();
  void warmStart();
  bool sweep(double& largest);
  void keepWarm();
  // The kinetic energy of the island's dynamic bodies now (each once), and resting contact's scale of it (`slack`,
  // set with the bodies: every body at g h).
  std::vector<int> islandBodies;
  double slack = 0;
  double islandEnergy() const {
    double e = 0;
    for (int i : islandBodies) e += ctx->kineticEnergy(i);
    return e;
  }
  void apply(const Row& row, double d) {
    for (const Slot& s : row.s)
      if (s.dof) {
        RigidBody& b = ctx->body(s.body);
        b.v += d * s.ml;
        b.w += d * s.ma;
      }
  }
};

}  // namespace

bool loadBearing(const Shape& shape) {
  if (shape.type == ShapeType::Mesh) return shape.polytope != nullptr;
  if (shape.type != ShapeType::Box) return false;
  glm::dvec3 e = shape.halfExtents;
  if (e.x > e.y) std::swap(e.x, e.y);
  if (e.y > e.z) std::swap(e.y, e.z);
  if (e.x > e.y) std::swap(e.x, e.y);
  return e.x <= 0.25 * e.y;
}

namespace {

// Solves one island (its pairs with groups, in pair order) when it needs it, as restingSolve says.
void IslandSolver::solve(const size_t* pairs, size_t count) {
  groups.clear();
  rows.clear();
  if (!needed(pairs, count)) return;
  buildRows(pairs, count);
  startFromContactStep();
  const double before = islandEnergy();
  warmStart();
  double largest = 0;
  bool converged = sweep(largest);
  // Contact takes energy away: a solve that hands the island more than it began with (beyond resting contact's
  // own scale, every body at g h) went wrong (a 0.14 kg plate against a 634 kg disc spinning at 77 rad/s: its
  // totals grew a hundredfold a substep through the warm start, to 1e6 m/s), and the contact step's result
  // stands, its totals forgotten.
  const bool gained = islandEnergy() > before + slack;
  if (!gained) keepWarm();
  // Out of sweeps: a solve whose last sweep still changed no row's velocity by more than ten times the
  // tolerance is taken (a house of cards of three storeys, while its upper cards land, takes 1000-2000
  // sweeps; the contact step's result instead let its lower frames slide apart). Stiff mass ratios (a heavy
  // body on a light one) converge slowly and may be far from it: there the contact step's result stands.
  if (!converged && largest < 10 * ctx->settings.restingSolveTolerance) converged = true;
  if (gained) converged = false;
  if (!converged) {
    for (auto it = kept.rbegin(); it != kept.rend(); ++it) {
      ctx->body(it->first).v = it->second.first;
      ctx->body(it->first).w = it->second.second;
    }
    return;
  }
  ++solves;
  for (const IslandGroup& ig : groups) {
    ContactGroup& g = ctx->groups[ig.pair][ig.index];
    const double* lam = &lambda[static_cast<size_t>(ig.rowStart)];
    g.totals.normal = lam[0];
    g.totals.tangential = lam[1] * g.patchMatrix.patch.t1 + lam[2] * g.patchMatrix.patch.t2;
  }
}

// Solved when the contact step left an approach at one of its groups, or when it was solved last substep, and
// only islands with a convex mesh block (masonry: arches, walls of cut stone) or a plate (cards). Piles of cubes
// and bricks keep the contact step's result: there the projected Gauss-Seidel sweeps did not converge within a
// few hundred sweeps (many redundant face rows; the 1000-box pile went from 2 to 75 ms a step), and the contact
// step with shock propagation holds them.
bool IslandSolver::needed(const size_t* pairs, size_t count) const {
  bool bearing = false;
  for (size_t k = 0; k < count && !bearing; ++k) {
    const Pair& pair = ctx->pairs[pairs[k]];
    for (int i : {pair.a, pair.b}) bearing = bearing || (ctx->body(i).dynamic() && loadBearing(*ctx->body(i).shape));
  }
  if (!bearing) return false;
  for (size_t k = 0; k < count; ++k) {
    const size_t pi = pairs[k];
    const uint64_t pk = pairKey(ctx->pairs[pi]);
    const auto w = firstWarm(pk);
    if (w != previous->end() && w->key == pk) return true;
    for (const ContactGroup& g : ctx->groups[pi])
      if (glm::dot(ctx->relativeVelocity(g.contact.a, g.contact.b, g.levers), g.contact.normal) <
          -ctx->settings.restingSolveTrigger)
        return true;
  }
  return false;
}

// Per group: a normal row, two friction rows, a torque row about each axis its patch can hold one about, and a
// twist row when it holds either.
void IslandSolver::buildRows(const size_t* pairs, size_t count) {
  for (size_t k = 0; k < count; ++k) {
    const size_t pi = pairs[k];
    for (size_t gi = 0; gi < ctx->groups[pi].size(); ++gi) {
      const ContactGroup& g = ctx->groups[pi][gi];
      const PatchExtent& e = g.patchMatrix.patch;
      IslandGroup ig{pi, gi};
      // Torque about t2 moves the centre of pressure along t1 (and the reverse).
      ig.torque2 = e.hi1 - e.lo1 > 1e-6;
      ig.torque1 = e.hi2 - e.lo2 > 1e-6;
      ig.mu = std::sqrt(ctx->body(g.contact.a).friction * ctx->body(g.contact.b).friction);
      ig.twistRadius = e.twistRadius();
      ig.twist = ig.torque1 || ig.torque2;
      ig.rowStart = static_cast<int>(rows.size());
      const Contact& c = g.contact;
      const glm::dvec3 dirs[6] = {e.n, e.t1, e.t2, e.t1, e.t2, e.n};
      for (int kind = 0; kind < 6; ++kind) {
        if ((kind == 3 && !ig.torque1) || (kind == 4 && !ig.torque2) || (kind == 5 && !ig.twist)) continue;
        Row row;
        row.group = groups.size();
        row.kind = kind;
        const glm::dvec3& d = dirs[kind];
        for (int side = 0; side < 2; ++side) {
          Slot& s = row.s[side];
          s.body = side ? c.b : c.a;
          const RigidBody& body = ctx->body(s.body);
          s.dof = body.dynamic();
          const double sign = side ? 1.0 : -1.0;
          const glm::dvec3& r = side ? g.levers.rb : g.levers.ra;
          if (kind < 3) {
            s.jl = sign * d;
            s.ja = sign * glm::cross(r, d);
          } else {
            s.ja = sign * d;
          }
          if (s.dof) {
            s.ml = body.invMass * s.jl;
            s.ma = ctx->invInertia[static_cast<size_t>(s.body)] * s.ja;
          }
        }
        rows.push_back(row);
      }
      ig.rows = static_cast<int>(rows.size()) - ig.rowStart;
      groups.push_back(ig);
    }
  }
}

// The totals at zero and the rows' diagonals; the island's bodies back at the velocities the contact step began
// with (its own result kept, in case the solve does not converge).
void IslandSolver::startFromContactStep() {
  const size_t m = rows.size();
  lambda.assign(m, 0.0);
  diag.assign(m, 0.0);
  for (size_t r = 0; r < m; ++r)
    for (const Slot& s : rows[r].s)
      if (s.dof) diag[r] += glm::dot(s.jl, s.ml) + glm::dot(s.ja, s.ma);
  kept.clear();
  islandBodies.clear();
  for (const Row& row : rows)
    for (const Slot& s : row.s)
      if (s.dof) {
        RigidBody& b = ctx->body(s.body);
        kept.push_back({s.body, {b.v, b.w}});
        islandBodies.push_back(s.body);
        b.v = (*v0)[static_cast<size_t>(s.body)];
        b.w = (*w0)[static_cast<size_t>(s.body)];
      }
  std::sort(islandBodies.begin(), islandBodies.end());
  islandBodies.erase(std::unique(islandBodies.begin(), islandBodies.end()), islandBodies.end());
  slack = 0;
  for (int i : islandBodies) slack += ctx->restingSlack(ctx->body(i), h);
}

// Warm start: the totals of the group of last substep whose normal agrees best (same pair), in this group's rows,
// clamped to this group's limits.
void IslandSolver::warmStart() {
  for (const IslandGroup& ig : groups) {
    const ContactGroup& g = ctx->groups[ig.pair][ig.index];
    const PatchExtent& e = g.patchMatrix.patch;
    const bool ab = g.contact.a == ctx->pairs[ig.pair].a;
    const glm::dvec3 nAB = ab ? e.n : -e.n;
    const uint64_t pk = pairKey(ctx->pairs[ig.pair]);
    const RestingWarm* best = nullptr;
    double bestDot = 0.95;
    for (auto w = firstWarm(pk); w != previous->end() && w->key == pk; ++w) {
      const double d = glm::dot(w->normal, nAB);
      if (d > bestDot) {
        bestDot = d;
        best = &*w;
      }
    }
    if (!best) continue;
    const glm::dvec3 J = ab ? best->impulse : -best->impulse, T = ab ? best->torque : -best->torque;
    const double jn = std::max(0.0, glm::dot(J, e.n));
    for (int k = 0; k < ig.rows; ++k) {
      const size_t r = static_cast<size_t>(ig.rowStart + k);
      double value = 0, limit = 0;
      switch (rows[r].kind) {
        case 0:
          value = jn;
          limit = 1e300;
          break;
        case 1:
          value = glm::dot(J, e.t1);
          limit = ig.mu * jn / std::sqrt(2.0);
          break;
        case 2:
          value = glm::dot(J, e.t2);
          limit = ig.mu * jn / std::sqrt(2.0);
          break;
        case 3:
          value = std::clamp(glm::dot(T, e.t1), e.lo2 * jn, e.hi2 * jn);
          limit = 1e300;
          break;
        case 4:
          value = std::clamp(glm::dot(T, e.t2), -e.hi1 * jn, -e.lo1 * jn);
          limit = 1e300;
          break;
        default:
          value = glm::dot(T, e.n);
          limit = ig.mu * jn * ig.twistRadius;
      }
      value = std::clamp(value, -limit, limit);
      lambda[r] = value;
      apply(rows[r], value);
    }
  }
}

// Sequential impulses with accumulated, projected totals (projected Gauss-Seidel) over the island's rows, in
// alternating sweeps until no row changes its velocity by more than the tolerance. Whether it converged; the last
// sweep's largest change in `largest`.
bool IslandSolver::sweep(double& largest) {
  const size_t m = rows.size();
  const double tolerance = ctx->settings.restingSolveTolerance;
  const int iterations = std::max(1, ctx->settings.restingSolveIterations);
  bool converged = false;
  largest = 0;
  for (int it = 0; it < iterations && !converged; ++it) {
    largest = 0;
    for (size_t k = 0; k < m; ++k) {
      const size_t r = it % 2 ? m - 1 - k : k;
      const Row& row = rows[r];
      if (!(diag[r] > 0)) continue;
      const IslandGroup& ig = groups[row.group];
      const ContactGroup& g = ctx->groups[ig.pair][ig.index];
      const PatchExtent& e = g.patchMatrix.patch;
      double u = 0;
      for (const Slot& s : row.s) {
        const RigidBody& b = ctx->body(s.body);
        u += glm::dot(s.jl, b.v) + glm::dot(s.ja, b.w);
      }
      const double jn = lambda[static_cast<size_t>(ig.rowStart)];
      double lo = -1e300, hi = 1e300;
      switch (row.kind) {
        case 0:
          lo = 0;
          break;
        case 1:
        case 2:
          hi = ig.mu * jn;
          lo = -hi;
          break;
        case 3:  // the centre of pressure T1 / jn along t2
          lo = e.lo2 * jn;
          hi = e.hi2 * jn;
          break;
        case 4:  // -T2 / jn along t1
          lo = -e.hi1 * jn;
          hi = -e.lo1 * jn;
          break;
        default:  // twist
          hi = ig.mu * jn * ig.twistRadius;
          lo = -hi;
      }
      const double next = std::clamp(lambda[r] - u / diag[r], lo, hi);
      const double d = next - lambda[r];
      if (d != 0) {
        apply(row, d);
        lambda[r] = next;
        largest = std::max(largest, std::abs(d) * diag[r]);
      }
      if (row.kind == 2) {
        // Coulomb's cone is round: the two friction rows together within mu jn.
        const size_t r1 = r - 1;
        const double t = std::hypot(lambda[r1], lambda[r]), limit = ig.mu * jn;
        if (t > limit) {
          const double f = limit / t;
          apply(rows[r1], lambda[r1] * f - lambda[r1]);
          apply(row, lambda[r] * f - lambda[r]);
          lambda[r1] *= f;
          lambda[r] *= f;
        }
      }
    }
    converged = largest < tolerance;
  }
  return converged;
}

// Each group's totals (linear and angular, in pair order a-to-b) for the next substep's warm start.
void IslandSolver::keepWarm() {
  for (const IslandGroup& ig : groups) {
    const ContactGroup& g = ctx->groups[ig.pair][ig.index];
    const PatchExtent& e = g.patchMatrix.patch;
    const bool ab = g.contact.a == ctx->pairs[ig.pair].a;
    glm::dvec3 J(0), T(0);
    for (int k = 0; k < ig.rows; ++k) {
      const size_t r = static_cast<size_t>(ig.rowStart + k);
      const glm::dvec3 axes[6] = {e.n, e.t1, e.t2, e.t1, e.t2, e.n};
      (rows[r].kind < 3 ? J : T) += lambda[r] * axes[rows[r].kind];
    }
    warm.push_back({pairKey(ctx->pairs[ig.pair]), ab ? e.n : -e.n, ab ? J : -J, ab ? T : -T});
  }
}

}  // namespace

void restingSolve(StepContext& ctx, const std::vector<glm::dvec3>& v0, const std::vector<glm::dvec3>& w0,
                  double h) {
  const int maxRows = ctx.settings.restingSolveRows;
  if (maxRows <= 0) return;
  if (!ctx.anyLoadBearing) {
    // Only islands holding a block or a plate are solved (below), and there is none: no totals to keep.
    ctx.restingWarm.clear();
    return;
  }
  const size_t nb = ctx.bodies.size();
  // Islands of dynamic bodies through the pairs that have groups.
  DisjointSets sets;
  sets.reset(nb);
  std::vector<char> joined(nb, 0);
  for (const Joint& j : ctx.joints) {
    if (j.removed || j.broken) continue;
    if (j.def.a >= 0) joined[static_cast<size_t>(j.def.a)] = 1;
    if (j.def.b >= 0) joined[static_cast<size_t>(j.def.b)] = 1;
  }
  auto dyn = [&](int i) { return ctx.body(i).dynamic(); };
  bool anyGroup = false;
  for (size_t pi = 0; pi < ctx.pairs.size() && pi < ctx.groups.size(); ++pi) {
    if (ctx.groups[pi].empty()) continue;
    anyGroup = true;
    const int a = ctx.pairs[pi].a, b = ctx.pairs[pi].b;
    if (dyn(a) && dyn(b)) sets.unite(a, b);
  }
  if (!anyGroup) {
    ctx.restingWarm.clear();
    return;
  }
  // Each island's groups, in pair order; an island with a joint or too many rows is left alone.
  std::vector<int> rowCount(nb, 0);
  std::vector<char> skip(nb, 0);
  auto rootOf = [&](size_t pi) {
    const int a = ctx.pairs[pi].a, b = ctx.pairs[pi].b;
    return sets.find(dyn(a) ? a : b);
  };
  for (size_t pi = 0; pi < ctx.pairs.size() && pi < ctx.groups.size(); ++pi) {
    if (ctx.groups[pi].empty()) continue;
    const int a = ctx.pairs[pi].a, b = ctx.pairs[pi].b;
    if (!dyn(a) && !dyn(b)) continue;
    const size_t r = static_cast<size_t>(rootOf(pi));
    rowCount[r] += 6 * static_cast<int>(ctx.groups[pi].size());
    if ((dyn(a) && joined[static_cast<size_t>(a)]) || (dyn(b) && joined[static_cast<size_t>(b)])) skip[r] = 1;
  }
  // The pairs of each island, in pair order (a counting sort by root).
  std::vector<int> first(nb + 1, 0);
  std::vector<size_t> islandPairs;
  for (size_t pi = 0; pi < ctx.pairs.size() && pi < ctx.groups.size(); ++pi)
    if (!ctx.groups[pi].empty() && (dyn(ctx.pairs[pi].a) || dyn(ctx.pairs[pi].b)))
      ++first[static_cast<size_t>(rootOf(pi)) + 1];
  for (size_t i = 0; i < nb; ++i) first[i + 1] += first[i];
  islandPairs.resize(static_cast<size_t>(first[nb]));
  {
    std::vector<int> at(first.begin(), first.end() - 1);
    for (size_t pi = 0; pi < ctx.pairs.size() && pi < ctx.groups.size(); ++pi)
      if (!ctx.groups[pi].empty() && (dyn(ctx.pairs[pi].a) || dyn(ctx.pairs[pi].b)))
        islandPairs[static_cast<size_t>(at[static_cast<size_t>(rootOf(pi))]++)] = pi;
  }
  // Last substep's totals (warm start), by pair key.
  std::vector<RestingWarm> previous;
  previous.swap(ctx.restingWarm);
  ctx.restingWarm.clear();
  // Each island on its own (in parallel on the World's threads); the workers' warm-start lists are merged by key
  // (a pair's groups all come from one island, in their order).
  std::vector<IslandSolver> work(static_cast<size_t>(ctx.workers()));
  for (IslandSolver& wk : work) {
    wk.ctx = &ctx;
    wk.v0 = &v0;
    wk.w0 = &w0;
    wk.previous = &previous;
    wk.h = h;
  }
  std::vector<size_t> roots;
  for (size_t root = 0; root < nb; ++root)
    if (rowCount[root] != 0 && !skip[root] && rowCount[root] <= maxRows) roots.push_back(root);
  ctx.parallel(roots.size(), [&](size_t item, int worker) {
    const size_t root = roots[item];
    work[static_cast<size_t>(worker)].solve(islandPairs.data() + first[root],
                                            static_cast<size_t>(first[root + 1] - first[root]));
  });
  for (IslandSolver& wk : work) {
    ctx.restingWarm.insert(ctx.restingWarm.end(), wk.warm.begin(), wk.warm.end());
    ctx.stats.restingSolves += wk.solves;
  }
  std::stable_sort(ctx.restingWarm.begin(), ctx.restingWarm.end(),
                   [](const RestingWarm& x, const RestingWarm& y) { return x.key < y.key; });
}

}  // namespace crumple::detail
