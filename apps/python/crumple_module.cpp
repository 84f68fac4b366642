// crumple._crumple: the C++ side of the Python module `crumple` (docs/python.md). The package's __init__.py
// turns overrides into JSON text and the JSON strings returned here into Python objects.
//
// Every Simulation owns its headless OpenGL context. Each call locks the simulation, makes its context current
// on the calling thread and releases it again before it returns, so several simulations live side by side in one
// process and a simulation may be used from any thread (one call at a time). The GIL is held while it works.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <crumple/core/log.h>
#include <crumple/core/version.h>
#include <crumple/engine/builtin_scenes.h>
#include <crumple/engine/output_writer.h>
#include <crumple/engine/overrides.h>
#include <crumple/engine/scene_view.h>
#include <crumple/engine/simulation.h>
#include <crumple/gl/context.h>
#include <crumple/render/renderer.h>

// After epoxy's GL header (through the engine's): EGL for releasing a context.
#include <EGL/egl.h>

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
  j["file"] = escapeInvalidUtf8(s.file);  // a path: bytes, not always UTF-8
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

// A path argument: not empty, no NUL byte (a C string would end there and name another file). ValueError naming the
// parameter.
void checkPath(const char* function, const char* parameter, const std::string& path) {
  if (path.empty()) throw py::value_error(std::string(function) + ": " + parameter + " must not be empty");
  if (path.find('\0') != std::string::npos)
    throw py::value_error(std::string(function) + ": " + parameter + " holds a NUL byte");
}

// No context current on this thread (after a call: the next may come from another thread).
void releaseCurrentContext() {
  const EGLDisplay display = eglGetCurrentDisplay();
  if (display != EGL_NO_DISPLAY) eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
}

class PySimulation;

// One call's use of a simulation: holds its lock (waiting without the GIL, so that the call that holds it can
// finish) and its GL context current on this thread; releases both at the end. An EGL context is current on at
// most one thread: made current by the thread that created it and never released, it refused every other thread
// (EGL_BAD_ACCESS).
class Use {
 public:
  explicit Use(PySimulation& sim);
  ~Use();
  Use(const Use&) = delete;
  Use& operator=(const Use&) = delete;

 private:
  PySimulation& sim_;
};

class PySimulation {
 public:
  PySimulation(const std::optional<std::string>& path, const Overrides& overrides, int gpu, int threads) {
    if (path) checkPath("Simulation", "path", *path);
    struct Release {
      ~Release() { releaseCurrentContext(); }
    } release;  // the context made here is current on this thread until the end
    scene_ = loadWithOverrides(path, overrides);
    if (threads >= 0) scene_.threads = threads;
    bool bumpMaps = false;
    for (const auto& b : scene_.bodies) bumpMaps = bumpMaps || b.bumpMap.present;
    // A context always when one can be made (render() needs it); without one, a scene without bump maps
    // still runs (physics only) and render() says why it cannot draw.
    try {
      gl::HeadlessOptions options;
      options.debug = false;
      options.device = gpu;
      gl_ = gl::createHeadlessContext(options);
    } catch (const gl::ContextError& e) {
      if (bumpMaps || gpu >= 0) throw std::runtime_error(e.what());
      glError_ = e.what();
    }
    sim_ = std::make_unique<Simulation>(scene_, gl_ != nullptr);
    defaultCamera_ = defaultCamera(*sim_);  // framed once, on the bodies as they start
    totalSteps_ = std::max(1L, std::lround(scene_.duration / scene_.timestep));
  }
  ~PySimulation() {
    // Possibly on another thread than the last call's (the garbage collector's): the context is current nowhere.
    if (gl_) {
      try {
        gl_->makeCurrent();
      } catch (...) {
      }
    }
    renderer_.reset();
    sim_.reset();
    gl_.reset();
    releaseCurrentContext();
  }
  PySimulation(const PySimulation&) = delete;
  PySimulation& operator=(const PySimulation&) = delete;

