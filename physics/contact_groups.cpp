#include "physics/contact_groups.h"

#include <algorithm>
#include <cmath>

namespace crumple::detail {

void groupContacts(const std::vector<Contact>& contacts, std::vector<ContactGroup>& out) {
  out.clear();
  thread_local std::vector<char> usedScratch;
  thread_local std::vector<size_t> membersScratch;
  std::vector<char>& used = usedScratch;  // (one thread-local lookup, not one per use)
  std::vector<size_t>& members = membersScratch;
  used.assign(contacts.size(), 0);
  for (size_t seed = 0; seed < contacts.size(); ++seed) {
    if (used[seed]) continue;
    GroupSum group{contacts[seed]};  // sorted deepest first
    members.clear();
    for (size_t i = seed; i < contacts.size(); ++i) {
      if (used[i] || !group.agrees(contacts[i])) continue;
      used[i] = 1;
      group.add(contacts[i]);
      members.push_back(i);
    }
    ContactGroup& g = out.emplace_back();
    g.contact = group.result();
    // The patch: the members' extent about the group's point in its tangent plane.
    const Contact& m = g.contact;
    PatchExtent& e = g.patchMatrix.patch;
    const glm::dvec3& n = m.normal;
    const glm::dvec3 axis =
        std::abs(n.x) < 0.57 ? glm::dvec3(1, 0, 0) : (std::abs(n.y) < 0.57 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1));
    e.n = n;
    e.t1 = glm::normalize(glm::cross(n, axis));
    e.t2 = glm::cross(n, e.t1);
    for (size_t i : members) {
      const glm::dvec3 d = contacts[i].point - m.point;
      const double d1 = glm::dot(d, e.t1), d2 = glm::dot(d, e.t2);
      e.lo1 = std::min(e.lo1, d1);
      e.hi1 = std::max(e.hi1, d1);
      e.lo2 = std::min(e.lo2, d2);
      e.hi2 = std::max(e.hi2, d2);
    }
  }
}

}  // namespace crumple::detail
