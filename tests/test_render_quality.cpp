// The sandbox's automatic quality (render/auto_quality.h): what a slow or a fast machine's frames do to the
// view's scale, FXAA and self-shadowing, and in which order.
#include <doctest/doctest.h>

#include <vector>

#include <crumple/render/auto_quality.h>

using namespace crumple::gl;
using namespace crumple::render;

namespace {
// Feeds `n` frames of `ms` each.
void run(AutoQuality& q, double ms, int n) {
  for (int i = 0; i < n; ++i) q.frame(ms);
}
}  // namespace

TEST_CASE("automatic quality: slow frames lower the scale, then shed FXAA and self-shadowing, then the scale again") {
  AutoQuality q;
  RendererSettings s;
  run(q, 120.0, 12);  // far over: the scale falls at once by the pixels' share (at most by half)
  CHECK(q.scale == doctest::Approx(0.5f));
  CHECK(q.shed() == 0);
  run(q, 120.0, 11);
  CHECK(q.scale == doctest::Approx(AutoQuality::kShedAt));
  CHECK(q.shed() == 0);
  q.apply(s);
  CHECK(s.antialias == Antialias::Fxaa);
  CHECK(s.selfShadow);
  run(q, 40.0, 11);
  CHECK(q.shed() == 1);
  q.apply(s);
  CHECK(s.antialias == Antialias::None);
  CHECK(s.selfShadow);
  run(q, 40.0, 11);
  CHECK(q.shed() == 2);
  q.apply(s);
  CHECK_FALSE(s.selfShadow);
  CHECK(q.scale == doctest::Approx(AutoQuality::kShedAt));
  run(q, 40.0, 200);  // still slow: the scale goes on down to its floor, no further
  CHECK(q.scale == doctest::Approx(AutoQuality::kScaleFloor));
  CHECK(q.shed() == 2);

  // Fast again: each comes back in reverse order (the scale to kShedAt, self-shadowing, FXAA), then the scale
  // rises to full size.
  std::vector<int> sheds{q.shed()};
  for (int i = 0; i < 2000; ++i) {
    const float scaleBefore = q.scale;
    q.frame(10.0);
    if (q.shed() != sheds.back()) {
      CHECK(q.scale == doctest::Approx(AutoQuality::kShedAt));  // nothing is restored below kShedAt
      sheds.push_back(q.shed());
    }
    if (q.scale > scaleBefore && q.scale > AutoQuality::kShedAt) CHECK(q.shed() == 0);  // the scale comes last
    CHECK(q.scale >= scaleBefore);
  }
  CHECK(sheds == std::vector<int>{2, 1, 0});
  CHECK(q.scale == doctest::Approx(1.0f));
}

TEST_CASE("automatic quality: frames within the band change nothing; by hand nothing is shed; choices are kept") {
  AutoQuality q;
  run(q, 24.0, 500);
  CHECK(q.scale == 1.0f);
  CHECK(q.shed() == 0);

  AutoQuality slow;
  run(slow, 60.0, 60);
  REQUIRE(slow.shed() > 0);
  slow.enabled = false;  // the scale set by hand: everything as chosen
  CHECK(slow.shed() == 0);
  const float scale = slow.scale;
  run(slow, 60.0, 100);
  CHECK(slow.scale == scale);
  RendererSettings s;
  slow.apply(s);
  CHECK(s.antialias == Antialias::Fxaa);
  slow.antialias = Antialias::None;  // antialiasing turned off by the user stays off however fast the frames
  slow.enabled = true;
  run(slow, 5.0, 2000);
  slow.apply(s);
  CHECK(s.antialias == Antialias::None);
  CHECK(s.selfShadow);
  CHECK(slow.scale == doctest::Approx(1.0f));
  slow.antialias = Antialias::Msaa;  // MSAA chosen: kept while fast, shed first when slow
  slow.apply(s);
  CHECK(s.antialias == Antialias::Msaa);
  run(slow, 60.0, 200);
  slow.apply(s);
  CHECK(s.antialias == Antialias::None);
}
