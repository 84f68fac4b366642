// Overrides: `crumple-sim SCENE --set KEY=VALUE`, Python's Simulation(path, overrides=...) and crumple-sweep
// change values of a scene document before it is checked (docs/sweeps.md).
//
// KEY is a key path as the loader's errors write it (`deformation.address_map`, `materials.clay.kappa`,
// `bodies[3].velocity`, `bodies[3].velocity[1]`); an element of an array of named objects (bodies, joints,
// cameras) may be picked by its name instead of its index: `bodies[ball].velocity`. A name in brackets may be
// quoted as a JSON string (`materials["a.b"].kappa`, `bodies["3"]` for a body named 3). VALUE is JSON text;
// text that is not JSON and does not start like a number, array, object or quoted string is taken as a
// string (`deformation.path=scatter`).
//
// What counts as a path that exists: every array element named by index or name must be there, and every
// material set key by key must be defined; objects missing on the way (`deformation` in a scene without a
// deformation block) are created, and the last key may be new when the loader knows it (an optional key the
// file leaves out). A key the loader does not know, at or under an overridden path, is an error (elsewhere in
// a file it stays a warning).
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include <crumple/engine/scene.h>

namespace crumple {

// KEY and VALUE (JSON text), applied in order: a later one wins.
using Override = std::pair<std::string, std::string>;
using Overrides = std::vector<Override>;

// "KEY=VALUE" split at the first '='. Throws SceneError("--set", assignment, ...) without a '=' or a key.
Override parseOverride(const std::string& assignment);

// VALUE as JSON (see above). Throws SceneError(file, key, ...) for text that starts like JSON but is not.
nlohmann::json overrideValue(const std::string& file, const std::string& key, const std::string& value);

// Applies the overrides to a scene document of `file`. Returns each override's path as the loader writes it
// (indices for names: `bodies[1].velocity`). Throws SceneError(file, KEY, reason) for a path that does not
// exist or a VALUE that is not JSON.
std::vector<std::string> applyOverrides(nlohmann::json& root, const Overrides& overrides, const std::string& file);

// parseScene (engine/scene.h) with the overrides applied to the document first. An error about an overridden
// key says which override set it.
Scene parseScene(const std::string& text, const std::string& file, const std::string& baseDir,
                 const Overrides& overrides);

// For the loader, while a scene with overrides is parsed on this thread: whether `keyPath` is at or under a
// path an override set (an unknown key there is refused instead of ignored).
bool isOverriddenPath(const std::string& keyPath);

}  // namespace crumple
