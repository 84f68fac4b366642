#include "physics/contact_groups.h"

#include <algorithm>
#include <cmath>

namespace crumple::detail {

namespace {
// The group's patch: its members' extent about the group's point in its tangent plane.
template <class Members>
void setPatch(const std::vector<Contact>& contacts, ContactGroup& g, Members&& members) {
  const Contact& m = g.contact;
  PatchExtent& e = g.patchMatrix.patch;
  const glm::dvec3& n = m.normal;
  const glm::dvec3 axis =
      std::abs(n.x) < 0.57 ? glm::dvec3(1, 0, 0) : (std::abs(n.y) < 0.57 ? glm::dvec3(0, 1, 0) : glm::dvec3(0, 0, 1));
  e.n = n;
  e.t1 = glm::normalize(glm::cross(n, axis));
  e.t2 = glm::cross(n, e.t1);
  members([&](size_t i) {
    const glm::dvec3 d = contacts[i].point - m.point;
    const double d1 = glm::dot(d, e.t1), d2 = glm::dot(d, e.t2);
    e.lo1 = std::min(e.lo1, d1);
    e.hi1 = std::max(e.hi1, d1);
    e.lo2 = std::min(e.lo2, d2);
    e.hi2 = std::max(e.hi2, d2);
  });
}
}  // namespace

void groupContacts(const std::vector<Contact>& contacts, std::vector<ContactGroup>& out) {
  out.clear();
  if (contacts.empty()) return;
  // One group (a contact manifold's points share their normal): the same sums in the same order as below.
  {
    GroupSum group{contacts[0]};
    bool one = true;
    for (size_t i = 1; i < contacts.size() && one; ++i) one = group.agrees(contacts[i]);
    if (one) {
      for (const Contact& c : contacts) group.add(c);
      ContactGroup& g = out.emplace_back();
      g.contact = group.result();
      setPatch(contacts, g, [&](auto&& fn) {
        for (size_t i = 0; i < contacts.size(); ++i) fn(i);
      });
      return;
    }
  }
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
    setPatch(contacts, g, [&](auto&& fn) {
      for (size_t i : members) fn(i);
    });
  }
}

}  // namespace crumple::detail
