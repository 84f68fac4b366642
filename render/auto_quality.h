// Automatic render quality for interactive views: the view's resolution scale and what the frame sheds
// follow the frame time, so that a software renderer (llvmpipe) keeps a fluid picture while a GPU keeps
// everything at full size. Over kSlowMs a frame (below about 33 fps) the scale falls to kShedAt (at once by
// as much as the pixels' share of the time could save, at most by half), then antialiasing is shed, then parallax
// self-shadowing, then the scale falls on to kScaleFloor; under kFastMs each comes back in reverse order.
// Each change waits kSettleFrames and is judged on frames measured after it.
#pragma once

#include <crumple/render/renderer.h>

namespace crumple::render {

class AutoQuality {
 public:
  static constexpr double kSlowMs = 30.0, kFastMs = 18.0;
  static constexpr float kShedAt = 0.35f, kScaleFloor = 0.25f;
  static constexpr long kSettleFrames = 10;
  static constexpr int kSkipFrames = 2;  // the first frames compile shaders: not counted

  bool enabled = true;
  float scale = 1.0f;                           // of the window's size (set by hand when not enabled)
  Antialias antialias = Antialias::Fxaa;  // as the user chose (FXAA or MSAA is what is shed first)
  bool wantSelfShadow = true;

  // One frame took `ms` (the whole loop: physics, rendering, presenting).
  void frame(double ms);
  // 0: as chosen, 1: antialiasing shed, 2: self-shadowing shed too.
  int shed() const { return enabled ? shed_ : 0; }
  // The settings this quality asks for (antialiasing, self-shadowing).
  void apply(RendererSettings& s) const;

 private:
  int shed_ = 0;
  long frames_ = 0, lastChange_ = 0;
  double average_ = 0;
};

}  // namespace crumple::render
