// Private to the library: x = A⁻¹b with CHOLMOD's supernodal LLᵀ factor of
// A, in two parts on the machine's two cores (docs/design.md, "Sparse solves
// in two parts"). Only stages that link CHOLMOD include it (through
// core/cholmod_factor.hpp).
//
// A solve reads the whole factor twice (L y = Pb, then Lᵀ z = y), at the
// speed of memory: on a 10⁶-coordinate net 0.15–0.2 s each, and the
// equilibrium's conjugate gradients and the Lanczos iteration take about a
// hundred of them. CHOLMOD's solve runs on one core; two cores read memory
// nearly twice as fast (8.8 against 16 GB/s on this project's machine). The
// supernodes form a tree (a supernode's parent holds the first row below its
// diagonal block), and disjoint subtrees are independent in both sweeps: the
// tree is cut into two sets of subtrees of about equal size (their factor
// entries) and the supernodes above them (`top`, a few separators: a small
// share of the factor). Forward, each part runs its subtrees (ascending) and
// sends what it subtracts from a top supernode's rows to a buffer of its own;
// the buffers are added (part 0's, then part 1's) and the top supernodes run
// in turn. Backward, the top supernodes run first (descending), then the two
// parts at once, each reading rows already final and writing only its own.
// The order of every sum is fixed by the factor's structure alone, so the
// result is the same on one core or two, run after run.
#pragma once

#include "core/in_parts.hpp"

#include <Eigen/Core>
#include <cholmod.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

