// The deformation stage's options (GL-free: scene files and the engine hold them).
#pragma once

namespace crumple::deform {

// The bump-map update (deformer.h says how each works): a per-texel gather on
// the GPU (the default, no gaps), or the paper's scatter, on the GPU or read
// back to the CPU.
enum class Path { Gather, Scatter, Readback };
const char* pathName(Path p);  // "gather", "scatter", "readback"
enum class TangentMode { None, Multiply, Divide };

struct DeformOptions {
  int addressMap = 512;
  Path path = Path::Gather;
  TangentMode tangent = TangentMode::None;
  float tangentFloor = 0.2f;
  bool craterRims = false;  // raise a ring around each dent by the volume it pushed down
  // Measure: glFinish at each phase boundary and record the wall time of each
  // phase (profile()). Slows the stage down; for crumple-bench --deform-profile.
  bool profile = false;
};

}  // namespace crumple::deform
