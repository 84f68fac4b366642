// The direct solve of all joints at once over the joint graph (physics/joint_solver.h; the guarantees are
// joint_step.cpp's).
#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <type_traits>
#include <utility>

#include <crumple/physics/disjoint_sets.h>
#include <crumple/physics/joint_solver.h>

namespace crumple::detail {

JointSolverCache::JointSolverCache() = default;
JointSolverCache::JointSolverCache(const JointSolverCache&) {}
JointSolverCache& JointSolverCache::operator=(const JointSolverCache& o) {
  if (this != &o) system.reset();
  return *this;
}
JointSolverCache::~JointSolverCache() = default;

namespace joints {

namespace {

// The symmetric (pseudo-)inverse of the n x n positive semi-definite matrix a
// (LDL^T without pivoting). A pivot that is not above 1e-9 of the row's own
// diagonal before any elimination (`scale`: what is left of it is rounding, the
// row repeats others) is dropped: that row gets lambda 0. Reads a's lower triangle only.
template <int n>
void pseudoInverseN(const Block& a, const double* scale, Block& inv) {
  double L[n][n] = {}, d[n] = {}, invd[n] = {};
  for (int k = 0; k < n; ++k) {
    double dk = a.m[k][k];
    for (int j = 0; j < k; ++j) dk -= L[k][j] * L[k][j] * d[j];
    const bool dead = !(dk > 1e-9 * scale[k]) || !(scale[k] > 0);
    d[k] = dead ? 0 : dk;
    invd[k] = dead ? 0 : 1 / dk;
    L[k][k] = 1;
    for (int i = k + 1; i < n; ++i) {
      if (dead) {
        L[i][k] = 0;
        continue;
      }
      double s = a.m[i][k];
      for (int j = 0; j < k; ++j) s -= L[i][j] * L[k][j] * d[j];
      L[i][k] = s / dk;
    }
  }
  // inv = L^-T diag(invd) L^-1, column by column.
  for (int c = 0; c < n; ++c) {
    double y[n];
    for (int i = 0; i < n; ++i) {
      double s = i == c ? 1.0 : 0.0;
      for (int j = 0; j < i; ++j) s -= L[i][j] * y[j];
      y[i] = s;
    }
    for (int i = 0; i < n; ++i) y[i] *= invd[i];
    for (int i = n - 1; i >= 0; --i) {
      double s = y[i];
      for (int j = i + 1; j < n; ++j) s -= L[j][i] * y[j];
      y[i] = s;
    }
    for (int i = 0; i < n; ++i) inv.m[i][c] = y[i];
  }
}

// Calls f(std::integral_constant<int, n>) for n in 1..6 (0: nothing), so that the small dense loops below are
// unrolled for each row count.
template <class F, int... N>
void withSizeIn(int n, F&& f, std::integer_sequence<int, N...>) {
  (void)((n == N + 1 && (f(std::integral_constant<int, N + 1>{}), true)) || ...);
}
template <class F>
void withSize(int n, F&& f) {
  withSizeIn(n, f, std::make_integer_sequence<int, 6>{});
}

// out (np x nq) = inv (np x np) * off (np x nq).
template <int np, int nq>
void leftMultiply(const Block& inv, const Block& off, Block& out) {
  for (int i = 0; i < np; ++i)
    for (int c = 0; c < nq; ++c) {
      double v = 0;
      for (int k = 0; k < np; ++k) v += inv.m[i][k] * off.m[k][c];
      out.m[i][c] = v;
    }
}

// target (nq x nr) -= a^T b, a: np x nq, b: np x nr; where `lower`, only its lower triangle (c <= i).
template <int np, int nq, int nr>
void subtractProduct(const Block& a, const Block& b, Block& target, bool lower) {
  for (int i = 0; i < nq; ++i)
    for (int c = 0; c < (lower ? i + 1 : nr); ++c) {
      double v = 0;
      for (int k = 0; k < np; ++k) v += a.m[k][i] * b.m[k][c];
      target.m[i][c] -= v;
    }
}

// What identifies a system: its active joints in order, each with which of its ends are dynamic.
int endsCode(const StepContext& ctx, const Joint& jt) {
  return (jt.def.a >= 0 && ctx.body(jt.def.a).dynamic() ? 1 : 0) | (ctx.body(jt.def.b).dynamic() ? 2 : 0);
}

// True when `s` is this call's system (compared in place: no vector built when it is the same).
bool sameSystem(const StepContext& ctx, const JointSystem& s) {
  size_t at = 0;
  bool same = true;
  for (size_t i = 0; i < ctx.joints.size() && same; ++i) {
    const Joint& jt = ctx.joints[i];
    if (!active(ctx, jt)) continue;
    same = at + 1 < s.signature.size() && s.signature[at] == static_cast<int>(i) &&
           s.signature[at + 1] == endsCode(ctx, jt);
    at += 2;
  }
  return same && at == s.signature.size();
}

// The active joints (ids, and their ends' slots), each body given its slot (side) on first use; the signature.
void collectJoints(const StepContext& ctx, JointSystem& s, std::vector<int>& ids,
                   std::vector<std::pair<int, int>>& ends) {
  s.signature.clear();
  s.conditional = false;
  s.slot.assign(ctx.bodies.size(), -1);
  s.sides.assign(1, Side{});
  s.joints.clear();
  s.ends.clear();
  s.loops.clear();
  s.loopEnds.clear();
  s.onBody.assign(1, {});
  auto slotOf = [&](int body) {
    if (body < 0) return 0;
    int& k = s.slot[static_cast<size_t>(body)];
    if (k < 0) {
      k = static_cast<int>(s.sides.size());
      s.sides.push_back(sideAt(ctx, body));
      s.onBody.emplace_back();
    }
    return k;
  };
  for (size_t i = 0; i < ctx.joints.size(); ++i) {
    const Joint& jt = ctx.joints[i];
    if (!active(ctx, jt)) continue;
    s.signature.push_back(static_cast<int>(i));
    s.signature.push_back(endsCode(ctx, jt));
    const int sa = slotOf(jt.def.a), sb = slotOf(jt.def.b);
    ids.push_back(static_cast<int>(i));
    ends.emplace_back(sa, sb);
  }
}

// A spanning forest over the bodies (what cannot move counting as one): the joints taken strongest first (most
// rows: a weld, then a hinge or a slider, a ball, a rod), then by id; one whose ends the forest already connects
// closes a loop. The forest is solved directly (s.joints), the loops (s.loops) with it (solveWithLoops). (With every
// joint of a component that holds a loop solved one by one, a heavy body welded on a long lever to a body held by
// a ring of joints kept only part of gravity's pull out of its velocity each substep.)
void spanningForest(const StepContext& ctx, JointSystem& s, const std::vector<int>& ids,
                    const std::vector<std::pair<int, int>>& ends) {
  auto rowCount = [&](int i) {
    switch (ctx.joints[static_cast<size_t>(i)].def.type) {
      case JointType::Fixed: return 6;
      case JointType::Hinge:
      case JointType::Slider: return 5;
      case JointType::Ball: return 3;
      default: return 1;
    }
  };
  std::vector<size_t> strongest(ids.size());
  for (size_t k = 0; k < strongest.size(); ++k) strongest[k] = k;
  std::stable_sort(strongest.begin(), strongest.end(),
                   [&](size_t p, size_t q) { return rowCount(ids[p]) > rowCount(ids[q]); });
  DisjointSets forest;
  forest.reset(s.sides.size());
  for (size_t k = 1; k < s.sides.size(); ++k)
    if (!(s.sides[k].invMass > 0)) forest.unite(static_cast<int>(k), 0);  // what cannot move is one
  std::vector<char> closesLoop(ids.size(), 0);
  for (size_t k : strongest) closesLoop[k] = !forest.unite(ends[k].first, ends[k].second);
  for (size_t k = 0; k < ids.size(); ++k) {
    const int i = ids[k];
    const Joint& jt = ctx.joints[static_cast<size_t>(i)];
    const int sa = ends[k].first, sb = ends[k].second;
    if (closesLoop[k]) {
      s.loops.push_back(i);
      s.loopEnds.emplace_back(sa, sb);
      continue;
    }
    const int kk = static_cast<int>(s.joints.size());
    s.joints.push_back(i);
    s.ends.emplace_back(sa, sb);
    const bool axial = jt.def.type == JointType::Hinge || jt.def.type == JointType::Slider;
    if ((axial && jt.def.limited) || (jt.def.type == JointType::Distance && jt.minLength != jt.maxLength))
      s.conditional = true;
    if (s.sides[static_cast<size_t>(sa)].invMass > 0) s.onBody[static_cast<size_t>(sa)].emplace_back(kk, -1);
    if (s.sides[static_cast<size_t>(sb)].invMass > 0) s.onBody[static_cast<size_t>(sb)].emplace_back(kk, +1);
  }
}

// The forest's elimination order: minimum degree over the joint graph (ties: the lower id), with the fill it
// makes (s.order, s.place, s.later); then the factorisation's workspace sized.
void eliminationOrder(JointSystem& s) {
  const size_t n = s.joints.size();
  std::vector<std::vector<int>> adj(n);
  auto link = [&](int p, int q) {
    auto& l = adj[static_cast<size_t>(p)];
    const auto it = std::lower_bound(l.begin(), l.end(), q);
    if (it == l.end() || *it != q) l.insert(it, q);
  };
  for (const auto& list : s.onBody)
    for (size_t i = 0; i < list.size(); ++i)
      for (size_t j = 0; j < list.size(); ++j)
        if (list[i].first != list[j].first) link(list[i].first, list[j].first);
  std::set<std::pair<size_t, int>> queue;
  for (size_t k = 0; k < n; ++k) queue.emplace(adj[k].size(), static_cast<int>(k));
  s.order.clear();
  s.place.assign(n, -1);
  std::vector<std::vector<int>> laterJoints;
  while (!queue.empty()) {
    const int p = queue.begin()->second;
    queue.erase(queue.begin());
    s.place[static_cast<size_t>(p)] = static_cast<int>(s.order.size());
    s.order.push_back(p);
    const std::vector<int> nb = adj[static_cast<size_t>(p)];
    for (int q : nb) {
      queue.erase({adj[static_cast<size_t>(q)].size(), q});
      auto& l = adj[static_cast<size_t>(q)];
      l.erase(std::lower_bound(l.begin(), l.end(), p));
      for (int r : nb)
        if (r != q) link(q, r);
      queue.emplace(l.size(), q);
    }
    laterJoints.push_back(nb);
  }
  s.later.assign(n, {});
  for (size_t p = 0; p < n; ++p) {
    for (int q : laterJoints[p]) s.later[p].push_back(s.place[static_cast<size_t>(q)]);
    std::sort(s.later[p].begin(), s.later[p].end());
  }
  s.rows.resize(n);
  s.diag.resize(n);
  s.inv.resize(n);
  s.scale.resize(n);
  s.off.resize(n);
  for (size_t p = 0; p < n; ++p) s.off[p].resize(s.later[p].size());
  s.x.resize(n);
}
}  // namespace

// The system of this call: the cached one with the sides brought up to date
// while the active joints and which of their ends are dynamic stay the same,
// else built anew.
JointSystem& buildSystem(StepContext& ctx) {
  if (!ctx.jointSolver.system) ctx.jointSolver.system = std::make_unique<JointSystem>();
  JointSystem& s = *ctx.jointSolver.system;
  if (sameSystem(ctx, s)) {
    for (size_t k = 1; k < s.sides.size(); ++k) setSide(s.sides[k], ctx, s.sides[k].index);
    return s;
  }
  std::vector<int> ids;
  std::vector<std::pair<int, int>> ends;
  collectJoints(ctx, s, ids, ends);
  spanningForest(ctx, s, ids, ends);
  eliminationOrder(s);
  return s;
}

// The velocities (and, pre, the predicted poses) of the bodies, then each joint's rows.
double lookAtJoints(const StepContext& ctx, JointSystem& s, double h, bool pre) {
  for (size_t k = 1; k < s.sides.size(); ++k) s.sides[k].refresh(ctx, h, pre);
  const double reach = ctx.settings.maxCorrectionSpeed * h;
  double worst = 0;
  for (size_t k = 0; k < s.joints.size(); ++k) {
    const Joint& jt = ctx.joints[static_cast<size_t>(s.joints[k])];
    fillJointRows(s.rows[k], jt, s.sides[static_cast<size_t>(s.ends[k].first)],
                  s.sides[static_cast<size_t>(s.ends[k].second)], h, pre, reach);
    worst = std::max(worst, s.rows[k].worst);
  }
  for (size_t k = 0; k < s.loops.size(); ++k) {
    const Joint& jt = ctx.joints[static_cast<size_t>(s.loops[k])];
    worst = std::max(worst, jointRows(jt, s.sides[static_cast<size_t>(s.loopEnds[k].first)],
                                      s.sides[static_cast<size_t>(s.loopEnds[k].second)], h, pre, reach)
                                .worst);
  }
  return worst;
}

// A hinge's or slider's motor: one row along the axis towards its speed, its
// impulse over the substep clamped to maxForce h.
void solveMotor(StepContext& ctx, Joint& jt, Side& a, Side& b, double h) {
  const JointDef& d = jt.def;
  a.refresh(ctx, h, true);
  b.refresh(ctx, h, true);
  const glm::dvec3 rb = b.dir(jt.rB, false);
  // A slider's A side acts at the point of its axis where B's anchor is (see jointRows).
  const glm::dvec3 ra = d.a < 0 ? glm::dvec3(0)
                                : a.dir(jt.rA, false) + (d.type == JointType::Slider
                                                             ? b.point(jt.rB, false) - a.point(jt.rA, false)
                                                             : glm::dvec3(0));
  const Mobility m = mobility(a, b, ra, rb);
  const bool hinge = d.type == JointType::Hinge;
  const glm::dvec3 axis = glm::normalize(a.dir(jt.axisA, true));
  const Row row = hinge ? Row{glm::dvec3(0), axis} : Row{axis, glm::dvec3(0)};
  const glm::dvec3 u = (b.v + glm::cross(b.w, rb)) - (a.v + glm::cross(a.w, ra));
  const double rate = hinge ? glm::dot(axis, b.w - a.w) : glm::dot(axis, u);
  // The effect of a unit impulse along the row on the rate.
  const glm::dvec3 ul = m.K * row.lin + m.C * row.ang, ua = glm::transpose(m.C) * row.lin + m.A * row.ang;
  const double mass = glm::dot(row.lin, ul) + glm::dot(row.ang, ua);
  if (!(mass > 0)) return;
  const double l = -(rate - d.motor.speed) / mass;
  const double cap = d.motor.maxForce * h;
  const double total = std::clamp(jt.motorImpulse + l, -cap, cap);
  const double lambda = total - jt.motorImpulse;
  jt.motorImpulse = total;
  if (lambda != 0) applyRows(ctx, jt, ra, rb, a, b, &row, 1, &lambda);
}

// One joint alone, a Newton step with the velocities of the moment; pre: its
// motor, its limit row, then its other rows; post: its rows, then its limit row.
void solveAlone(StepContext& ctx, Joint& jt, Side& a, Side& b, double h, bool pre) {
  if (pre && jt.def.motor.enabled && (jt.def.type == JointType::Hinge || jt.def.type == JointType::Slider))
    solveMotor(ctx, jt, a, b, h);
  for (int part : {pre ? kLimitRow : kMainRows, pre ? kMainRows : kLimitRow}) {
    a.refresh(ctx, h, pre);
    b.refresh(ctx, h, pre);
    const JointRows jr = jointRows(jt, a, b, h, pre, ctx.settings.maxCorrectionSpeed * h, part);
    if (jr.n == 0) continue;
    double rhs[6], lambda[6];
    for (int r = 0; r < jr.n; ++r) rhs[r] = pre ? -jr.err[r] / h : -jr.err[r];
    solveRows(mobility(a, b, jr.ra, jr.rb), jr.rows, jr.n, rhs, lambda);
    applyRows(ctx, jt, jr.ra, jr.rb, a, b, jr.rows, jr.n, lambda);
    if (pre && jr.limit) jt.limitHeld = true;
  }
}

// One Gauss-Seidel sweep over the joints of components with loops (a second
// joint between two bodies, a ring, a second anchor to what cannot move),
// where a direct solve would split the load between redundant rows at random:
// each joint alone in id order.
void solveLoops(StepContext& ctx, JointSystem& s, double h, bool pre) {
  for (size_t k = 0; k < s.loops.size(); ++k)
    solveAlone(ctx, ctx.joints[static_cast<size_t>(s.loops[k])], s.sides[static_cast<size_t>(s.loopEnds[k].first)],
               s.sides[static_cast<size_t>(s.loopEnds[k].second)], h, pre);
}

namespace {
// A row (its lever r) on a joint's end on a body (sign +1 on B, -1 on A) moves the body's (v, omega) along
// g = sign (lin, r x lin + ang); with the body given, also W g (W = diag(1/m, I^-1)).
inline void rowTerms(const Row& row, const glm::dvec3& r, double sign, double* g, const Side* body, double* wg) {
  const glm::dvec3 lin = sign * row.lin, ang = sign * (glm::cross(r, row.lin) + row.ang);
  g[0] = lin.x, g[1] = lin.y, g[2] = lin.z, g[3] = ang.x, g[4] = ang.y, g[5] = ang.z;
  if (!body) return;
  const glm::dvec3 wl = body->invMass * lin, wa = body->invInertia * ang;
  wg[0] = wl.x, wg[1] = wl.y, wg[2] = wl.z, wg[3] = wa.x, wg[4] = wa.y, wg[5] = wa.z;
}
// Row k of a joint's end: rowTerms with the end's lever.
void rowOnEnd(const JointRows& jr, int k, double sign, double* g, const Side* body = nullptr, double* wg = nullptr) {
  rowTerms(jr.rows[k], sign > 0 ? jr.rb : jr.ra, sign, g, body, wg);
}
// Every row of a joint's end on `body`, into e.
void endRows(const JointRows& jr, double sign, const Side& body, RowEnd& e) {
  const glm::dvec3& r = sign > 0 ? jr.rb : jr.ra;
  for (int k = 0; k < jr.n; ++k) rowTerms(jr.rows[k], r, sign, e.g[k], &body, e.wg[k]);
}

// The system's matrix, block by block (s.diag, s.off), from the rows of each body's joints.
void assemble(JointSystem& s) {
  const size_t n = s.joints.size();
  for (size_t p = 0; p < n; ++p) {
    s.diag[p] = {};
    for (Block& b : s.off[p]) b = {};
  }
  // A: per body, the effect of each of its joints' rows on each of its joints' rows (rowOnEnd's g_k): the block
  // entry of rows a of p and b of q is g_a . W g_b.
  std::vector<RowEnd>& ends = s.endScratch;
  for (size_t slot = 1; slot < s.onBody.size(); ++slot) {
    const auto& list = s.onBody[slot];
    if (list.empty()) continue;
    const Side& body = s.sides[slot];
    ends.resize(list.size());
    for (size_t i = 0; i < list.size(); ++i) {
      const JointRows& jr = s.rows[static_cast<size_t>(list[i].first)];
      endRows(jr, list[i].second, body, ends[i]);
    }
    for (size_t i = 0; i < list.size(); ++i) {
      const int p = s.place[static_cast<size_t>(list[i].first)];
      const int np = s.rows[static_cast<size_t>(list[i].first)].n;
      for (size_t j = 0; j < list.size(); ++j) {
        const int q = s.place[static_cast<size_t>(list[j].first)];
        if (q < p) continue;  // the block (p, q) with p first in the order
        const int nq = s.rows[static_cast<size_t>(list[j].first)].n;
        Block* blk = &s.diag[static_cast<size_t>(p)];
        if (q != p) {
          const auto& l = s.later[static_cast<size_t>(p)];
          blk = &s.off[static_cast<size_t>(p)][static_cast<size_t>(std::lower_bound(l.begin(), l.end(), q) - l.begin())];
        }
        const RowEnd& ei = ends[i];
        const RowEnd& ej = ends[j];
        // (A diagonal block's lower triangle only: the factorisation reads no more of it.)
        const bool lower = q == p;
        withSize(np, [&](auto NP) {
          withSize(nq, [&](auto NQ) {
            for (int a = 0; a < NP(); ++a)
              for (int c = 0; c < (lower ? a + 1 : NQ()); ++c) {
                const double* x = ei.g[a];
                const double* y = ej.wg[c];
                blk->m[a][c] += x[0] * y[0] + x[1] * y[1] + x[2] * y[2] + x[3] * y[3] + x[4] * y[4] + x[5] * y[5];
              }
          });
        });
      }
    }
  }
}

// Factor: eliminate each position into the later ones it is coupled to; the off-diagonal blocks become
// D_p^-1 A_pq.
void factor(JointSystem& s) {
  const size_t n = s.joints.size();
  auto size = [&](int pos) { return s.rows[static_cast<size_t>(s.order[static_cast<size_t>(pos)])].n; };
  for (size_t p = 0; p < n; ++p)
    for (int k = 0; k < size(static_cast<int>(p)); ++k) s.scale[p][static_cast<size_t>(k)] = s.diag[p].m[k][k];
  for (size_t p = 0; p < n; ++p) {
    const int np = size(static_cast<int>(p));
    const auto& later = s.later[p];
    std::vector<Block>& off = s.off[p];
    std::vector<Block>& scaled = s.scratch;
    scaled.resize(off.size());
    withSize(np, [&](auto NP) {
      constexpr int kNp = NP();
      pseudoInverseN<kNp>(s.diag[p], s.scale[p].data(), s.inv[p]);
      for (size_t e = 0; e < later.size(); ++e)
        withSize(size(later[e]), [&](auto NQ) { leftMultiply<kNp, NQ()>(s.inv[p], off[e], scaled[e]); });
      for (size_t e1 = 0; e1 < later.size(); ++e1) {
        const int q = later[e1], nq = size(q);
        for (size_t e2 = e1; e2 < later.size(); ++e2) {
          const int r = later[e2], nr = size(r);
          Block* target = &s.diag[static_cast<size_t>(q)];
          if (r != q) {
            const auto& l = s.later[static_cast<size_t>(q)];
            target = &s.off[static_cast<size_t>(q)]
                           [static_cast<size_t>(std::lower_bound(l.begin(), l.end(), r) - l.begin())];
          }
          withSize(nq, [&](auto NQ) {
            withSize(nr, [&](auto NR) { subtractProduct<kNp, NQ(), NR()>(off[e1], scaled[e2], *target, r == q); });
          });
        }
      }
    });
    off.swap(scaled);
  }
}

// x (by position) := A^-1 x, with the factors of `factor`: forward substitution, the diagonal, back substitution.
void solveFactored(const JointSystem& s, std::vector<std::array<double, 6>>& x) {
  const size_t n = s.joints.size();
  auto size = [&](int pos) { return s.rows[static_cast<size_t>(s.order[static_cast<size_t>(pos)])].n; };
  // (Each block's loops unrolled for its row counts: withSize.)
  for (size_t p = 0; p < n; ++p) {
    withSize(size(static_cast<int>(p)), [&](auto NP) {
      const std::array<double, 6>& xp = x[p];
      for (size_t e = 0; e < s.later[p].size(); ++e) {
        const int q = s.later[p][e];
        const Block& off = s.off[p][e];
        std::array<double, 6>& xq = x[static_cast<size_t>(q)];
        withSize(size(q), [&](auto NQ) {
          for (int c = 0; c < NQ(); ++c) {
            double v = 0;
            for (int k = 0; k < NP(); ++k) v += off.m[k][c] * xp[static_cast<size_t>(k)];
            xq[static_cast<size_t>(c)] -= v;
          }
        });
      }
    });
  }
  for (size_t p = 0; p < n; ++p) {
    withSize(size(static_cast<int>(p)), [&](auto NP) {
      std::array<double, 6> y{};
      std::array<double, 6>& xp = x[p];
      for (int i = 0; i < NP(); ++i) {
        double v = 0;
        for (int k = 0; k < NP(); ++k) v += s.inv[p].m[i][k] * xp[static_cast<size_t>(k)];
        y[static_cast<size_t>(i)] = v;
      }
      for (int i = 0; i < NP(); ++i) xp[static_cast<size_t>(i)] = y[static_cast<size_t>(i)];
    });
  }
  for (size_t p = n; p-- > 0;) {
    withSize(size(static_cast<int>(p)), [&](auto NP) {
      std::array<double, 6>& xp = x[p];
      for (size_t e = 0; e < s.later[p].size(); ++e) {
        const int q = s.later[p][e];
        const Block& off = s.off[p][e];
        const std::array<double, 6>& xq = x[static_cast<size_t>(q)];
        withSize(size(q), [&](auto NQ) {
          for (int i = 0; i < NP(); ++i) {
            double v = 0;
            for (int c = 0; c < NQ(); ++c) v += off.m[i][c] * xq[static_cast<size_t>(c)];
            xp[static_cast<size_t>(i)] -= v;
          }
        });
      }
    });
  }
}

// The impulses (s.x, by position): the right-hand sides (the rows' errors as rates), solved.
void substitute(JointSystem& s, double h, bool pre) {
  const size_t n = s.joints.size();
  for (size_t p = 0; p < n; ++p) {
    const JointRows& jr = s.rows[static_cast<size_t>(s.order[p])];
    for (int k = 0; k < jr.n; ++k) s.x[p][static_cast<size_t>(k)] = pre ? -jr.err[k] / h : -jr.err[k];
  }
  solveFactored(s, s.x);
}

// Applies the impulses s.x (by position) to the forest's joints, in id order.
void applySolved(StepContext& ctx, JointSystem& s, bool pre) {
  for (size_t k = 0; k < s.joints.size(); ++k) {
    const JointRows& jr = s.rows[k];
    if (jr.n == 0) continue;
    Joint& jt = ctx.joints[static_cast<size_t>(s.joints[k])];
    applyRows(ctx, jt, jr.ra, jr.rb, s.sides[static_cast<size_t>(s.ends[k].first)],
              s.sides[static_cast<size_t>(s.ends[k].second)], jr.rows, jr.n,
              s.x[static_cast<size_t>(s.place[k])].data());
    if (pre && jr.limit) jt.limitHeld = true;
  }
}

// The symmetric pseudo-inverse solve of the m x m positive semi-definite system a x = b (row-major; LDL^T without
// pivoting): a pivot not above `drop` of its row's `scale` is dropped (that row's x is 0). True where one was.
// `d`: room for the pivots.
bool solveDenseDropping(std::vector<double>& a, const std::vector<double>& scale, int m, double drop,
                        std::vector<double>& x, std::vector<double>& d) {
  bool dropped = false;
  d.assign(static_cast<size_t>(m), 0.0);
  auto at = [&](int i, int j) -> double& {
    return a[static_cast<size_t>(i) * static_cast<size_t>(m) + static_cast<size_t>(j)];
  };
  for (int k = 0; k < m; ++k) {  // a's lower triangle becomes L, d the pivots
    double dk = at(k, k);
    for (int j = 0; j < k; ++j) dk -= at(k, j) * at(k, j) * d[static_cast<size_t>(j)];
    const bool dead = !(dk > drop * scale[static_cast<size_t>(k)]) || !(scale[static_cast<size_t>(k)] > 0);
    dropped = dropped || dead;
    d[static_cast<size_t>(k)] = dead ? 0 : dk;
    for (int i = k + 1; i < m; ++i) {
      double v = at(i, k);
      for (int j = 0; j < k; ++j) v -= at(i, j) * at(k, j) * d[static_cast<size_t>(j)];
      at(i, k) = dead ? 0 : v / dk;
    }
  }
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < i; ++j) x[static_cast<size_t>(i)] -= at(i, j) * x[static_cast<size_t>(j)];
  for (int i = 0; i < m; ++i)
    x[static_cast<size_t>(i)] =
        d[static_cast<size_t>(i)] > 0 ? x[static_cast<size_t>(i)] / d[static_cast<size_t>(i)] : 0;
  for (int i = m - 1; i >= 0; --i)
    for (int j = i + 1; j < m; ++j) x[static_cast<size_t>(i)] -= at(j, i) * x[static_cast<size_t>(j)];
  return dropped;
}

// The forest and the loops' rows solved as one system: the forest's factors, and the loops' rows through their
// Schur complement [A B; B^T C] -> (C - B^T A^-1 B) lambda_loops = r_loops - B^T A^-1 r_forest (one solve with the
// forest's factors per loop row). A loop row the forest nearly holds already (a ring of hinges nearly in a plane:
// its turns out of the plane are held by every hinge) has less than a thousandth of its own pivot left and is
// dropped (`dropped`; the caller then sweeps the loop joints one by one over what is left): solved here, such a row
// asked 13,000 N s of a 16-plank bridge to close a tenth of a millimetre out of its plane, and rows down to 1e-5
// of their pivot left its hinges 4 mm open; left unsolved, two sliders 2 degrees apart (3e-4) let their body gain
// speed along them while the projection held it in place. False where the loops have more than kMaxLoopRows rows
// (then they go one by one, after the forest: the bridge's one loop solved so diverged, 0.5 mm open before a pass
// and 7 mm after).
constexpr int kMaxLoopRows = 24;
bool solveWithLoops(StepContext& ctx, JointSystem& s, double h, bool pre, bool& dropped) {
  dropped = false;
  const double reach = ctx.settings.maxCorrectionSpeed * h;
  std::vector<JointRows>& lr = s.loopRows;
  lr.resize(s.loops.size());
  int m = 0;
  for (size_t k = 0; k < s.loops.size(); ++k) {
    lr[k] = jointRows(ctx.joints[static_cast<size_t>(s.loops[k])], s.sides[static_cast<size_t>(s.loopEnds[k].first)],
                      s.sides[static_cast<size_t>(s.loopEnds[k].second)], h, pre, reach);
    m += lr[k].n;
  }
  if (m > kMaxLoopRows) return false;
  const size_t n = s.joints.size();
  assemble(s);
  factor(s);
  substitute(s, h, pre);
  if (m > 0) {
    // Each loop row's direction on each of its dynamic ends, g and W g (as `assemble` makes them).
    std::vector<std::array<LoopRowEnd, 2>>& ends = s.loopRowEnds;
    std::vector<int>& endCount = s.loopRowEndCount;
    std::vector<double>& rhs = s.loopRhs;
    ends.resize(static_cast<size_t>(m));
    endCount.assign(static_cast<size_t>(m), 0);
    rhs.resize(static_cast<size_t>(m));
    int row = 0;
    for (size_t k = 0; k < s.loops.size(); ++k) {
      const JointRows& jr = lr[k];
      for (int c = 0; c < jr.n; ++c, ++row) {
        rhs[static_cast<size_t>(row)] = pre ? -jr.err[c] / h : -jr.err[c];
        for (const auto& [slot, sign] : {std::pair{s.loopEnds[k].first, -1.0}, std::pair{s.loopEnds[k].second, 1.0}}) {
          const Side& body = s.sides[static_cast<size_t>(slot)];
          if (!(body.invMass > 0)) continue;
          LoopRowEnd& e = ends[static_cast<size_t>(row)][static_cast<size_t>(endCount[static_cast<size_t>(row)]++)];
          e.slot = slot;
          rowOnEnd(jr, c, sign, e.g, &body, e.wg);
        }
      }
    }
    auto dot6 = [](const double* x, const double* y) {
      return x[0] * y[0] + x[1] * y[1] + x[2] * y[2] + x[3] * y[3] + x[4] * y[4] + x[5] * y[5];
    };
    // B's columns (the forest's rows' response to each loop row, by position), then A^-1 B.
    std::vector<std::vector<std::array<double, 6>>>& solved = s.loopColumns;
    std::vector<std::vector<std::array<double, 6>>>& columns = s.loopResponse;
    solved.resize(static_cast<size_t>(m));
    columns.resize(static_cast<size_t>(m));
    for (int j = 0; j < m; ++j) {
      std::vector<std::array<double, 6>>& b = columns[static_cast<size_t>(j)];
      b.assign(n, std::array<double, 6>{});
      for (int e = 0; e < endCount[static_cast<size_t>(j)]; ++e) {
        const LoopRowEnd& end = ends[static_cast<size_t>(j)][static_cast<size_t>(e)];
        for (const auto& [k, sign] : s.onBody[static_cast<size_t>(end.slot)]) {
          const JointRows& jt = s.rows[static_cast<size_t>(k)];
          const size_t p = static_cast<size_t>(s.place[static_cast<size_t>(k)]);
          for (int c = 0; c < jt.n; ++c) {
            double g[6];
            rowOnEnd(jt, c, double(sign), g);
            b[p][static_cast<size_t>(c)] += dot6(g, end.wg);
          }
        }
      }
      solved[static_cast<size_t>(j)] = b;
      solveFactored(s, solved[static_cast<size_t>(j)]);
    }
    auto across = [&](const std::vector<std::array<double, 6>>& x, const std::vector<std::array<double, 6>>& y) {
      double v = 0;
      for (size_t p = 0; p < n; ++p)
        for (size_t c = 0; c < static_cast<size_t>(s.rows[static_cast<size_t>(s.order[p])].n); ++c)
          v += x[p][c] * y[p][c];
      return v;
    };
    // The Schur complement and its right-hand side.
    std::vector<double>& schur = s.loopSchur;
    std::vector<double>& scale = s.loopScale;
    schur.resize(static_cast<size_t>(m) * static_cast<size_t>(m));
    scale.resize(static_cast<size_t>(m));
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j <= i; ++j) {
        double c = 0;
        for (int ei = 0; ei < endCount[static_cast<size_t>(i)]; ++ei)
          for (int ej = 0; ej < endCount[static_cast<size_t>(j)]; ++ej) {
            const LoopRowEnd& a = ends[static_cast<size_t>(i)][static_cast<size_t>(ei)];
            const LoopRowEnd& b = ends[static_cast<size_t>(j)][static_cast<size_t>(ej)];
            if (a.slot == b.slot) c += dot6(a.g, b.wg);
          }
        if (i == j) scale[static_cast<size_t>(i)] = c;
        const double v = c - across(columns[static_cast<size_t>(i)], solved[static_cast<size_t>(j)]);
        schur[static_cast<size_t>(i * m + j)] = schur[static_cast<size_t>(j * m + i)] = v;
      }
      rhs[static_cast<size_t>(i)] -= across(columns[static_cast<size_t>(i)], s.x);
    }
    dropped = solveDenseDropping(schur, scale, m, 1e-3, rhs, s.loopPivots);  // rhs: the loops' impulses
    for (int j = 0; j < m; ++j)
      for (size_t p = 0; p < n; ++p)
        for (size_t c = 0; c < static_cast<size_t>(s.rows[static_cast<size_t>(s.order[p])].n); ++c)
          s.x[p][c] -= rhs[static_cast<size_t>(j)] * solved[static_cast<size_t>(j)][p][c];
    row = 0;
    for (size_t k = 0; k < s.loops.size(); ++k) {
      const JointRows& jr = lr[k];
      if (jr.n > 0) {
        Joint& jt = ctx.joints[static_cast<size_t>(s.loops[k])];
        applyRows(ctx, jt, jr.ra, jr.rb, s.sides[static_cast<size_t>(s.loopEnds[k].first)],
                  s.sides[static_cast<size_t>(s.loopEnds[k].second)], jr.rows, jr.n, rhs.data() + row);
        if (pre && jr.limit) jt.limitHeld = true;
      }
      row += jr.n;
    }
  }
  applySolved(ctx, s, pre);
  return true;
}
}  // namespace

// Solves every joint's rows at once and applies the impulses.
void solveSystem(StepContext& ctx, JointSystem& s, double h, bool pre) {
  assemble(s);
  factor(s);
  substitute(s, h, pre);
  applySolved(ctx, s, pre);
}

// A pass (after a look at the joints): the forest and the loops at once, then, where a loop row was dropped, the
// loops one by one over what is left; where the loops hold too many rows for that, the forest at once, then the
// loops one by one (a loop joint takes only what the forest leaves to it).
void solvePass(StepContext& ctx, JointSystem& s, double h, bool pre) {
  bool dropped = false;
  if (!s.loops.empty() && solveWithLoops(ctx, s, h, pre, dropped)) {
    if (dropped) solveLoops(ctx, s, h, pre);
    return;
  }
  solveSystem(ctx, s, h, pre);
  solveLoops(ctx, s, h, pre);
}


}  // namespace joints

}  // namespace crumple::detail
