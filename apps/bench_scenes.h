// crumple-bench's scenes, described once and built in each engine it compares
// (crumple, Bullet, and Jolt where a Jolt build is given: bench_jolt.cpp).
#pragma once
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <memory>
#include <string>
#include <vector>

#include <crumple/engine/primitives.h>

namespace crumple::bench {

enum class Kind { Box, Sphere, Capsule, Torus };
struct BodySpec {
  Kind kind = Kind::Box;
  glm::dvec3 size{0};  // box: full size; sphere: radius in x; capsule: radius in x, straight height in y
  glm::dvec3 position{0};
  glm::dquat orientation{1, 0, 0, 0};
  double friction = 0.6, restitution = 0.1, density = 1000;
};
struct SceneSpec {
  std::vector<BodySpec> bodies;
  // Chains of 0.2 m box links (1 kg), ball-jointed end to end, the first to the world; laid out
  // horizontally so they fall and swing.
  int chains = 0, links = 0;
};
// Every scene stands on a static 60 x 1 x 60 m ground box whose top is y = 0 (friction 0.6, restitution 0.1).
constexpr double kLink = 0.2;
inline glm::dvec3 chainPivot(int c) { return {-2.0, 5.0, -2.0 + 0.5 * c}; }
// The torus of the tori and heap scenes (ring radius 0.3 m, tube 0.1 m).
constexpr float kTorusRing = 0.3f, kTorusTube = 0.1f;
constexpr int kTorusSegments = 16, kTorusSides = 8;
inline TriangleMesh benchTorus() { return torusMesh(kTorusRing, kTorusTube, kTorusSegments, kTorusSides); }

// An engine compared beside crumple and Bullet, built outside crumple (bench_jolt.cpp).
class PeerWorld {
 public:
  virtual ~PeerWorld() = default;
  virtual void step(double h) = 0;
  virtual int bodies() const = 0;  // dynamic bodies
  virtual int awake() const = 0;
  virtual double top() const = 0;  // the highest centre of a dynamic body
};
// Jolt (when crumple-bench was built with CRUMPLE_JOLT_DIR), single-threaded; nullptr otherwise.
std::unique_ptr<PeerWorld> makeJoltWorld(const SceneSpec& spec);
bool joltBuilt();
// How the linked Jolt was built: its own configuration string (JPH::GetConfigurationString: instruction sets,
// precision, asserts, profiler, debug renderer) and a warning for each option that slows it (profiler, debug
// renderer, asserts, floating-point exceptions); empty without Jolt.
std::string joltConfiguration();
std::vector<std::string> joltWarnings();
// Leaves the vector registers' upper halves clean after Jolt's code (AVX2) has run: crumple and Bullet are
// SSE2 code, and every SSE instruction after dirty upper halves pays a transition penalty (crumple's rows
// after a Jolt row ran 1.3-1.5 times slower, its sleep stage 6 times). A no-op without Jolt.
void joltLeaveClean();

}  // namespace crumple::bench
