// crumple._crumple: the C++ side of the Python module `crumple` (docs/python.md). The package's __init__.py
// turns overrides into JSON text and the JSON strings returned here into Python objects.
//
// Every Simulation owns its headless OpenGL context and makes it current before each call that touches GL,
// so several simulations live side by side in one process. The GIL is held throughout: one call at a time.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/log.h"
#include "core/version.h"
#include "engine/builtin_scenes.h"
#include "engine/output_writer.h"
#include "engine/overrides.h"
#include "engine/scene_view.h"
#include "engine/simulation.h"
#include "render/gl_context.h"
#include "render/renderer.h"

namespace py = pybind11;
namespace fs = std::filesystem;
using namespace crumple;
using ojson = nlohmann::ordered_json;

namespace {

const char* kDefaultScene = "<built-in default scene>";

Scene loadWithOverrides(const std::optional<std::string>& path, const Overrides& overrides) {
  if (!path) return parseScene(builtinSceneText(), kDefaultScene, fs::current_path().string(), overrides);
  return loadScene(*path, overrides);
}

py::object loads(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

// What a scene holds, without running it (crumple.load_scene; crumple-sweep checks its variants with it).
ojson sceneJson(const Scene& s) {
  ojson j;
  j["name"] = s.name;
  j["file"] = s.file;
  j["timestep"] = s.timestep;
  j["duration"] = s.duration;
  j["steps"] = std::max(1L, std::lround(s.duration / s.timestep));
  ojson bodies = ojson::array();
  for (const BodyDesc& b : s.bodies) {
    ojson jb;
    jb["name"] = b.name;
    jb["static"] = b.isStatic;
    jb["bump_map"] = b.bumpMap.present ? ojson(b.bumpMap.resolution) : ojson(nullptr);
    bodies.push_back(jb);
  }
  j["bodies"] = bodies;
  ojson cams = ojson::array();
  for (const CameraDesc& c : s.cameras) cams.push_back(c.name);
  j["cameras"] = cams;
  ojson joints = ojson::array();
  for (const JointDesc& jd : s.joints) joints.push_back(jd.name);
  j["joints"] = joints;
  return j;
}

class PySimulation {
 public:
  PySimulation(const std::optional<std::string>& path, const Overrides& overrides, int gpu, int threads) {
    scene_ = loadWithOverrides(path, overrides);
    if (threads >= 0) scene_.threads = threads;
    bool bumpMaps = false;
    for (const auto& b : scene_.bodies) bumpMaps = bumpMaps || b.bumpMap.present;
    // A context always when one can be made (render() needs it); without one, a scene without bump maps
    // still runs (physics only) and render() says why it cannot draw.
    try {
      render::HeadlessOptions options;
      options.debug = false;
      options.device = gpu;
      gl_ = render::createHeadlessContext(options);
    } catch (const render::ContextError& e) {
      if (bumpMaps || gpu >= 0) throw std::runtime_error(e.what());
      glError_ = e.what();
    }
    sim_ = std::make_unique<Simulation>(scene_, gl_ != nullptr);
    defaultCamera_ = defaultCamera(*sim_);  // framed once, on the bodies as they start
    totalSteps_ = std::max(1L, std::lround(scene_.duration / scene_.timestep));
  }
  ~PySimulation() {
    if (gl_) {
      try {
        gl_->makeCurrent();
      } catch (...) {
      }
    }
    renderer_.reset();
    sim_.reset();
    gl_.reset();
  }
  PySimulation(const PySimulation&) = delete;
  PySimulation& operator=(const PySimulation&) = delete;

  void step(long n) {
    if (n < 0) throw py::value_error("step(n): n must be >= 0, got " + std::to_string(n));
    current();
    for (long i = 0; i < n; ++i) {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();  // Ctrl-C between steps
      sim_->step();
    }
  }
  long run() {
    const long n = std::max(0L, totalSteps_ - sim_->steps());
    step(n);
    return n;
  }
  double time() const { return sim_->world().time(); }
  long steps() const { return sim_->steps(); }
  const Scene& scene() const { return scene_; }
  long totalSteps() const { return totalSteps_; }

  // What summary.json's "bodies" and events.jsonl hold (engine/output_writer.h).
  py::object bodies() const { return loads(bodiesJson(*sim_)); }
  py::object events() {
    current();
    std::string array = "[";
    for (const std::string& line : eventLines(*sim_)) array += (array.size() > 1 ? "," : "") + line;
    return loads(array + "]");
  }
  std::string glDescription() const { return gl_ ? gl_->description() : "none: " + glError_; }

  py::array_t<float> heightMap(const std::string& name) {
    const BodyRuntime& b = mapped(name);
    const render::Image h = b.surface->downloadHeight();
    py::array_t<float> out({h.height, h.width});
    std::copy(h.pixels.begin(), h.pixels.begin() + static_cast<long>(h.width) * h.height, out.mutable_data());
    return out;
  }
  py::array_t<float> normalMap(const std::string& name) {
    const BodyRuntime& b = mapped(name);
    const int n = b.surface->resolution();
    std::vector<unsigned char> rgba(static_cast<size_t>(n) * n * 4);
    b.surface->normal().download(GL_RGBA, GL_UNSIGNED_BYTE, rgba.data(), rgba.size());
    py::array_t<float> out({n, n, 3});
    float* p = out.mutable_data();
    for (size_t i = 0; i < static_cast<size_t>(n) * n; ++i)
      for (size_t c = 0; c < 3; ++c) p[i * 3 + c] = rgba[i * 4 + c] / 255.0f * 2.0f - 1.0f;
    return out;
  }

  void writeOutputs(const std::string& dir) {
    current();
    OutputWriter writer(dir);
    writer.write(*sim_);
    writer.commit();
  }

  py::array_t<uint8_t> render(const std::optional<std::string>& camera, int width, int height) {
    if (!gl_) throw std::runtime_error("render: no OpenGL context (" + glError_ + ")");
    if (width < 16 || height < 16 || width > 8192 || height > 8192)
      throw py::value_error("render: width and height must be in [16, 8192], got " + std::to_string(width) + "x" +
                            std::to_string(height));
    std::vector<CameraDesc> cams = scene_.cameras;
    if (cams.empty()) cams.push_back(defaultCamera_);
    const CameraDesc* cam = camera ? nullptr : &cams.front();
    std::string names;
    for (const auto& c : cams) {
      if (camera && c.name == *camera) cam = &c;
      names += (names.empty() ? "" : ", ") + c.name;
    }
    if (!cam) throw py::value_error("render: no camera is named '" + *camera + "' (cameras: " + names + ")");
    current();
    if (!renderer_)
      renderer_ = std::make_unique<render::Renderer>(width, height);
    else if (renderer_->width() != width || renderer_->height() != height)
      renderer_->resize(width, height);
    drawFrame(*sim_, *renderer_, cameraView(*cam, sim_.get()));
    const render::Image img = renderer_->readPixels();
    py::array_t<uint8_t> out({height, width, 3});
    uint8_t* p = out.mutable_data();
    for (size_t i = 0; i < img.pixels.size(); ++i)
      p[i] = static_cast<uint8_t>(std::lround(std::clamp(img.pixels[i], 0.0f, 1.0f) * 255.0f));
    return out;
  }

 private:
  void current() {
    if (gl_) gl_->makeCurrent();
  }
  const BodyRuntime& mapped(const std::string& name) {
    std::string withMaps;
    const BodyRuntime* found = nullptr;
    for (const auto& b : sim_->bodies()) {
      if (b.name == name) found = &b;
      if (b.surface) withMaps += (withMaps.empty() ? "" : ", ") + b.name;
    }
    if (!found) throw py::value_error("no body is named '" + name + "' (bodies with a bump map: " + withMaps + ")");
    if (!found->surface) {
      if (!gl_) throw std::runtime_error("no OpenGL context, so no maps (" + glError_ + ")");
      throw py::value_error("body '" + name + "' has no bump_map (bodies with one: " +
                            (withMaps.empty() ? "none" : withMaps) + ")");
    }
    current();
    return *found;
  }

  Scene scene_;
  std::unique_ptr<render::GlContext> gl_;
  std::string glError_;
  std::unique_ptr<Simulation> sim_;
  std::unique_ptr<render::Renderer> renderer_;
  CameraDesc defaultCamera_;  // for scenes without cameras
  long totalSteps_ = 1;
};

}  // namespace

PYBIND11_MODULE(_crumple, m) {
  m.doc() = "crumple's C++ core; use the package `crumple` (docs/python.md)";
  // Warnings (unknown keys, ...) go to stderr as crumple-sim prints them; info stays quiet.
  setLogLevel(LogLevel::Warning);

  // crumple.SceneError(ValueError): the message crumple-sim prints after "crumple-sim: error: ", with the
  // parts as attributes. Leaked on purpose: it must outlive the interpreter's teardown.
  static auto* sceneError = new py::exception<SceneError>(m, "SceneError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const SceneError& e) {
      py::object err = py::reinterpret_borrow<py::object>(sceneError->ptr())(e.what());
      err.attr("file") = e.file;
      err.attr("key_path") = e.keyPath;
      err.attr("reason") = e.reason;
      PyErr_SetObject(sceneError->ptr(), err.ptr());
    }
  });

  m.attr("__version__") = versionString();

  m.def(
      "_load_scene",
      [](const std::optional<std::string>& path, const Overrides& overrides) {
        return sceneJson(loadWithOverrides(path, overrides)).dump();
      },
      py::arg("path"), py::arg("overrides"));

  py::class_<PySimulation>(m, "_Simulation")
      .def(py::init<const std::optional<std::string>&, const Overrides&, int, int>(), py::arg("path"),
           py::arg("overrides"), py::arg("gpu"), py::arg("threads"))
      .def("step", &PySimulation::step, py::arg("n") = 1)
      .def("run", &PySimulation::run)
      .def_property_readonly("time", &PySimulation::time)
      .def_property_readonly("steps", &PySimulation::steps)
      .def_property_readonly("total_steps", &PySimulation::totalSteps)
      .def_property_readonly("_scene_json", [](const PySimulation& s) { return sceneJson(s.scene()).dump(); })
      .def_property_readonly("gl", &PySimulation::glDescription)
      .def("bodies", &PySimulation::bodies)
      .def("events", &PySimulation::events)
      .def("height_map", &PySimulation::heightMap, py::arg("name"))
      .def("normal_map", &PySimulation::normalMap, py::arg("name"))
      .def("write_outputs", &PySimulation::writeOutputs, py::arg("dir"))
      .def("render", &PySimulation::render, py::arg("camera") = py::none(), py::arg("width") = 960,
           py::arg("height") = 540);
}
