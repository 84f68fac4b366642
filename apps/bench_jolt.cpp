// crumple-bench's Jolt peer: the bench's scenes built in Jolt Physics, stepped on
// one thread (JobSystemSingleThreaded), one collision step per 1/240 s step, Jolt's
// default solver settings (10 velocity and 2 position iterations, sleep after 0.5 s
// as crumple's). Compiled only when crumple-bench is configured with
// CRUMPLE_JOLT_DIR, the install prefix of a Jolt build made outside crumple
// (tools/build-jolt.sh); crumple never needs it, and no Jolt code lives here.
//
// What differs from the scene as crumple and Bullet build it, because Jolt has
// no dynamic nonconvex mesh body: a torus is a compound of one convex hull per
// segment of its mesh (16, each the hull of the segment's two rings), the
// decomposition a Jolt user would make. Boxes keep Jolt's default convex radius
// (5 cm, less where a box is thinner).
#include <Jolt/Jolt.h>

#include <Jolt/Core/Factory.h>
#include <Jolt/Core/JobSystemSingleThreaded.h>
#include <Jolt/Core/TempAllocator.h>
#include <Jolt/Physics/Body/BodyCreationSettings.h>
#include <Jolt/Physics/Collision/GroupFilterTable.h>
#include <Jolt/Physics/Collision/Shape/BoxShape.h>
#include <Jolt/Physics/Collision/Shape/CapsuleShape.h>
#include <Jolt/Physics/Collision/Shape/ConvexHullShape.h>
#include <Jolt/Physics/Collision/Shape/SphereShape.h>
#include <Jolt/Physics/Collision/Shape/StaticCompoundShape.h>
#include <Jolt/Physics/Constraints/PointConstraint.h>
#include <Jolt/Physics/PhysicsSystem.h>
#include <Jolt/RegisterTypes.h>

#if defined(__AVX__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cstdio>
#include <map>
#include <mutex>
#include <stdexcept>
#include <tuple>

#include <Jolt/ConfigurationString.h>

#include "bench_scenes.h"

namespace crumple::bench {

namespace {

namespace layers {
constexpr JPH::ObjectLayer kStatic = 0, kMoving = 1, kCount = 2;
}

class BroadPhaseLayers final : public JPH::BroadPhaseLayerInterface {
 public:
  JPH::uint GetNumBroadPhaseLayers() const override { return 2; }
  JPH::BroadPhaseLayer GetBroadPhaseLayer(JPH::ObjectLayer layer) const override {
    return JPH::BroadPhaseLayer(static_cast<JPH::uint8>(layer));
  }
#if defined(JPH_EXTERNAL_PROFILE) || defined(JPH_PROFILE_ENABLED)
  const char* GetBroadPhaseLayerName(JPH::BroadPhaseLayer layer) const override {
    return layer.GetValue() == 0 ? "static" : "moving";
  }
#endif
};
class ObjectVsBroadPhase final : public JPH::ObjectVsBroadPhaseLayerFilter {
 public:
  bool ShouldCollide(JPH::ObjectLayer layer, JPH::BroadPhaseLayer bp) const override {
    return layer == layers::kMoving || bp.GetValue() == layers::kMoving;
  }
};
class ObjectPairs final : public JPH::ObjectLayerPairFilter {
 public:
  bool ShouldCollide(JPH::ObjectLayer a, JPH::ObjectLayer b) const override {
    return a == layers::kMoving || b == layers::kMoving;
  }
};

JPH::Vec3 v3(const glm::dvec3& v) {
  return JPH::Vec3(static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z));
}
JPH::Quat quat(const glm::dquat& q) {
  return JPH::Quat(static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z), static_cast<float>(q.w));
}

void registerJolt() {
  static std::once_flag once;
  std::call_once(once, [] {
    JPH::RegisterDefaultAllocator();
    JPH::Factory::sInstance = new JPH::Factory();
    JPH::RegisterTypes();
  });
}

