// What the renderer needs from a simulation: one item per body, and views from
// the scene's cameras.
#pragma once
#include <vector>

#include <crumple/engine/simulation.h>
#include <crumple/render/renderer.h>

namespace crumple {

std::vector<render::RenderItem> renderItems(const Simulation& sim);
// The view of a scene camera; a camera that follows a body needs the simulation.
render::View cameraView(const CameraDesc& camera, const Simulation* sim = nullptr);
// The camera of a scene without cameras: a 3/4 view from above (45 degrees around, 30 up) framing the moving
// bodies (not static: dynamic and kinematic) as they are now, along their velocities up to the first static
// body each meets (where it dents; within the scene's duration, at most 5 s; meeting none, its next 1.5 s),
// and the top of the static body each would fall onto. Without moving bodies, every body. Named "default"; vertical fov 45, fitted for frames
// at least 3:2 wide.
CameraDesc defaultCamera(const Simulation& sim);
// One frame of the apps' loops: the simulation's bodies drawn from `view` into the renderer's target; the
// wall-clock milliseconds of issuing it added to sim.timings().renderMs and returned (the GPU is not waited
// for: its time per frame comes from sim.renderTimer(), sim.gpuTimes()).
double drawFrame(Simulation& sim, render::Renderer& renderer, const render::View& view);

}  // namespace crumple