  void step(long n) {
    if (n < 0) throw py::value_error("step(n): n must be >= 0, got " + std::to_string(n));
    Use use(*this);
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
  double time() {
    Use use(*this);
    return sim_->world().time();
  }
  long steps() {
    Use use(*this);
    return sim_->steps();
  }
  const Scene& scene() const { return scene_; }
  long totalSteps() const { return totalSteps_; }

  // What summary.json's "bodies" and events.jsonl hold (engine/output_writer.h).
  py::object bodies() {
    std::string text;
    {
      Use use(*this);
      text = bodiesJson(*sim_);
    }
    return loads(text);
  }
  py::object events() {
    std::string array = "[";
    {
      Use use(*this);
      for (const std::string& line : eventLines(*sim_)) array += (array.size() > 1 ? "," : "") + line;
    }
    return loads(array + "]");
  }
  std::string glDescription() {
    if (!gl_) return "none: " + glError_;
    Use use(*this);
    return gl_->description();
  }

  py::array_t<float> heightMap(const std::string& name) {
    const BodyRuntime& b = mapped(name);
    Use use(*this);
    const gl::Image h = b.surface->downloadHeight();
    py::array_t<float> out({h.height, h.width});
    std::copy(h.pixels.begin(), h.pixels.begin() + static_cast<long>(h.width) * h.height, out.mutable_data());
    return out;
  }
  py::array_t<float> normalMap(const std::string& name) {
    const BodyRuntime& b = mapped(name);
    Use use(*this);
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
    checkPath("write_outputs", "dir", dir);
    Use use(*this);
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
    if (!cam) throw py::value_error("render: no camera is named '" + quoteText(*camera) + "' (cameras: " + names + ")");
    Use use(*this);
    if (!renderer_)
      renderer_ = std::make_unique<render::Renderer>(width, height);
    else if (renderer_->width() != width || renderer_->height() != height)
      renderer_->resize(width, height);
    drawFrame(*sim_, *renderer_, cameraView(*cam, sim_.get()));
    const gl::Image img = renderer_->readPixels();
    py::array_t<uint8_t> out({height, width, 3});
    uint8_t* p = out.mutable_data();
    for (size_t i = 0; i < img.pixels.size(); ++i)
      p[i] = static_cast<uint8_t>(std::lround(std::clamp(img.pixels[i], 0.0f, 1.0f) * 255.0f));
    return out;
  }

 private:
  friend class Use;
  const BodyRuntime& mapped(const std::string& name) {
    std::string withMaps;
    const BodyRuntime* found = nullptr;
    for (const auto& b : sim_->bodies()) {
      if (b.name == name) found = &b;
      if (b.surface) withMaps += (withMaps.empty() ? "" : ", ") + b.name;
    }
    if (!found)
      throw py::value_error("no body is named '" + quoteText(name) + "' (bodies with a bump map: " + withMaps + ")");
    if (!found->surface) {
      if (!gl_) throw std::runtime_error("no OpenGL context, so no maps (" + glError_ + ")");
      throw py::value_error("body '" + quoteText(name) +
                            "' has no bump_map (bodies with one: " + (withMaps.empty() ? "none" : withMaps) + ")");
    }
    return *found;
  }

  Scene scene_;
  std::unique_ptr<gl::GlContext> gl_;
  std::string glError_;
  std::unique_ptr<Simulation> sim_;
  std::unique_ptr<render::Renderer> renderer_;
  CameraDesc defaultCamera_;  // for scenes without cameras
  long totalSteps_ = 1;
  std::mutex mutex_;
  std::thread::id user_;  // the thread of the call that holds mutex_
};

Use::Use(PySimulation& sim) : sim_(sim) {
  if (!sim.mutex_.try_lock()) {
    if (sim.user_ == std::this_thread::get_id())
      throw std::runtime_error("this Simulation is already in a call on this thread");
    py::gil_scoped_release nogil;
    sim.mutex_.lock();
  }
  sim.user_ = std::this_thread::get_id();
  try {
    if (sim.gl_) sim.gl_->makeCurrent();
  } catch (...) {
    sim.user_ = std::thread::id();
    sim.mutex_.unlock();
    throw;
  }
}

Use::~Use() {
  if (sim_.gl_) releaseCurrentContext();
  sim_.user_ = std::thread::id();
  sim_.mutex_.unlock();
}

// A method of the simulation, checked: an object made without __init__ (Simulation.__new__(Simulation)) holds no
// simulation. pybind11 would hand the method uninitialised memory for it (it allocates the value lazily), so the
// holder's state is looked at instead of loading `self` as a PySimulation.
PySimulation& initialised(py::handle self) {
  if (!py::isinstance<PySimulation>(self)) throw py::type_error("expected a crumple.Simulation");
  auto* inst = reinterpret_cast<py::detail::instance*>(self.ptr());
  const py::detail::value_and_holder v_h =
      inst->get_value_and_holder(py::detail::get_type_info(typeid(PySimulation)), false);
  if (!v_h || !v_h.holder_constructed() || v_h.value_ptr() == nullptr)
    throw py::type_error(
        "this crumple.Simulation was not initialised (made by __new__ without __init__): make one with "
        "crumple.Simulation(path)");
  return *static_cast<PySimulation*>(v_h.value_ptr());
}

template <typename R, typename... A>
auto checked(R (PySimulation::*method)(A...)) {
  return [method](py::handle self, A... args) -> R { return (initialised(self).*method)(std::forward<A>(args)...); };
}
template <typename R, typename... A>
auto checked(R (PySimulation::*method)(A...) const) {
  return [method](py::handle self, A... args) -> R { return (initialised(self).*method)(std::forward<A>(args)...); };
}

}  // namespace

