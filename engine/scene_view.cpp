#include <crumple/engine/scene_view.h>

#include <crumple/engine/surface_bake.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace crumple {

std::vector<render::RenderItem> renderItems(const Simulation& sim) {
  std::vector<render::RenderItem> items;
  for (size_t i = 0; i < sim.bodies().size(); ++i) {
    const BodyRuntime& b = sim.bodies()[i];
    if (!b.gpuMesh) continue;
    render::RenderItem it;
    it.vao = b.gpuMesh->vao.id();
    it.indexCount = b.gpuMesh->indexCount;
    if (b.gpuMesh->simplifiedIndexCount > 0) {
      it.simplifiedVao = b.gpuMesh->simplifiedVao.id();
      it.simplifiedIndexCount = b.gpuMesh->simplifiedIndexCount;
      it.shadowVao = b.gpuMesh->shadowVao.id();
      it.shadowIndexCount = b.gpuMesh->shadowIndexCount;
    }
    it.model = glm::mat4(sim.model(static_cast<int>(i)));
    it.color = b.material->color;
    it.metallic = b.material->metallic;
    it.roughness = b.material->roughness;
    it.texture = surfaceTextureNamed(b.material->texture);
    it.textureScale = b.material->textureScale;
    it.look = b.look.get();
    it.ownColor = !b.material->hasColor;
    it.ownMetallic = !b.material->hasMetallic;
    it.ownRoughness = !b.material->hasRoughness;
    it.boundsMin = b.gpuMesh->boundsMin;
    it.boundsMax = b.gpuMesh->boundsMax;
    if (b.surface) {
      it.height = b.surface->height().id();
      it.normal = b.surface->normal().id();
      it.heightBound = b.surface->maps().bound.id();
      it.boundTile = deform::SurfaceMaps::kBoundTile;
      it.bumpDepth = b.surface->bumpDepth();
      it.seamEdges = b.gpuMesh->seamEdges.id();
      it.seamVertices = b.gpuMesh->seamVertices.id();
      it.metresPerUv = static_cast<float>(b.gpuMesh->metresPerUv);
      if (const gl::Buffer* crease = b.surface->crease()) {
        it.vertexNodes = b.gpuMesh->vertexNodes.id();
        it.crease = crease->id();
      }
    }
    items.push_back(it);
  }
  std::vector<VehiclePart> parts = sim.vehicleParts();
  for (const VehiclePart& part : sim.jointParts()) parts.push_back(part);
  for (const VehiclePart& part : parts) {
    if (!part.mesh) continue;  // (without GL)
    render::RenderItem it;
    it.vao = part.mesh->vao.id();
    it.indexCount = part.mesh->indexCount;
    it.model = glm::mat4(part.model);
    it.color = part.color;
    it.roughness = 0.85f;  // tyres, belts, joint links: rubber and dull metal
    it.boundsMin = part.mesh->boundsMin;
    it.boundsMax = part.mesh->boundsMax;
    items.push_back(it);
  }
  return items;
}

double drawFrame(Simulation& sim, render::Renderer& renderer, const render::View& view) {
  const auto t0 = std::chrono::steady_clock::now();
  if (sim.renderTimer()) sim.renderTimer()->begin();
  if (renderer.settings().displace || view.displace) sim.updateCreaseBevels();
  renderer.draw(renderItems(sim), view);
  if (sim.renderTimer()) sim.renderTimer()->end();
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  sim.timings().renderMs += ms;
  return ms;
}

render::View cameraView(const CameraDesc& c, const Simulation* sim) {
  render::View v;
  glm::dvec3 eye = c.position, target = c.target;
  if (!c.follow.empty() && sim) {
    for (const BodyRuntime& b : sim->bodies()) {
      if (b.name != c.follow) continue;
      const RigidBody& rb = sim->world().body(b.index);
      glm::dmat3 axes(1);
      if (c.followHeading) {
        // The body's x on the ground plane (normal to up) gives the heading.
        const glm::dvec3 up = glm::normalize(c.up);
        glm::dvec3 fwd = glm::mat3_cast(rb.q) * glm::dvec3(1, 0, 0);
        fwd -= up * glm::dot(fwd, up);
        if (glm::length(fwd) > 1e-6) {
          fwd = glm::normalize(fwd);
          axes = glm::dmat3(fwd, up, glm::cross(fwd, up));
        }
      }
      eye = rb.x + axes * c.position;
      target = rb.x + axes * c.target;
    }
  }
  v.eye = glm::vec3(eye);
  v.target = glm::vec3(target);
  v.up = glm::vec3(c.up);
  v.fovDegrees = static_cast<float>(c.fov);
  v.displace = c.displace;
  const float dist = glm::length(v.target - v.eye);
  v.zNear = std::max(0.01f, dist * 0.01f);
  v.zFar = std::max(100.0f, dist * 50.0f);
  return v;
}

