// One headless GL context per test process (llvmpipe on machines with no GPU).
#pragma once
#include <crumple/gl/context.h>

namespace crumple::test {
inline gl::GlContext& glContext() {
  static std::unique_ptr<gl::GlContext> ctx = gl::createHeadlessContext();
  ctx->makeCurrent();
  return *ctx;
}
}  // namespace crumple::test
