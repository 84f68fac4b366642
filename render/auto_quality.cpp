#include <crumple/render/auto_quality.h>

#include <algorithm>
#include <cmath>

namespace crumple::render {

void AutoQuality::frame(double ms) {
  const long n = frames_++;
  if (n < kSkipFrames) return;
  average_ = average_ == 0 ? ms : 0.85 * average_ + 0.15 * ms;
  if (!enabled || n - lastChange_ < kSettleFrames) return;
  const float before = scale;
  const int shedBefore = shed_;
  if (average_ > kSlowMs) {
    const float by = std::clamp(static_cast<float>(std::sqrt(kSlowMs / average_)), 0.5f, 0.85f);
    if (scale > kShedAt)
      scale = std::max(kShedAt, scale * by);
    else if (shed_ < 2)
      ++shed_;
    else
      scale = std::max(kScaleFloor, scale * 0.85f);
  } else if (average_ < kFastMs) {
    if (scale < kShedAt)
      scale = std::min(kShedAt, scale * 1.1f);
    else if (shed_ > 0)
      --shed_;
    else
      scale = std::min(1.0f, scale * 1.1f);
  }
  if (scale != before || shed_ != shedBefore) {
    lastChange_ = n;
    average_ = 0;  // judged afresh
  }
}

void AutoQuality::apply(RendererSettings& s) const {
  s.antialias = shed() < 1 ? antialias : Antialias::None;
  s.selfShadow = wantSelfShadow && shed() < 2;
}

}  // namespace crumple::render
