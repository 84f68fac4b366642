// The deformation stage's options (GL-free: scene files and the engine hold them).
#pragma once
#include <cstddef>

namespace crumple::deform {

// The bump-map update (deformer.h says how each works): a per-texel gather on
// the GPU (the default, no gaps), or the paper's scatter, on the GPU or read
// back to the CPU.
enum class Path { Gather, Scatter, Readback };
const char* pathName(Path p);  // "gather", "scatter", "readback"
enum class TangentMode { None, Multiply, Divide };
// Who rasterises the gather's address pass (the other body's back faces) and visits X's texels: compute shaders
// (a binned rasteriser on every multiprocessor, then X's texels per tile of its map) or the fragment stage (the
// pass drawn, X drawn in its texture space). Auto: compute on NVIDIA's data-centre GPUs (H100, H200, A100,
// B200 and kin), whose fragment stage runs on a few of their multiprocessors, else the fragment stage. The two
// agree up to rounding at triangle edges (tests/test_deform.cpp); a run uses one, so its outputs stay bit-identical.
enum class AddressRaster { Auto, Compute, Fragment };
const char* addressRasterName(AddressRaster r);  // "auto", "compute", "fragment"
// Auto resolved for the OpenGL renderer named `renderer` (GL_RENDERER): Compute or Fragment.
AddressRaster resolveAddressRaster(AddressRaster r, const char* renderer);

struct DeformOptions {
  int addressMap = 512;
  Path path = Path::Gather;
  TangentMode tangent = TangentMode::None;
  float tangentFloor = 0.2f;
  bool craterRims = false;  // raise a ring around each dent by the volume it pushed down
  AddressRaster addressRaster = AddressRaster::Auto;
  // GPU memory a wave of events (Deformer::deform of several) may hold for its sides' address passes (33.6 MB an
  // event at address map 1024): 1 GiB is 31 events at 1024, 127 at 512, 7 at 2048. A wave's stages cost about as
  // much for many sides as for a few (a dispatch for many), so larger waves save time; the compute rasteriser,
  // which makes waves, is picked on data-centre GPUs (40 GB and more).
  size_t waveMemory = size_t(1) << 30;
  // Entries of the change log (Deformer::logChanges) the engine keeps where dents are felt: the texels one step's
  // deformations may change before the maps dented in it are read back whole instead (12 bytes an entry).
  size_t changeLog = size_t(1) << 20;
  // Measure: glFinish at each phase boundary and record the wall time of each
  // phase (profile()). Slows the stage down; for crumple-bench --deform-profile.
  bool profile = false;
};

}  // namespace crumple::deform
