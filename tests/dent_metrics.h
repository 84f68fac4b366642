// How well a dent holds together, measured on a height map (issue: gap-free dents).
//   continuity: over the dented texels, the mean fraction of their 4 neighbours
//               (on the surface) that are dented too; a continuous dent scores
//               about 1 - 1/(2w) for a strip w texels wide (0.95 at w = 10),
//               a screen door about 0.5, scattered dots near 0.
//   holes:      texels on the surface left flat between two dented neighbours
//               (left and right, or above and below), as a fraction of the
//               dented texels plus those holes.
#pragma once
#include <cstdint>
#include <vector>

#include <crumple/gl/image.h>

namespace crumple::test {

struct DentContinuity {
  long dented = 0, holes = 0;
  double continuity = 0;
  double holeFraction() const { return dented + holes ? double(holes) / double(dented + holes) : 0.0; }
};

// `before` and `after` are height maps of one surface; a texel is dented where
// it dropped by more than `eps`. `onSurface` (res * res, may be empty: all)
// marks the texels that belong to a chart of the atlas.
inline DentContinuity dentContinuity(const gl::Image& before, const gl::Image& after,
                                     const std::vector<uint8_t>& onSurface = {}, float eps = 1e-5f) {
  const int w = after.width, h = after.height;
  auto inside = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < w && y < h && (onSurface.empty() || onSurface[size_t(y) * w + x]);
  };
  auto dented = [&](int x, int y) { return inside(x, y) && after.at(x, y) < before.at(x, y) - eps; };
  DentContinuity r;
  double sum = 0;
  const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!inside(x, y)) continue;
      if (dented(x, y)) {
        int on = 0, dent = 0;
        for (int k = 0; k < 4; ++k) {
          on += inside(x + dx[k], y + dy[k]);
          dent += dented(x + dx[k], y + dy[k]);
        }
        ++r.dented;
        sum += on ? double(dent) / on : 1.0;
      } else if ((dented(x - 1, y) && dented(x + 1, y)) || (dented(x, y - 1) && dented(x, y + 1))) {
        ++r.holes;
      }
    }
  r.continuity = r.dented ? sum / double(r.dented) : 0.0;
  return r;
}

}  // namespace crumple::test