PYBIND11_MODULE(_crumple, m) {
  m.doc() = "crumple's C++ core; use the package `crumple` (docs/python.md)";
  // Warnings (unknown keys, ...) go to stderr as crumple-sim prints them; info stays quiet.
  setLogLevel(LogLevel::Warning);

  // crumple.SceneError(ValueError): the message crumple-sim prints after "crumple-sim: error: ", with the
  // parts as attributes. Leaked on purpose: it must outlive the interpreter's teardown.
  static auto* sceneError = new py::exception<SceneError>(m, "SceneError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    // Text for Python: bytes that are not UTF-8 (a file name's) escaped, never a UnicodeDecodeError instead.
    auto text = [](const std::string& s) { return py::str(escapeInvalidUtf8(s)); };
    try {
      if (p) std::rethrow_exception(p);
    } catch (const SceneError& e) {
      py::object err = py::reinterpret_borrow<py::object>(sceneError->ptr())(text(e.what()));
      err.attr("file") = text(e.file);
      err.attr("key_path") = text(e.keyPath);
      err.attr("reason") = text(e.reason);
      PyErr_SetObject(sceneError->ptr(), err.ptr());
    } catch (const std::invalid_argument& e) {
      // pybind11 makes these ValueError (and out_of_range IndexError): here they are failures at run time (the
      // engine's checks of its own state), which raise RuntimeError. The module's own checks of arguments raise
      // ValueError and TypeError, and bad input SceneError.
      PyErr_SetObject(PyExc_RuntimeError, text(e.what()).ptr());
    } catch (const std::domain_error& e) {
      PyErr_SetObject(PyExc_RuntimeError, text(e.what()).ptr());
    } catch (const std::length_error& e) {
      PyErr_SetObject(PyExc_RuntimeError, text(e.what()).ptr());
    } catch (const std::out_of_range& e) {
      PyErr_SetObject(PyExc_RuntimeError, text(e.what()).ptr());
    } catch (const std::range_error& e) {
      PyErr_SetObject(PyExc_RuntimeError, text(e.what()).ptr());
    } catch (const std::overflow_error& e) {
      PyErr_SetObject(PyExc_RuntimeError, text(e.what()).ptr());
    } catch (const std::underflow_error& e) {
      PyErr_SetObject(PyExc_RuntimeError, text(e.what()).ptr());
    }
  });

  m.attr("__version__") = versionString();

  m.def(
      "_load_scene",
      [](const std::optional<std::string>& path, const Overrides& overrides) {
        if (path) checkPath("load_scene", "path", *path);
        return sceneJson(loadWithOverrides(path, overrides)).dump();
      },
      py::arg("path"), py::arg("overrides"));
  // For the test suite: throws the C++ exception `kind` names, as the engine would, to check what Python gets.
  m.def("_raise_for_test", [](const std::string& kind) {
    if (kind == "invalid_argument") throw std::invalid_argument("invalid_argument from C++");
    if (kind == "length_error") throw std::length_error("length_error from C++");
    if (kind == "out_of_range") throw std::out_of_range("out_of_range from C++");
    if (kind == "runtime_error") throw std::runtime_error("runtime_error from C++");
    if (kind == "scene_error") throw SceneError("f\xff.json", "k", "bad");
    throw py::value_error("_raise_for_test: unknown kind");
  });

  py::class_<PySimulation>(m, "_Simulation")
      .def(py::init<const std::optional<std::string>&, const Overrides&, int, int>(), py::arg("path"),
           py::arg("overrides"), py::arg("gpu"), py::arg("threads"))
      .def("step", checked(&PySimulation::step), py::arg("n") = 1)
      .def("run", checked(&PySimulation::run))
      .def_property_readonly("time", checked(&PySimulation::time))
      .def_property_readonly("steps", checked(&PySimulation::steps))
      .def_property_readonly("total_steps", checked(&PySimulation::totalSteps))
      .def_property_readonly("_scene_json", [](py::handle s) { return sceneJson(initialised(s).scene()).dump(); })
      .def_property_readonly("gl", checked(&PySimulation::glDescription))
      .def("bodies", checked(&PySimulation::bodies))
      .def("events", checked(&PySimulation::events))
      .def("height_map", checked(&PySimulation::heightMap), py::arg("name"))
      .def("normal_map", checked(&PySimulation::normalMap), py::arg("name"))
      .def("write_outputs", checked(&PySimulation::writeOutputs), py::arg("dir"))
      .def("render", checked(&PySimulation::render), py::arg("camera") = py::none(), py::arg("width") = 960,
           py::arg("height") = 540);
}
