// One headless GL context per test process (llvmpipe on machines with no GPU).
#pragma once
#include "render/gl_context.h"

namespace crumple::test {
inline render::GlContext& glContext() {
  static std::unique_ptr<render::GlContext> ctx = render::createHeadlessContext();
  ctx->makeCurrent();
  return *ctx;
}
}  // namespace crumple::test