namespace modal::detail {

// The cut of one factor's supernodal tree (supernodal_schedule), made again
// only when the structure changes (a new symbolic analysis).
struct SupernodalSchedule {
  std::vector<int> super, pi;  // the structure it was made for (L->Super, L->pi)
  std::array<std::vector<int>, 2> parts;  // each part's supernodes, ascending
  std::vector<int> top;                   // the supernodes above them, ascending
  std::vector<int> slot;                  // column → index in a part's buffer (−1: not a top column)
  std::size_t top_columns = 0;
  int below = 0;  // the most rows any supernode has below its diagonal block
  bool split = false;  // false: one part (a small factor, or a tree that does not cut)
};

// A factor is solved in two parts from this many entries on (8 MB: a solve
// of about a millisecond, where a thread's start costs tens of µs).
constexpr double supernodal_parts_from = 1 << 20;

inline bool is_supernodal_llt(const cholmod_factor* L) {
  return L != nullptr && L->is_super && L->is_ll && L->xtype == CHOLMOD_REAL && L->dtype == CHOLMOD_DOUBLE &&
         L->itype == CHOLMOD_INT && L->x != nullptr && L->Perm != nullptr && L->super != nullptr &&
         L->pi != nullptr && L->px != nullptr && L->s != nullptr;
}

// The cut of L's supernodal tree into two parts (see the header comment):
// from the roots, the largest subtree is replaced by its children while
// the two parts (filled largest first) differ by more than 5 % of the
// factor, at most 256 times; no cut where the supernodes above would hold
// over a tenth of the factor, or they and the heavier part over three
// quarters.
inline void supernodal_schedule(const cholmod_factor& L, SupernodalSchedule& sch) {
  const auto* super = static_cast<const int*>(L.super);
  const auto* pi = static_cast<const int*>(L.pi);
  const auto* px = static_cast<const int*>(L.px);
  const auto* ls = static_cast<const int*>(L.s);
  const int ns = static_cast<int>(L.nsuper);
  const int n = static_cast<int>(L.n);
  sch = SupernodalSchedule{};
  sch.super.assign(super, super + ns + 1);
  sch.pi.assign(pi, pi + ns + 1);
  const double total = static_cast<double>(px[ns]);
  if (ns < 2 || total < supernodal_parts_from) return;
  std::vector<int> of_column(static_cast<std::size_t>(n));
  for (int s = 0; s < ns; ++s) std::fill(of_column.begin() + super[s], of_column.begin() + super[s + 1], s);
  std::vector<int> parent(static_cast<std::size_t>(ns), -1);
  std::vector<double> weight(static_cast<std::size_t>(ns));
  std::vector<std::vector<int>> children(static_cast<std::size_t>(ns));
  std::vector<int> roots;
  for (int s = 0; s < ns; ++s) {
    const int ncol = super[s + 1] - super[s], nrow = pi[s + 1] - pi[s];
    sch.below = std::max(sch.below, nrow - ncol);
    weight[static_cast<std::size_t>(s)] += static_cast<double>(px[s + 1] - px[s]);
    if (nrow > ncol) {
      const int p = of_column[static_cast<std::size_t>(ls[pi[s] + ncol])];
      if (p <= s) return;  // not a supernodal elimination tree: CHOLMOD's own solve
      parent[static_cast<std::size_t>(s)] = p;
      children[static_cast<std::size_t>(p)].push_back(s);
    } else {
      roots.push_back(s);
    }
  }
  // Subtree weights: children come before their parent.
  for (int s = 0; s < ns; ++s)
    if (const int p = parent[static_cast<std::size_t>(s)]; p >= 0)
      weight[static_cast<std::size_t>(p)] += weight[static_cast<std::size_t>(s)];
  std::vector<int> candidates = roots, top;
  double top_weight = 0;
  std::array<std::vector<int>, 2> bins;
  std::array<double, 2> load{0, 0};
  for (int round = 0; round < 256; ++round) {
    std::sort(candidates.begin(), candidates.end(), [&](int a, int b) {
      return weight[static_cast<std::size_t>(a)] > weight[static_cast<std::size_t>(b)] ||
             (weight[static_cast<std::size_t>(a)] == weight[static_cast<std::size_t>(b)] && a < b);
    });
    load = {0, 0};
    bins = {};
    for (int c : candidates) {
      const std::size_t b = load[0] <= load[1] ? 0 : 1;
      load[b] += weight[static_cast<std::size_t>(c)];
      bins[b].push_back(c);
    }
    if (std::abs(load[0] - load[1]) <= 0.05 * total) break;
    const int largest = candidates.front();
    // The bins stay those of the candidates they were filled from.
    if (children[static_cast<std::size_t>(largest)].empty() || round == 255) break;
    candidates.erase(candidates.begin());
    top.push_back(largest);
    top_weight += static_cast<double>(px[largest + 1] - px[largest]);
    for (int c : children[static_cast<std::size_t>(largest)]) candidates.push_back(c);
  }
  if (bins[0].empty() || bins[1].empty()) return;
  const double heavier = std::max(load[0], load[1]);
  // The top runs on one core with Eigen's kernels, slower than CHOLMOD's
  // BLAS on large dense blocks (a 3-D grid's separators): cut only where
  // the top is small and the cut saves at least a quarter.
  if (top_weight > 0.1 * total || top_weight + heavier > 0.75 * total) return;
  // Each part: every supernode of its subtrees (a subtree's supernodes are
  // its root's descendants, found by the parent links).
  std::vector<int> owner(static_cast<std::size_t>(ns), -2);  // −2: not yet known, −1: top
  for (int t : top) owner[static_cast<std::size_t>(t)] = -1;
  for (int b = 0; b < 2; ++b)
    for (int c : bins[static_cast<std::size_t>(b)]) owner[static_cast<std::size_t>(c)] = b;
  for (int s = ns - 1; s >= 0; --s)
    if (owner[static_cast<std::size_t>(s)] == -2) {
      const int p = parent[static_cast<std::size_t>(s)];
      // Below a part's subtree root; a root not reached from the chosen
      // subtrees or the top (there is none such) would go to the top.
      owner[static_cast<std::size_t>(s)] = p >= 0 ? owner[static_cast<std::size_t>(p)] : -1;
    }
  sch.slot.assign(static_cast<std::size_t>(n), -1);
  for (int s = 0; s < ns; ++s) {
    const int o = owner[static_cast<std::size_t>(s)];
    if (o >= 0) {
      sch.parts[static_cast<std::size_t>(o)].push_back(s);
      continue;
    }
    sch.top.push_back(s);
    for (int k = super[s]; k < super[s + 1]; ++k) sch.slot[static_cast<std::size_t>(k)] = static_cast<int>(sch.top_columns++);
  }
  sch.split = true;
}

// x = A⁻¹b (n each; x may be b) with L's supernodal LLᵀ factor of A (A =
// Pᵀ L Lᵀ P, CHOLMOD's Perm), in two parts where L is large enough to pay
// (see the header comment). False where L is no supernodal LLᵀ factor in
// double precision with int indices, or its tree does not cut: then the
// caller solves with CHOLMOD (cholmod_solve2).
inline bool supernodal_solve(const cholmod_factor* L, const double* b, double* x, SupernodalSchedule& sch) {
  if (!is_supernodal_llt(L)) return false;
  const auto* super = static_cast<const int*>(L->super);
  const auto* pi = static_cast<const int*>(L->pi);
  const auto* px = static_cast<const int*>(L->px);
  const auto* ls = static_cast<const int*>(L->s);
  const auto* lx = static_cast<const double*>(L->x);
  const auto* perm = static_cast<const int*>(L->Perm);
  const int ns = static_cast<int>(L->nsuper);
  const auto n = static_cast<Eigen::Index>(L->n);
  if (sch.super.size() != static_cast<std::size_t>(ns) + 1 || !std::equal(sch.super.begin(), sch.super.end(), super) ||
      !std::equal(sch.pi.begin(), sch.pi.end(), pi))
    supernodal_schedule(*L, sch);
  if (!sch.split) return false;

  using Block = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
  Eigen::VectorXd y(n);
  for (Eigen::Index k = 0; k < n; ++k) y[k] = b[perm[k]];
  std::array<Eigen::VectorXd, 2> sent;  // what each part subtracts from the top columns
  // One supernode's forward step: its columns' y by L11, then L21 y1 sent to
  // the rows below (`send(row, value)`).
  auto forward = [&](int s, Eigen::VectorXd& work, auto&& send) {
    const int k1 = super[s], ncol = super[s + 1] - k1, nrow = pi[s + 1] - pi[s];
    const Block block(lx + px[s], nrow, ncol, Eigen::OuterStride<>(nrow));
    auto y1 = y.segment(k1, ncol);
    block.topRows(ncol).triangularView<Eigen::Lower>().solveInPlace(y1);
    if (nrow == ncol) return;
    work.head(nrow - ncol).noalias() = block.bottomRows(nrow - ncol) * y1;
    const int* rows = ls + pi[s] + ncol;
    for (int i = 0; i < nrow - ncol; ++i) send(rows[i], work[i]);
  };
  auto backward = [&](int s, Eigen::VectorXd& work) {
    const int k1 = super[s], ncol = super[s + 1] - k1, nrow = pi[s + 1] - pi[s];
    const Block block(lx + px[s], nrow, ncol, Eigen::OuterStride<>(nrow));
    auto y1 = y.segment(k1, ncol);
    if (nrow > ncol) {
      const int* rows = ls + pi[s] + ncol;
      for (int i = 0; i < nrow - ncol; ++i) work[i] = y[rows[i]];
      y1.noalias() -= block.bottomRows(nrow - ncol).transpose() * work.head(nrow - ncol);
    }
    block.topRows(ncol).triangularView<Eigen::Lower>().transpose().solveInPlace(y1);
  };
  std::array<Eigen::VectorXd, 2> work{Eigen::VectorXd(sch.below), Eigen::VectorXd(sch.below)};
  in_parts(2, [&](std::size_t part) {
    Eigen::VectorXd& to_top = sent[part];
    to_top.setZero(static_cast<Eigen::Index>(sch.top_columns));
    for (int s : sch.parts[part])
      forward(s, work[part], [&](int row, double v) {
        if (const int slot = sch.slot[static_cast<std::size_t>(row)]; slot >= 0)
          to_top[slot] += v;
        else
          y[row] -= v;
      });
  });
  for (int s : sch.top)
    for (int k = super[s]; k < super[s + 1]; ++k) {
      const int slot = sch.slot[static_cast<std::size_t>(k)];
      y[k] -= sent[0][slot];
      y[k] -= sent[1][slot];
    }
  for (int s : sch.top) forward(s, work[0], [&](int row, double v) { y[row] -= v; });
  for (auto s = sch.top.rbegin(); s != sch.top.rend(); ++s) backward(*s, work[0]);
  in_parts(2, [&](std::size_t part) {
    const std::vector<int>& own = sch.parts[part];
    for (auto s = own.rbegin(); s != own.rend(); ++s) backward(*s, work[part]);
  });
  for (Eigen::Index k = 0; k < n; ++k) x[perm[k]] = y[k];
  return true;
}

}  // namespace modal::detail
