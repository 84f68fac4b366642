#version 450 core
// brdf_lut.frag: the split-sum table of GGX (Smith G, Schlick F): for n.v (x)
// and roughness (y), the scale and bias of F0 in the environment's specular.
// in: vUV (texel centres); out: fragColor.rg
in vec2 vUV;
out vec4 fragColor;
const float PI = 3.14159265;

vec2 hammersley(uint i, uint n) { return vec2(float(i) / float(n), float(bitfieldReverse(i)) * 2.3283064365386963e-10); }

void main() {
  float NV = max(vUV.x, 1e-3), rough = vUV.y;
  float a = rough * rough, k = a / 2.0;
  vec3 V = vec3(sqrt(1.0 - NV * NV), 0.0, NV);
  float A = 0.0, Bs = 0.0;
  const uint n = 128u;
  for (uint i = 0u; i < n; ++i) {
    vec2 xi = hammersley(i, n);
    float phi = 2.0 * PI * xi.x;
    float cosT = sqrt((1.0 - xi.y) / (1.0 + (a * a - 1.0) * xi.y)), sinT = sqrt(1.0 - cosT * cosT);
    vec3 H = vec3(cos(phi) * sinT, sin(phi) * sinT, cosT);
    vec3 L = 2.0 * dot(V, H) * H - V;
    float NL = max(L.z, 0.0), NH = max(H.z, 0.0), VH = max(dot(V, H), 0.0);
    if (NL <= 0.0) continue;
    float G = (NL / (NL * (1.0 - k) + k)) * (NV / (NV * (1.0 - k) + k));
    float Gv = G * VH / max(NH * NV, 1e-6);
    float Fc = pow(1.0 - VH, 5.0);
    A += (1.0 - Fc) * Gv;
    Bs += Fc * Gv;
  }
  fragColor = vec4(A / float(n), Bs / float(n), 0.0, 1.0);
}
