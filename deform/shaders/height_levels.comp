#version 450 core
// height_levels.comp: a height map's mip levels over its uv charts alone (Deformer::chartLevels). The gutters
// between an atlas's charts hold the flat 0.5 of an undented map; levels made by averaging every texel would
// blend them into each chart's edge, so that a crushed panel read at a coarse level (the displaced renderer reads
// as coarse as the surface moves far) rises back towards flat along its edges, by how its border crosses the
// texel grid: a row of teeth along a crease. Here each level's texel is the mean of the covered level-0 texels
// under it (ChartCover's fractions as weights: push), and a texel no chart covers takes the level above's bilinear
// value at its centre (pull, from the coarsest level down), so a read near a chart's edge meets the chart's own
// heights. Level 0 is left as the deformer wrote it. By uStage:
//   0 (push): level uLevel from level uLevel - 1 (uFrom), each texel the covered mean of its 2 x 2 children
//   1 (pull): level uLevel's uncovered texels from level uLevel + 1 (uFrom), bilinear at the texel's centre
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0, r32f) uniform image2D uTo;             // bindings::levels::kTo: level uLevel
layout(binding = 1, r32f) readonly uniform image2D uFrom;  // bindings::levels::kFrom: the level it is made from
layout(std430, binding = 0) readonly buffer Cover { float uCover[]; };  // bindings::levels::kCover (ChartCover)
uniform int uStage;
uniform ivec2 uSize;      // level uLevel's size
uniform ivec2 uFromSize;  // uFrom's
uniform uint uCoverTo;    // ChartCover::offsets[uLevel]
uniform uint uCoverFrom;  // and uFrom's level's
// uFrom's height at texel t, clamped to its edges.
float fromAt(ivec2 t) { return imageLoad(uFrom, clamp(t, ivec2(0), uFromSize - 1)).r; }
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= uSize.x || p.y >= uSize.y) return;
  if (uStage == 0) {
    float sum = 0.0, weight = 0.0;
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        ivec2 c = 2 * p + ivec2(i, j);
        if (c.x >= uFromSize.x || c.y >= uFromSize.y) continue;
        float w = uCover[uCoverFrom + uint(c.y * uFromSize.x + c.x)];
        sum += w * imageLoad(uFrom, c).r;
        weight += w;
      }
    imageStore(uTo, p, vec4(weight > 0.0 ? sum / weight : 0.5));
  } else {
    if (uCover[uCoverTo + uint(p.y * uSize.x + p.x)] > 0.0) return;
    vec2 at = (vec2(p) + 0.5) * vec2(uFromSize) / vec2(uSize) - 0.5;  // in the level above's texels
    ivec2 a = ivec2(floor(at));
    vec2 f = at - vec2(a);
    float h00 = fromAt(a), h10 = fromAt(a + ivec2(1, 0)), h01 = fromAt(a + ivec2(0, 1)), h11 = fromAt(a + ivec2(1));
    imageStore(uTo, p, vec4(mix(mix(h00, h10, f.x), mix(h01, h11, f.x), f.y)));
  }
}
