// What the renderer needs from a simulation: one item per body, and views from
// the scene's cameras.
#pragma once
#include <vector>

#include "engine/simulation.h"
#include "render/renderer.h"

namespace crumple {

std::vector<render::RenderItem> renderItems(const Simulation& sim);
render::View cameraView(const CameraDesc& camera);

}  // namespace crumple