// The bench torus as Jolt can hold it: one convex hull per segment of its mesh.
JPH::RefConst<JPH::Shape> torusCompound(double density) {
  const TriangleMesh mesh = benchTorus();
  JPH::StaticCompoundShapeSettings compound;
  const int ring = kTorusSides + 1;  // torusMesh's vertices per ring (the seam repeated)
  for (int i = 0; i < kTorusSegments; ++i) {
    JPH::Array<JPH::Vec3> points;
    for (int k = i * ring; k < (i + 2) * ring; ++k)
      points.push_back(JPH::Vec3(mesh.positions[static_cast<size_t>(k)].x, mesh.positions[static_cast<size_t>(k)].y,
                                 mesh.positions[static_cast<size_t>(k)].z));
    auto* hull = new JPH::ConvexHullShapeSettings(points, 0.02f);
    hull->SetDensity(static_cast<float>(density));
    compound.AddShape(JPH::Vec3::sZero(), JPH::Quat::sIdentity(), hull);
  }
  JPH::ShapeSettings::ShapeResult made = compound.Create();
  if (made.HasError()) throw std::runtime_error("Jolt torus compound: " + std::string(made.GetError().c_str()));
  return made.Get();
}

class JoltWorld final : public PeerWorld {
 public:
  explicit JoltWorld(const SceneSpec& spec)
      : temp_(512u * 1024u * 1024u), jobs_(JPH::cMaxPhysicsJobs) {
    const JPH::uint bodies = static_cast<JPH::uint>(spec.bodies.size() + static_cast<size_t>(spec.chains * spec.links) + 1);
    const JPH::uint pairs = std::max<JPH::uint>(65536, 16 * bodies);
    system_.Init(bodies, 0, pairs, pairs, broad_, objectVsBroad_, objectPairs_);
    JPH::BodyInterface& bi = system_.GetBodyInterfaceNoLock();
    {
      JPH::BodyCreationSettings ground(new JPH::BoxShape(JPH::Vec3(30, 0.5f, 30)), JPH::RVec3(0, -0.5, 0),
                                       JPH::Quat::sIdentity(), JPH::EMotionType::Static, layers::kStatic);
      ground.mFriction = 0.6f;
      ground.mRestitution = 0.1f;
      bi.CreateAndAddBody(ground, JPH::EActivation::DontActivate);
    }
    // One shape per distinct kind, size and density, shared by its bodies (as the other engines' sides do).
    std::map<std::tuple<int, double, double, double, double>, JPH::RefConst<JPH::Shape>> shapes;
    for (const BodySpec& b : spec.bodies) {
      JPH::RefConst<JPH::Shape>& shape = shapes[{static_cast<int>(b.kind), b.size.x, b.size.y, b.size.z, b.density}];
      if (!shape) shape = makeShape(b);
      JPH::BodyCreationSettings s(shape, JPH::RVec3(v3(b.position)), quat(b.orientation), JPH::EMotionType::Dynamic,
                                  layers::kMoving);
      s.mFriction = static_cast<float>(b.friction);
      s.mRestitution = static_cast<float>(b.restitution);
      ids_.push_back(bi.CreateAndAddBody(s, JPH::EActivation::Activate));
    }
    if (spec.chains > 0) {
      // Joined links do not collide (as in crumple and Bullet): each chain a group, its links sub-groups.
      auto* filter = new JPH::GroupFilterTable(static_cast<JPH::uint>(spec.links));
      for (int k = 0; k + 1 < spec.links; ++k)
        filter->DisableCollision(static_cast<JPH::CollisionGroup::SubGroupID>(k),
                                 static_cast<JPH::CollisionGroup::SubGroupID>(k + 1));
      chainFilter_ = filter;
      const float half = static_cast<float>(kLink / 2);
      JPH::RefConst<JPH::Shape> link = new JPH::BoxShape(JPH::Vec3(half, 0.02f, 0.02f), 0.01f);
      for (int c = 0; c < spec.chains; ++c) {
        JPH::Body* previous = &JPH::Body::sFixedToWorld;
        for (int k = 0; k < spec.links; ++k) {
          const glm::dvec3 p = chainPivot(c) + glm::dvec3((k + 0.5) * kLink, 0, 0);
          JPH::BodyCreationSettings s(link, JPH::RVec3(v3(p)), JPH::Quat::sIdentity(), JPH::EMotionType::Dynamic,
                                      layers::kMoving);
          s.mFriction = 0.5f;
          s.mRestitution = 0.5f;
          s.mOverrideMassProperties = JPH::EOverrideMassProperties::CalculateInertia;
          s.mMassPropertiesOverride.mMass = 1.0f;
          s.mCollisionGroup = JPH::CollisionGroup(chainFilter_, static_cast<JPH::CollisionGroup::GroupID>(c),
                                                  static_cast<JPH::CollisionGroup::SubGroupID>(k));
          JPH::Body* body = bi.CreateBody(s);
          bi.AddBody(body->GetID(), JPH::EActivation::Activate);
          ids_.push_back(body->GetID());
          JPH::PointConstraintSettings joint;
          joint.mPoint1 = joint.mPoint2 = JPH::RVec3(v3(chainPivot(c) + glm::dvec3(k * kLink, 0, 0)));
          system_.AddConstraint(joint.Create(*previous, *body));
          previous = body;
        }
      }
    }
    system_.OptimizeBroadPhase();
  }
  void step(double h) override {
    const struct Clean {
      ~Clean() { joltLeaveClean(); }
    } clean;
    const JPH::EPhysicsUpdateError e = system_.Update(static_cast<float>(h), 1, &temp_, &jobs_);
    if (e != JPH::EPhysicsUpdateError::None) errors_ |= static_cast<unsigned>(e);
  }
  int bodies() const override { return static_cast<int>(ids_.size()); }
  int awake() const override {
    const JPH::BodyInterface& bi = system_.GetBodyInterfaceNoLock();
    return static_cast<int>(std::count_if(ids_.begin(), ids_.end(), [&](JPH::BodyID id) { return bi.IsActive(id); }));
  }
  double top() const override {
    const JPH::BodyInterface& bi = system_.GetBodyInterfaceNoLock();
    double y = 0;
    for (JPH::BodyID id : ids_) y = std::max(y, static_cast<double>(bi.GetCenterOfMassPosition(id).GetY()));
    return y;
  }
  ~JoltWorld() override {
    if (errors_)
      std::fprintf(stderr, "crumple-bench: Jolt reported update errors (%#x): raise its body-pair or contact limits\n",
                   errors_);
  }

