#include <crumple/gl/state.h>

namespace crumple::gl {

namespace {
void setEnabled(GLenum capability, GLboolean on) {
  if (on)
    glEnable(capability);
  else
    glDisable(capability);
}
}  // namespace

StateGuard::StateGuard() {
  glGetIntegerv(GL_VIEWPORT, viewport_);
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &drawFramebuffer_);
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &readFramebuffer_);
  glGetIntegerv(GL_CURRENT_PROGRAM, &program_);
  glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &vertexArray_);
  glGetIntegerv(GL_DEPTH_FUNC, &depthFunc_);
  glGetIntegerv(GL_CULL_FACE_MODE, &cullFace_);
  glGetBooleanv(GL_DEPTH_WRITEMASK, &depthMask_);
  depthTest_ = glIsEnabled(GL_DEPTH_TEST);
  cull_ = glIsEnabled(GL_CULL_FACE);
  blend_ = glIsEnabled(GL_BLEND);
}

StateGuard::~StateGuard() {
  glViewport(viewport_[0], viewport_[1], viewport_[2], viewport_[3]);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(drawFramebuffer_));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(readFramebuffer_));
  glUseProgram(static_cast<GLuint>(program_));
  glBindVertexArray(static_cast<GLuint>(vertexArray_));
  glDepthFunc(static_cast<GLenum>(depthFunc_));
  glCullFace(static_cast<GLenum>(cullFace_));
  glDepthMask(depthMask_);
  setEnabled(GL_DEPTH_TEST, depthTest_);
  setEnabled(GL_CULL_FACE, cull_);
  setEnabled(GL_BLEND, blend_);
}

}  // namespace crumple::gl
