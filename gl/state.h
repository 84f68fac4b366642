// Scoped GL state: what a pass changes on the way (viewport, framebuffers,
// program, depth and cull state) saved at construction and put back at
// destruction, so that the caller's rendering state survives it.
#pragma once
#include <epoxy/gl.h>

namespace crumple::gl {

class StateGuard {
 public:
  StateGuard();
  ~StateGuard();
  StateGuard(const StateGuard&) = delete;
  StateGuard& operator=(const StateGuard&) = delete;

 private:
  GLint viewport_[4] = {0, 0, 0, 0};
  GLint drawFramebuffer_ = 0, readFramebuffer_ = 0, program_ = 0, vertexArray_ = 0;
  GLint depthFunc_ = GL_LESS, cullFace_ = GL_BACK;
  GLboolean depthMask_ = GL_TRUE, depthTest_ = GL_FALSE, cull_ = GL_FALSE, blend_ = GL_FALSE;
};

}  // namespace crumple::gl
