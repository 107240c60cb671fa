// Disjoint sets of the integers 0 .. n-1 (union-find with path halving: R. E. Tarjan, J. van Leeuwen,
// "Worst-case Analysis of Set Union Algorithms", J. ACM 31(2), 1984): which pieces a mesh's triangles
// form, which river banks continue through junctions.
#pragma once

#include <cstddef>
#include <numeric>
#include <vector>

namespace squall {

class DisjointSets {
 public:
  explicit DisjointSets(size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), size_t(0)); }

  // The representative of the set holding `a`.
  size_t find(size_t a) {
    while (parent_[a] != a) a = parent_[a] = parent_[parent_[a]];
    return a;
  }
  // Merges the sets holding `a` and `b`.
  void join(size_t a, size_t b) { parent_[find(a)] = find(b); }
  size_t size() const { return parent_.size(); }

 private:
  std::vector<size_t> parent_;
};

}  // namespace squall
