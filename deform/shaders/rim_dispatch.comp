#version 450 core
// rim_dispatch.comp: the crater rim's ring width W for side uSide's touched region (craterRing(): a quarter of
// the region's longer side, 2 to 16 texels) and the rim passes' indirect dispatch sizes (16x16 groups over the
// region grown by W, at most the map), on the GPU: the deformation never waits to read the region back.
// in:  uRegion[uSide]; out: uRimIndirect[uSide * 3 .. + 2], uRimRing[uSide] (0: nothing dented)
layout(local_size_x = 1) in;
layout(std430, binding = 0) buffer Region { ivec4 uRegion[]; };  // bindings::kRegion
layout(std430, binding = 5) buffer Rim { uint uRimIndirect[6]; int uRimRing[2]; };  // bindings::rim::kRim
uniform int uSide;
uniform int uResolution;
void main() {
  ivec4 r = uRegion[uSide];
  uint base = uint(uSide) * 3u;
  if (r.z < r.x) {
    uRimIndirect[base] = 0u;
    uRimIndirect[base + 1u] = 0u;
    uRimIndirect[base + 2u] = 1u;
    uRimRing[uSide] = 0;
    return;
  }
  int w = r.z - r.x + 1, h = r.w - r.y + 1;
  int ring = clamp(max(w, h) / 4, 2, 16);
  uRimIndirect[base] = uint((min(uResolution, w + 2 * ring) + 15) / 16);
  uRimIndirect[base + 1u] = uint((min(uResolution, h + 2 * ring) + 15) / 16);
  uRimIndirect[base + 2u] = 1u;
  uRimRing[uSide] = ring;
}
