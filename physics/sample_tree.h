// A shape's samples in a bounding-volume hierarchy (shape frame), so that the
// broad phase finds the samples inside a box without visiting the others: a
// small body resting on a mesh of 60 000 samples looks at the few near it
// (internal to the physics library).
#pragma once
#include <glm/glm.hpp>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace crumple {

class SampleTree {
 public:
  // Shapes with at most this many samples are scanned whole (no tree).
  static constexpr size_t kMinSamples = 64;

  explicit SampleTree(const std::vector<glm::dvec3>& samples) : order_(samples.size()) {
    for (size_t i = 0; i < order_.size(); ++i) order_[i] = static_cast<uint32_t>(i);
    if (!order_.empty()) build(samples, 0, static_cast<uint32_t>(order_.size()));
  }
  size_t size() const { return order_.size(); }

  // Calls visit(i) for every sample i inside the oriented box with this centre,
  // axes (the columns of `axes`, unit and orthogonal) and half extents (and for
  // some near it: callers test each sample themselves), in no particular order.
  // A node is skipped when one of its own axes or one of the box's separates
  // the two (conservative: the other nine axes are not tried).
  template <class Visit>
  void query(const glm::dvec3& centre, const glm::dmat3& axes, const glm::dvec3& half, Visit&& visit) const {
    if (nodes_.empty()) return;
    glm::dmat3 abs;
    for (int c = 0; c < 3; ++c) abs[c] = glm::abs(axes[c]);
    // The box's reach along the tree's axes.
    const glm::dvec3 reach = abs * half;
    uint32_t stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const uint32_t at = stack[--top];
      const Node& node = nodes_[at];
      const glm::dvec3& ne = node.extent;
      const glm::dvec3 d = centre - node.centre;
      if (std::abs(d.x) > ne.x + reach.x || std::abs(d.y) > ne.y + reach.y || std::abs(d.z) > ne.z + reach.z) continue;
      bool apart = false;
      for (int c = 0; c < 3 && !apart; ++c)
        apart = std::abs(glm::dot(axes[c], d)) > half[c] + glm::dot(abs[c], ne);
      if (apart) continue;
      if (node.right == 0) {
        for (uint32_t k = node.first; k < node.first + node.count; ++k) visit(order_[k]);
        continue;
      }
      stack[top++] = node.right;
      stack[top++] = at + 1;  // the left child follows its parent
    }
  }

 private:
  static constexpr uint32_t kLeaf = 16;
  struct Node {
    glm::dvec3 centre, extent;  // its samples' bounding box: centre and half extents
    uint32_t first = 0, count = 0;
    uint32_t right = 0;  // 0: a leaf
  };
  // The node over order_[first, first + count): split at the median of its longest axis (ties by index).
  // Depth stays below 64: every split halves the range.
  void build(const std::vector<glm::dvec3>& samples, uint32_t first, uint32_t count) {
    const size_t at = nodes_.size();
    nodes_.push_back({});
    glm::dvec3 lo(samples[order_[first]]), hi = lo;
    for (uint32_t k = first; k < first + count; ++k) {
      lo = glm::min(lo, samples[order_[k]]);
      hi = glm::max(hi, samples[order_[k]]);
    }
    nodes_[at].centre = (lo + hi) * 0.5;
    nodes_[at].extent = (hi - lo) * 0.5;
    nodes_[at].first = first;
    nodes_[at].count = count;
    if (count <= kLeaf) return;
    const glm::dvec3 e = hi - lo;
    const int axis = e.x >= e.y ? (e.x >= e.z ? 0 : 2) : (e.y >= e.z ? 1 : 2);
    const uint32_t half = count / 2;
    auto begin = order_.begin() + first;
    std::nth_element(begin, begin + half, begin + count, [&](uint32_t a, uint32_t b) {
      const double va = samples[a][axis], vb = samples[b][axis];
      return va != vb ? va < vb : a < b;
    });
    build(samples, first, half);
    const uint32_t right = static_cast<uint32_t>(nodes_.size());
    build(samples, first + half, count - half);
    nodes_[at].right = right;
  }
  std::vector<Node> nodes_;
  std::vector<uint32_t> order_;
};

}  // namespace crumple
