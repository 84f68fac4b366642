#version 450 core
// sky.frag: crumple's analytic sky (a gradient from a pale horizon to a deep
// zenith, brightened towards the sun, a sun disc and glow; a dark ground below
// the horizon). Drawn as the background (tone mapped) and into the environment
// cube map (linear radiance, no disc: the sun is a direct light there).
// in:  vNdc; uBasis maps (ndc.x, ndc.y, 1) to a world direction
// out: fragColor
in vec2 vNdc;
uniform mat3 uBasis;
uniform vec3 uToSun, uSunColor, uSkyColor, uGroundColor;
uniform bool uBackground;  // true: sun disc, exposure and tone map
uniform float uExposure;
out vec4 fragColor;

vec3 acesFit(vec3 x) { return clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); }

vec3 sky(vec3 d) {
  vec3 sunDir = normalize(uToSun);
  float mu = max(dot(d, sunDir), 0.0);
  vec3 horizon = mix(uSkyColor, vec3(0.92, 0.96, 1.0), 0.6);
  vec3 zenith = uSkyColor * vec3(0.4, 0.72, 1.5);
  float y = clamp(d.y, 0.0, 1.0);
  vec3 c = mix(horizon, zenith, pow(y, 0.45));
  c += uSunColor * (0.12 * pow(mu, 6.0) + 0.35 * pow(mu, 90.0)) * (0.4 + 0.6 * (1.0 - y));
  // Below the horizon: a ground lit by the sun and sky, dimmer away from the horizon's haze.
  vec3 ground = uGroundColor * (0.9 + 0.9 * max(sunDir.y, 0.0));
  vec3 haze = mix(ground, horizon, 0.35);
  vec3 below = mix(haze, ground, smoothstep(0.0, 0.08, -d.y));
  c = mix(below, c, smoothstep(-0.012, 0.004, d.y));
  return c;
}

void main() {
  vec3 d = normalize(uBasis * vec3(vNdc, 1.0));
  vec3 c = sky(d);
  if (uBackground) {
    float mu = dot(d, normalize(uToSun));
    c += uSunColor * 30.0 * smoothstep(0.99996, 0.99999, mu);
    c = acesFit(c * uExposure);
  }
  fragColor = vec4(c, 1.0);
}
