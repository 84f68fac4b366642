// Scenes built into the programs (embedded from scenes/ at build time), so that
// crumple-sim and the sandbox run from anywhere without a scene file.
#pragma once
#include <string>

#include <crumple/engine/scene.h>

namespace crumple {

// Built-in files as text: "default" (sphere into plate), "highway" and its meshes ("sedan.obj", "wbeam.obj"),
// and "car.obj".
std::string builtinSceneText(const std::string& name = "default");
// The built-in highway scene, its meshes written to a temporary folder.
Scene builtinHighway();

}  // namespace crumple
