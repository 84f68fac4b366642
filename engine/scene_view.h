// What the renderer needs from a simulation: one item per body, and views from
// the scene's cameras.
#pragma once
#include <vector>

#include "engine/simulation.h"
#include "render/renderer.h"

namespace crumple {

std::vector<render::RenderItem> renderItems(const Simulation& sim);
// The view of a scene camera; a camera that follows a body needs the simulation.
render::View cameraView(const CameraDesc& camera, const Simulation* sim = nullptr);
// One frame of the apps' loops: the simulation's bodies drawn from `view` into the renderer's target, the
// GPU waited for (an honest time), the milliseconds added to sim.timings().renderMs and returned.
double drawFrame(Simulation& sim, render::Renderer& renderer, const render::View& view);

}  // namespace crumple
