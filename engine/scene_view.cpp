#include "engine/scene_view.h"

#include <chrono>

namespace crumple {

std::vector<render::RenderItem> renderItems(const Simulation& sim) {
  std::vector<render::RenderItem> items;
  for (size_t i = 0; i < sim.bodies().size(); ++i) {
    const BodyRuntime& b = sim.bodies()[i];
    if (!b.gpuMesh) continue;
    render::RenderItem it;
    it.vao = b.gpuMesh->vao.id();
    it.indexCount = b.gpuMesh->indexCount;
    it.model = glm::mat4(sim.model(static_cast<int>(i)));
    it.color = b.material->color;
    it.metallic = b.material->metallic;
    it.roughness = b.material->roughness;
    it.look = b.look.get();
    it.ownColor = !b.material->hasColor;
    it.ownMetallic = !b.material->hasMetallic;
    it.ownRoughness = !b.material->hasRoughness;
    it.boundsMin = b.gpuMesh->boundsMin;
    it.boundsMax = b.gpuMesh->boundsMax;
    if (b.surface) {
      it.height = b.surface->height().id();
      it.normal = b.surface->normal().id();
      it.bumpDepth = b.surface->bumpDepth();
    }
    items.push_back(it);
  }
  std::vector<VehiclePart> parts = sim.vehicleParts();
  for (const VehiclePart& part : sim.jointParts()) parts.push_back(part);
  for (const VehiclePart& part : parts) {
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
  renderer.draw(renderItems(sim), view);
  glFinish();
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
  const float dist = glm::length(v.target - v.eye);
  v.zNear = std::max(0.01f, dist * 0.01f);
  v.zFar = std::max(100.0f, dist * 50.0f);
  return v;
}

}  // namespace crumple
