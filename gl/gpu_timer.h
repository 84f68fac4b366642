// GPU time of stretches of GL commands, from pairs of GL_TIMESTAMP queries read
// back only once the GPU has passed them: a loop that times its GPU work this
// way never waits for the GPU (a glFinish per step or frame would stop the CPU
// from preparing the next one while the GPU works on this one).
#pragma once
#include <epoxy/gl.h>

#include <cstddef>
#include <vector>

namespace crumple::gl {

class GpuTimer {
 public:
  // A current GL context is needed from construction to destruction.
  explicit GpuTimer(size_t slots = 8);
  ~GpuTimer();
  GpuTimer(const GpuTimer&) = delete;
  GpuTimer& operator=(const GpuTimer&) = delete;
  // Marks the start and the end of a stretch (end(false): its time is not wanted). With every slot still
  // waiting on the GPU, begin() waits for the oldest.
  void begin();
  void end(bool keep = true);
  // Milliseconds of the kept stretches whose results have come back (polled, never waiting)...
  double ms();
  // ... and after waiting for all of them (the totals at the end of a run).
  double finish();
  size_t measured() const { return measured_; }  // kept stretches read so far

 private:
  struct Slot {
    GLuint query[2] = {0, 0};
    bool pending = false, keep = false;
  };
  void read(Slot& s, bool wait);
  std::vector<Slot> slots_;
  size_t next_ = 0;
  bool open_ = false;
  double ms_ = 0;
  size_t measured_ = 0;
};

}  // namespace crumple::gl
