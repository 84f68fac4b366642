// Joints: what holds bodies together (Weinstein, Teran & Fedkiw 2006, on top of
// the Guendelman step; physics/joint_step.cpp says how they are enforced).
//
// Every joint is defined in world terms at the moment it is added: the anchor
// is one world point (each body keeps it in its own frame from then on), the
// axis a world direction (kept in both bodies' frames). Angles are radians
// here (scene files use degrees); angle 0 and offset 0 are the pose at creation.
#pragma once
#include <glm/glm.hpp>

#include <cstdint>
#include <limits>
#include <string>

namespace crumple {

enum class JointType {
  Ball,      // the anchor points coincide
  Hinge,     // ball + the bodies turn only about the axis
  Slider,    // the bodies move only along the axis and never turn relative to each other
  Fixed,     // no relative motion (a weld)
  Distance,  // the two anchors stay `length` apart, or within [minLength, maxLength] (a rope when min is 0)
};

const char* jointTypeName(JointType t);

// A velocity target along the joint's free axis, reached with a bounded effort.
struct JointMotor {
  bool enabled = false;
  double speed = 0;     // rad/s (hinge) or m/s (slider): B relative to A about / along the axis
  double maxForce = 0;  // N m (hinge) or N (slider); the impulse per step is at most maxForce * h
};

struct JointDef {
  JointType type = JointType::Ball;
  int a = -1;  // body index; -1 is the static world
  int b = -1;  // body index (required)
  glm::dvec3 anchor{0};                // world point, for ball, hinge, slider and fixed
  glm::dvec3 anchorA{0}, anchorB{0};   // world points, for distance
  glm::dvec3 axis{0, 1, 0};            // world direction (hinge, slider); normalised when added
  bool limited = false;                // hinge: angle in [lower, upper] (rad); slider: offset (m)
  double lower = 0, upper = 0;
  double length = -1;                  // distance: < 0 takes the anchors' distance when added
  double minLength = -1, maxLength = -1;  // distance: maxLength >= 0 makes a range [minLength (0 when < 0), maxLength]
  JointMotor motor;                    // hinge and slider
  // N s (see JointState::impulse). A joint asked for more in a step yields: it passes on only its
  // breakImpulse, breaks, and the rest of the push stays with the bodies.
  double breakImpulse = std::numeric_limits<double>::infinity();
  bool collideConnected = false;       // whether a and b still collide with each other
};

// A joint's state as the API reads it back.
struct JointState {
  bool broken = false;   // broke under its breakImpulse: enforces nothing from then on (the same step included)
  double angle = 0;      // hinge: B's turn relative to A about the axis since creation (rad, not wrapped)
  double offset = 0;     // slider: B's anchor along the axis relative to A's (m); distance: the anchors' distance
  // N s: the size of the linear impulse the joint applied at its anchor over the last step (pre- and
  // post-stabilisation, limits and motor, all substeps, summed as vectors). This is what breakImpulse
  // is compared with; the torques that hold a hinge's or a weld's axes are not in it.
  double impulse = 0;
};

// A handle to a joint (see BodyId): stale once the joint is removed and its slot reused.
struct JointId {
  int32_t index = -1;
  uint32_t generation = 0;
  bool operator==(const JointId&) const = default;
};

struct JointBreak {
  double time = 0;  // the world's time at the end of the substep in which it broke
  int joint = -1;
  double impulse = 0;  // the impulse the step asked of it (over breakImpulse; it passed on only breakImpulse)
};

}  // namespace crumple
