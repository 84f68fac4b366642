#include <crumple/physics/contact_groups.h>

#include <algorithm>
#include <cmath>

namespace crumple::detail {

void groupContacts(const std::vector<Contact>& contacts, std::vector<ContactGroup>& out) {
  // The elements `out` already holds are reused, only the fields this function owns reset: a group is nearly a
  // kilobyte, and zeroing a fresh one for every look cost a tenth of a box pile's step. Each contact's group
  // number goes on the stack for the usual few contacts (a box face's corners), to the heap beyond.
  constexpr size_t kOnStack = 64;
  const size_t nc = contacts.size();
  uint32_t onStack[kOnStack];
  thread_local std::vector<uint32_t> onHeap;
  uint32_t* groupOf = onStack;
  if (nc > kOnStack) {
    onHeap.resize(nc);
    groupOf = onHeap.data();
  }
  constexpr uint32_t kNone = ~0u;
  std::fill(groupOf, groupOf + nc, kNone);
  uint32_t count = 0;
  for (size_t seed = 0; seed < nc; ++seed) {
    if (groupOf[seed] != kNone) continue;
    GroupSum group{contacts[seed]};  // sorted deepest first
    for (size_t i = seed; i < nc; ++i) {
      if (groupOf[i] != kNone || !group.agrees(contacts[i])) continue;
      groupOf[i] = count;
      group.add(contacts[i]);
    }
    ContactGroup& g = count < out.size() ? out[count] : out.emplace_back();
    g.totals = FrictionTotals{};
    g.contact = group.result();
    // The patch: the members' extent about the group's point in its tangent plane.
    const Contact& m = g.contact;
    PatchExtent& e = g.patchMatrix.patch;
    e = PatchExtent{};
    const glm::dvec3& n = m.normal;
    const glm::dvec3 axis =
        std::abs(n.x) < 0.57 ? glm::dvec3(1, 0, 0) : (std::abs(n.y) < 0.57 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1));
    e.n = n;
    e.t1 = glm::normalize(glm::cross(n, axis));
    e.t2 = glm::cross(n, e.t1);
    for (size_t i = seed; i < nc; ++i) {
      if (groupOf[i] != count) continue;
      const glm::dvec3 d = contacts[i].point - m.point;
      const double d1 = glm::dot(d, e.t1), d2 = glm::dot(d, e.t2);
      e.lo1 = std::min(e.lo1, d1);
      e.hi1 = std::max(e.hi1, d1);
      e.lo2 = std::min(e.lo2, d2);
      e.hi2 = std::max(e.hi2, d2);
    }
    ++count;
  }
  out.resize(count);
}

}  // namespace crumple::detail
