#version 450 core
// prefilter.frag: one face of a cube map level, integrated from the environment
// cube uEnv. uMode 0: the specular lobe of GGX at uRoughness for the split-sum
// approximation (N = V = R, importance sampled; each sample reads a mip level
// that matches its solid angle, so few samples stay smooth). uMode 1: the
// diffuse irradiance over pi (cosine-weighted average radiance).
// in:  vNdc; uBasis maps (ndc.x, ndc.y, 1) to the texel's direction
// out: fragColor (linear radiance)
in vec2 vNdc;
layout(binding = 0) uniform samplerCube uEnv;  // renderer.cpp kSource
uniform mat3 uBasis;
uniform float uRoughness;
uniform int uMode;
uniform int uSamples;
out vec4 fragColor;
const float PI = 3.14159265;

vec2 hammersley(uint i, uint n) { return vec2(float(i) / float(n), float(bitfieldReverse(i)) * 2.3283064365386963e-10); }

void main() {
  vec3 N = normalize(uBasis * vec3(vNdc, 1.0));
  vec3 up = abs(N.y) < 0.999 ? vec3(0, 1, 0) : vec3(1, 0, 0);
  vec3 T = normalize(cross(up, N)), B = cross(N, T);
  float envSize = float(textureSize(uEnv, 0).x);
  float texelSolidAngle = 4.0 * PI / (6.0 * envSize * envSize);
  vec3 sum = vec3(0.0);
  float weight = 0.0;
  uint n = uint(uSamples);
  for (uint i = 0u; i < n; ++i) {
    vec2 xi = hammersley(i, n);
    float phi = 2.0 * PI * xi.x;
    if (uMode == 1) {
      float cosT = sqrt(1.0 - xi.y), sinT = sqrt(xi.y);
      vec3 L = T * (cos(phi) * sinT) + B * (sin(phi) * sinT) + N * cosT;
      float pdf = cosT / PI;
      float lod = 0.5 * log2(1.0 / (float(n) * max(pdf, 1e-4) * texelSolidAngle)) + 1.0;
      sum += textureLod(uEnv, L, max(lod, 0.0)).rgb;
      weight += 1.0;
    } else {
      float a = uRoughness * uRoughness;
      float cosT = sqrt((1.0 - xi.y) / (1.0 + (a * a - 1.0) * xi.y)), sinT = sqrt(1.0 - cosT * cosT);
      vec3 H = T * (cos(phi) * sinT) + B * (sin(phi) * sinT) + N * cosT;
      vec3 L = 2.0 * dot(N, H) * H - N;
      float NL = dot(N, L);
      if (NL <= 0.0) continue;
      float NH = cosT;
      float dd = NH * NH * (a * a - 1.0) + 1.0;
      float D = a * a / (PI * dd * dd);
      float pdf = D / 4.0;  // D NH / (4 VH) with V = N
      float lod = 0.5 * log2(1.0 / (float(n) * max(pdf, 1e-4) * texelSolidAngle)) + 1.0;
      sum += textureLod(uEnv, L, max(lod, 0.0)).rgb * NL;
      weight += NL;
    }
  }
  fragColor = vec4(sum / max(weight, 1e-6), 1.0);
}
