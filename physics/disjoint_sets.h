// Disjoint sets of 0..n-1 (union-find with path halving) whose roots do not depend on the order of the unions:
// unite puts the set with the larger root under the smaller one, so that every set's root is its smallest member.
// The step's islands, the resting solve's and sleep's islands and the joint solver's spanning forest use it.
#pragma once
#include <algorithm>
#include <cstddef>
#include <numeric>
#include <vector>

namespace crumple::detail {

class DisjointSets {
 public:
  // n singletons (the storage is kept from one use to the next).
  void reset(size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  int find(int i) {
    while (parent_[at(i)] != i) {
      parent_[at(i)] = parent_[at(parent_[at(i)])];
      i = parent_[at(i)];
    }
    return i;
  }
  // Joins the sets of a and b; false when they were one set already.
  bool unite(int a, int b) {
    const int ra = find(a), rb = find(b);
    if (ra == rb) return false;
    parent_[at(std::max(ra, rb))] = std::min(ra, rb);
    return true;
  }

 private:
  static size_t at(int i) { return static_cast<size_t>(i); }
  std::vector<int> parent_;
};

}  // namespace crumple::detail
