#include <crumple/gl/gpu_timer.h>

namespace crumple::gl {

GpuTimer::GpuTimer(size_t slots) : slots_(slots > 0 ? slots : 1) {
  for (Slot& s : slots_) glCreateQueries(GL_TIMESTAMP, 2, s.query);
}

GpuTimer::~GpuTimer() {
  for (Slot& s : slots_) glDeleteQueries(2, s.query);
}

void GpuTimer::read(Slot& s, bool wait) {
  if (!s.pending) return;
  if (!wait) {
    GLint ready = 0;
    glGetQueryObjectiv(s.query[1], GL_QUERY_RESULT_AVAILABLE, &ready);
    if (!ready) return;
  }
  s.pending = false;
  if (!s.keep) return;
  GLuint64 t0 = 0, t1 = 0;  // (the end's result available: the start's is too, as it came first)
  glGetQueryObjectui64v(s.query[0], GL_QUERY_RESULT, &t0);
  glGetQueryObjectui64v(s.query[1], GL_QUERY_RESULT, &t1);
  ms_ += t1 > t0 ? static_cast<double>(t1 - t0) * 1e-6 : 0.0;
  ++measured_;
}

void GpuTimer::begin() {
  for (Slot& s : slots_) read(s, false);
  Slot& s = slots_[next_];
  read(s, true);  // (every slot still waiting: the GPU is that far behind)
  glQueryCounter(s.query[0], GL_TIMESTAMP);
  open_ = true;
}

void GpuTimer::end(bool keep) {
  if (!open_) return;
  Slot& s = slots_[next_];
  glQueryCounter(s.query[1], GL_TIMESTAMP);
  s.pending = true;
  s.keep = keep;
  open_ = false;
  next_ = (next_ + 1) % slots_.size();
}

double GpuTimer::ms() {
  for (Slot& s : slots_) read(s, false);
  return ms_;
}

double GpuTimer::finish() {
  for (Slot& s : slots_) read(s, true);
  return ms_;
}

}  // namespace crumple::gl