namespace {
struct Box {
  glm::dvec3 lo{std::numeric_limits<double>::infinity()}, hi{-std::numeric_limits<double>::infinity()};
  void add(const glm::dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void add(const Box& b) {
    if (b.empty()) return;
    add(b.lo);
    add(b.hi);
  }
  bool empty() const { return !(lo.x <= hi.x); }
};

Box worldBox(const RigidBody& rb) {
  Box b;
  const glm::dvec3 lo = rb.shape->boundsMin, hi = rb.shape->boundsMax;
  const glm::dmat3 r = rb.rotation();
  for (int c = 0; c < 8; ++c)
    b.add(rb.origin() + r * glm::dvec3(c & 1 ? hi.x : lo.x, c & 2 ? hi.y : lo.y, c & 4 ? hi.z : lo.z));
  return b;
}
}  // namespace

CameraDesc defaultCamera(const Simulation& sim) {
  const World& world = sim.world();
  const glm::dvec3 up = glm::length(sim.scene().gravity) > 0 ? -glm::normalize(sim.scene().gravity) : glm::dvec3(0, 1, 0);
  const double ahead = std::clamp(sim.scene().duration, 0.1, 1.5);
  std::vector<Box> statics;
  std::vector<const RigidBody*> moving;
  Box all;
  for (const BodyRuntime& b : sim.bodies()) {
    const RigidBody& rb = world.body(b.index);
    if (rb.removed || !rb.shape) continue;
    all.add(worldBox(rb));
    if (rb.isStatic)
      statics.push_back(worldBox(rb));
    else
      moving.push_back(&rb);
  }
  Box frame;
  for (const RigidBody* rb : moving) {
    const Box now = worldBox(*rb);
    // Along its velocity until it first meets a static body it is clear of now (its dent), for at most
    // the scene's duration (5 s); without such a meeting, its next `ahead` seconds.
    auto overlaps = [](const Box& a, const Box& b, double grow) {
      for (int k = 0; k < 3; ++k)
        if (a.lo[k] > b.hi[k] + grow || b.lo[k] > a.hi[k] + grow) return false;
      return true;
    };
    const double horizon = std::clamp(sim.scene().duration, 0.1, 5.0);
    double reach = ahead;
    if (glm::length(rb->v) > 0) {
      bool hit = false;
      for (int i = 1; i <= 100 && !hit; ++i) {
        const double t = horizon * i / 100;
        Box moved;
        moved.add(now.lo + rb->v * t);
        moved.add(now.hi + rb->v * t);
        for (const Box& s : statics) hit = hit || (!overlaps(now, s, 0.01) && overlaps(moved, s, 0.0));
        if (hit) reach = t;
      }
    }
    Box path = now;
    path.add(now.lo + rb->v * reach);
    path.add(now.hi + rb->v * reach);
    frame.add(path);
    // The static surface it would fall onto: the highest top below it among the static bodies under its path.
    const glm::dvec3 centre = 0.5 * (path.lo + path.hi);
    double landing = -std::numeric_limits<double>::infinity();
    for (const Box& s : statics) {
      bool under = true;
      for (int k = 0; k < 3; ++k)
        if (std::abs(up[k]) < 0.5) under = under && s.hi[k] >= path.lo[k] && s.lo[k] <= path.hi[k];
      const double top = std::max(glm::dot(s.lo, up), glm::dot(s.hi, up));
      if (under && top <= std::max(glm::dot(now.lo, up), glm::dot(now.hi, up))) landing = std::max(landing, top);
    }
    if (std::isfinite(landing)) frame.add(centre + up * (landing - glm::dot(centre, up)));
  }
  if (frame.empty()) frame = all;
  if (frame.empty()) frame.add(glm::dvec3(0));
  CameraDesc cam;
  cam.name = "default";
  cam.fov = 45;
  cam.up = up;
  const glm::dvec3 centre = 0.5 * (frame.lo + frame.hi);
  // 45 degrees around the up axis from the scene's +x/+z side, 30 degrees above the horizon.
  glm::dvec3 side = glm::abs(up.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
  side = glm::normalize(side - up * glm::dot(side, up));
  const glm::dvec3 side2 = glm::cross(side, up);
  const double elevation = glm::radians(30.0);
  const glm::dvec3 toEye = std::cos(elevation) * glm::normalize(side + side2) + std::sin(elevation) * up;
  const glm::dvec3 forward = -toEye;
  const glm::dvec3 right = glm::normalize(glm::cross(forward, up));
  const glm::dvec3 camUp = glm::cross(right, forward);
  const double tanV = std::tan(glm::radians(cam.fov) * 0.5), tanH = tanV * 1.5;
  // The nearest eye distance at which every corner of the box lies inside the view, with a margin.
  double distance = 0;
  const glm::dvec3 half = 0.5 * (frame.hi - frame.lo);
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 d(c & 1 ? half.x : -half.x, c & 2 ? half.y : -half.y, c & 4 ? half.z : -half.z);
    const double depthOffset = glm::dot(d, forward);
    distance = std::max(distance, std::abs(glm::dot(d, right)) * 1.15 / tanH - depthOffset);
    distance = std::max(distance, std::abs(glm::dot(d, camUp)) * 1.15 / tanV - depthOffset);
    distance = std::max(distance, 0.3 - depthOffset);
  }
  distance = std::max(distance, 1.0);
  cam.target = centre;
  cam.position = centre + toEye * distance;
  return cam;
}

}  // namespace crumple