 private:
  static JPH::RefConst<JPH::Shape> makeShape(const BodySpec& b) {
    JPH::Ref<JPH::ConvexShape> convex;
    switch (b.kind) {
      case Kind::Box:
        convex = new JPH::BoxShape(v3(b.size * 0.5));
        break;
      case Kind::Sphere:
        convex = new JPH::SphereShape(static_cast<float>(b.size.x));
        break;
      case Kind::Capsule:  // along y, b.size.y the straight part
        convex = new JPH::CapsuleShape(static_cast<float>(b.size.y / 2), static_cast<float>(b.size.x));
        break;
      case Kind::Torus:
        return torusCompound(b.density);
    }
    convex->SetDensity(static_cast<float>(b.density));
    return JPH::RefConst<JPH::Shape>(convex.GetPtr());
  }

  BroadPhaseLayers broad_;
  ObjectVsBroadPhase objectVsBroad_;
  ObjectPairs objectPairs_;
  JPH::PhysicsSystem system_;
  JPH::TempAllocatorImpl temp_;
  JPH::JobSystemSingleThreaded jobs_;
  JPH::Ref<JPH::GroupFilter> chainFilter_;
  std::vector<JPH::BodyID> ids_;
  unsigned errors_ = 0;
};

}  // namespace

std::unique_ptr<PeerWorld> makeJoltWorld(const SceneSpec& spec) {
  registerJolt();
  return std::make_unique<JoltWorld>(spec);
}
bool joltBuilt() { return true; }
std::string joltConfiguration() { return JPH::GetConfigurationString(); }
std::vector<std::string> joltWarnings() {
  std::vector<std::string> w;
#if defined(JPH_PROFILE_ENABLED)
  w.push_back("Jolt was built with its profiler (JPH_PROFILE_ENABLED): its rows are slower than a Release build's");
#endif
#if defined(JPH_DEBUG_RENDERER)
  w.push_back("Jolt was built with its debug renderer (JPH_DEBUG_RENDERER)");
#endif
#if defined(JPH_ENABLE_ASSERTS)
  w.push_back("Jolt was built with asserts (JPH_ENABLE_ASSERTS)");
#endif
#if defined(JPH_FLOATING_POINT_EXCEPTIONS_ENABLED)
  w.push_back("Jolt was built with floating-point exceptions on (JPH_FLOATING_POINT_EXCEPTIONS_ENABLED)");
#endif
#if defined(_DEBUG) || !defined(NDEBUG)
  w.push_back("Jolt's headers were compiled without NDEBUG (a Debug configuration)");
#endif
  return w;
}
void joltLeaveClean() {
#if defined(__AVX__)
  _mm256_zeroupper();  // (a Jolt built without AVX leaves nothing to clean)
#endif
}

}  // namespace crumple::bench
