// commit_side.glsl (included): the commit's sides (CommitPass::run), one entry each, in groups of 8 a dispatch:
// workgroup z takes entry uFirst + z, its maps at index z of the shader's sampler and image arrays, reached by
// constant indices in a switch (EACH8): Mesa's llvmpipe read a shader's other samplers as zero once an array of
// them was indexed by a variable.
struct CommitEntry {
  int slot;         // its region in uRegion / uNormalRegion
  int resolution;   // its map's
  int grow;         // 1: the region grows by its crater rim's ring (uRimRing[slot])
  int statsIndex;
  uint scratchBase;  // its new heights in uScratch
  float bumpDepth;   // k (m)
  float slopeScale;  // k / (2 * texel size in metres)
  int group;         // its dispatch (uArgs[9 group ..])
  int changeLog;     // its map's change-log id (Surface::changeLog), -1: its changes are not logged
};
layout(std430, binding = 6) readonly buffer CommitEntries { CommitEntry uEntry[]; };  // bindings::commit::kEntries
uniform int uFirst;
// Where level k of a bound pyramid lies in its texture (SurfaceMaps::boundOrigin; S: level 0's side).
ivec2 boundOrigin(int S, int k) { return k == 0 ? ivec2(0) : ivec2(S, S - 2 * (S >> k)); }
#define EACH8(M) case 0: M(0); break; case 1: M(1); break; case 2: M(2); break; case 3: M(3); break; \
  case 4: M(4); break; case 5: M(5); break; case 6: M(6); break; case 7: M(7); break;
