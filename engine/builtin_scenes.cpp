#include <crumple/engine/builtin_scenes.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace crumple {

namespace fs = std::filesystem;

namespace engine::scenes {
std::string_view embeddedFile(std::string_view name);
}

std::string builtinSceneText(const std::string& name) {
  if (name == "default" || name == "sphere-into-plate")
    return std::string(engine::scenes::embeddedFile("sphere-into-plate.json"));
  if (name == "highway") return std::string(engine::scenes::embeddedFile("highway.json"));
  for (const char* asset : {"car.obj", "sedan.obj", "wbeam.obj"})
    if (name == asset) return std::string(engine::scenes::embeddedFile(asset));
  throw std::invalid_argument("no built-in scene named " + name);
}

Scene builtinHighway() {
  const fs::path dir = fs::temp_directory_path() / ("crumple-highway-" + std::to_string(::getpid()));
  fs::create_directories(dir / "assets");
  for (const char* asset : {"sedan.obj", "wbeam.obj"}) std::ofstream(dir / "assets" / asset) << builtinSceneText(asset);
  return parseScene(builtinSceneText("highway"), "<built-in highway scene>", dir.string());
}

}  // namespace crumple
