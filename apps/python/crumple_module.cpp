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
#include <crumple/gl/image.h>
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
    jb["kinematic"] = b.kinematic;
    jb["path"] = !b.path.empty();  // a kinematic body on keyframes: the path sets its pose and velocities
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
  // `text`: the scene's JSON itself (Simulation.from_json / from_dict), named `origin` in errors; relative file
  // names in it are found from the working folder.
  PySimulation(const std::optional<std::string>& path, const Overrides& overrides, int gpu, int threads,
               const std::optional<std::string>& text, const std::string& origin) {
    if (path) checkPath("Simulation", "path", *path);
    struct Release {
      ~Release() { releaseCurrentContext(); }
    } release;  // the context made here is current on this thread until the end
    scene_ = text ? parseScene(*text, origin, fs::current_path().string(), overrides) : loadWithOverrides(path, overrides);
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

  bool closed() const { return closed_; }
  // Releases the simulation and its OpenGL context now (the object stays, every later call raises).
  void close() {
    if (closed_) return;
    {
      Use use(*this);
      renderer_.reset();
      sim_.reset();
    }
    gl_.reset();
    releaseCurrentContext();
    closed_ = true;
  }

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

  // ---- bodies by their place in the scene (crumple.Body) ----
  std::vector<std::string> bodyNames() {
    std::vector<std::string> names;
    for (const BodyRuntime& b : sim_->bodies()) names.push_back(b.name);
    return names;
  }
  int bodyIndex(const std::string& name) {
    const auto& bodies = sim_->bodies();
    std::string names;
    for (size_t i = 0; i < bodies.size(); ++i) {
      if (bodies[i].name == name) return static_cast<int>(i);
      if (i < 20) names += (names.empty() ? "" : ", ") + bodies[i].name;
    }
    if (bodies.size() > 20) names += ", ... (" + std::to_string(bodies.size()) + " in all)";
    throw py::value_error("no body is named '" + quoteText(name) + "' (bodies: " + names + ")");
  }
  // (position of the shape's origin, orientation w x y z, linear velocity, angular velocity, mass, static,
  // kinematic, asleep): the fields of summary.json's bodies.
  py::tuple bodyState(int k) {
    Use use(*this);
    const RigidBody& b = sim_->world().body(worldIndex(k));
    const glm::dvec3 o = b.origin();
    return py::make_tuple(py::make_tuple(o.x, o.y, o.z), py::make_tuple(b.q.w, b.q.x, b.q.y, b.q.z),
                          py::make_tuple(b.v.x, b.v.y, b.v.z), py::make_tuple(b.w.x, b.w.y, b.w.z),
                          b.isStatic ? 0.0 : b.mass, b.isStatic, b.kinematic, b.asleep);
  }
  // Sets one of position (of the shape's origin), orientation (w x y z, normalised), linear_velocity,
  // angular_velocity (world, rad/s). The values are checked (finite, length) by the package.
  void setBody(int k, const std::string& what, const std::vector<double>& v) {
    Use use(*this);
    World& w = sim_->world();
    const int i = worldIndex(k);
    const RigidBody& b = w.body(i);
    if (b.isStatic && what != "orientation" && what != "position")
      throw py::value_error(what + ": body '" + quoteText(sim_->bodies()[static_cast<size_t>(k)].name) +
                            "' is static (it never moves)");
    if (what == "position") {
      const glm::dvec3 origin(v[0], v[1], v[2]);
      w.setPose(i, {origin + b.rotation() * b.localCom, b.q});
    } else if (what == "orientation") {
      const glm::dquat q = glm::normalize(glm::dquat(v[0], v[1], v[2], v[3]));
      const glm::dvec3 origin = b.origin();
      w.setPose(i, {origin + glm::mat3_cast(q) * b.localCom, q});
    } else if (what == "linear_velocity") {
      w.setVelocity(i, {v[0], v[1], v[2]});
    } else if (what == "angular_velocity") {
      w.setAngularVelocity(i, {v[0], v[1], v[2]});
    } else {
      throw py::value_error("unknown body field '" + what + "'");
    }
  }
  // A force (N) through the centre of mass or at a world point, for the next step only; or an impulse (N s) now.
  void push(int k, const std::string& kind, const std::vector<double>& vector, const std::optional<std::vector<double>>& at) {
    Use use(*this);
    World& w = sim_->world();
    const int i = worldIndex(k);
    const RigidBody& b = w.body(i);
    if (b.isStatic || b.kinematic)
      throw py::value_error(kind + ": body '" + quoteText(sim_->bodies()[static_cast<size_t>(k)].name) + "' is " +
                            (b.isStatic ? "static" : "kinematic") + ": only dynamic bodies are pushed");
    const glm::dvec3 f(vector[0], vector[1], vector[2]);
    const glm::dvec3 p = at ? glm::dvec3((*at)[0], (*at)[1], (*at)[2]) : b.x;
    w.wake(i);
    if (kind == "apply_force") {
      w.addForceAtPoint(i, f, p);
    } else {
      const glm::dvec3 dw = b.invInertiaWorld() * glm::cross(p - b.x, f);
      const glm::dvec3 v = b.v + f * b.invMass, av = b.w + dw;
      w.setVelocity(i, v);
      w.setAngularVelocity(i, av);
    }
  }
  // Every body's pose, one row each in the scene's order: the shape origin's position and the orientation
  // (w x y z).
  py::array_t<double> poses() {
    Use use(*this);
    const auto& bodies = sim_->bodies();
    py::array_t<double> out({static_cast<py::ssize_t>(bodies.size()), static_cast<py::ssize_t>(7)});
    double* p = out.mutable_data();
    for (const BodyRuntime& br : bodies) {
      const RigidBody& b = sim_->world().body(br.index);
      const glm::dvec3 o = b.origin();
      for (double x : {o.x, o.y, o.z, b.q.w, b.q.x, b.q.y, b.q.z}) *p++ = x;
    }
    return out;
  }

  // A frame from a camera given by its place (position, target, up; fov in degrees, vertical).
  py::array_t<uint8_t> renderView(const std::vector<double>& position, const std::vector<double>& target,
                                  const std::vector<double>& up, double fov, int width, int height) {
    CameraDesc cam;
    cam.name = "view";
    cam.position = {position[0], position[1], position[2]};
    cam.target = {target[0], target[1], target[2]};
    cam.up = {up[0], up[1], up[2]};
    cam.fov = fov;
    if (upAlongView(cam.position, cam.target, cam.up))  // (as a scene's camera, which crumple-sim refuses)
      throw py::value_error(
          "render: up must not be zero or parallel to the view direction (position to target), got [" +
          std::to_string(up[0]) + ", " + std::to_string(up[1]) + ", " + std::to_string(up[2]) + "]");
    return draw(cam, width, height);
  }

  py::array_t<uint8_t> render(const std::optional<std::string>& camera, int width, int height) {
    std::vector<CameraDesc> cams = scene_.cameras;
    if (cams.empty()) cams.push_back(defaultCamera_);
    const CameraDesc* cam = camera ? nullptr : &cams.front();
    std::string names;
    for (const auto& c : cams) {
      if (camera && c.name == *camera) cam = &c;
      names += (names.empty() ? "" : ", ") + c.name;
    }
    if (!cam) throw py::value_error("render: no camera is named '" + quoteText(*camera) + "' (cameras: " + names + ")");
    return draw(*cam, width, height);
  }

 private:
  friend class Use;
  py::array_t<uint8_t> draw(const CameraDesc& cam, int width, int height) {
    if (!gl_) throw std::runtime_error("render: no OpenGL context (" + glError_ + ")");
    if (width < 16 || height < 16 || width > 8192 || height > 8192)
      throw py::value_error("render: width and height must be in [16, 8192], got " + std::to_string(width) + "x" +
                            std::to_string(height));
    Use use(*this);
    if (!renderer_)
      renderer_ = std::make_unique<render::Renderer>(width, height);
    else if (renderer_->width() != width || renderer_->height() != height)
      renderer_->resize(width, height);
    drawFrame(*sim_, *renderer_, cameraView(cam, sim_.get()));
    const gl::Image img = renderer_->readPixels();
    py::array_t<uint8_t> out({height, width, 3});
    uint8_t* p = out.mutable_data();
    for (size_t i = 0; i < img.pixels.size(); ++i)
      p[i] = static_cast<uint8_t>(std::lround(std::clamp(img.pixels[i], 0.0f, 1.0f) * 255.0f));
    return out;
  }
  // The world's index of the scene's k-th body (checked by the package: 0 <= k < the bodies).
  int worldIndex(int k) const { return sim_->bodies().at(static_cast<size_t>(k)).index; }
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
  bool closed_ = false;
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
  auto& sim = *static_cast<PySimulation*>(v_h.value_ptr());
  return sim;
}
PySimulation& live(py::handle self) {
  PySimulation& sim = initialised(self);
  if (sim.closed()) throw std::runtime_error("this crumple.Simulation is closed");
  return sim;
}

template <typename R, typename... A>
auto checked(R (PySimulation::*method)(A...)) {
  return [method](py::handle self, A... args) -> R { return (live(self).*method)(std::forward<A>(args)...); };
}
template <typename R, typename... A>
auto checked(R (PySimulation::*method)(A...) const) {
  return [method](py::handle self, A... args) -> R { return (live(self).*method)(std::forward<A>(args)...); };
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
  // crumple.write_png: a float32 array (rows, cols, channels) with values in [0, 1], written atomically.
  m.def(
      "_write_png",
      [](const std::string& path, py::array_t<float, py::array::c_style | py::array::forcecast> pixels, int bitDepth) {
        checkPath("write_png", "path", path);
        if (pixels.ndim() != 3 || pixels.shape(2) < 1 || pixels.shape(2) > 4)
          throw py::value_error("write_png: expected (rows, cols, channels) with 1 to 4 channels");
        gl::Image image(static_cast<int>(pixels.shape(1)), static_cast<int>(pixels.shape(0)),
                        static_cast<int>(pixels.shape(2)));
        std::copy(pixels.data(), pixels.data() + pixels.size(), image.pixels.begin());
        try {
          gl::writePng(path, image, bitDepth);
        } catch (const gl::ImageError& e) {
          PyErr_SetString(PyExc_OSError, escapeInvalidUtf8(e.what()).c_str());
          throw py::error_already_set();
        }
      },
      py::arg("path"), py::arg("pixels"), py::arg("bit_depth"));
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
      .def(py::init<const std::optional<std::string>&, const Overrides&, int, int, const std::optional<std::string>&,
                    const std::string&>(),
           py::arg("path"), py::arg("overrides"), py::arg("gpu"), py::arg("threads"), py::arg("text") = py::none(),
           py::arg("origin") = "")
      .def("close", [](py::handle self) { initialised(self).close(); })
      .def_property_readonly(
          "closed", [](py::handle self) { return initialised(self).closed(); }, "Whether close() was called.")
      .def_property_readonly("body_names", checked(&PySimulation::bodyNames),
                             "The bodies' names in the scene's order (the rows of poses()).")
      .def("_body_index", checked(&PySimulation::bodyIndex), py::arg("name"))
      .def("_body_state", checked(&PySimulation::bodyState), py::arg("k"))
      .def("_set_body", checked(&PySimulation::setBody), py::arg("k"), py::arg("what"), py::arg("values"))
      .def("_push", checked(&PySimulation::push), py::arg("k"), py::arg("kind"), py::arg("vector"), py::arg("at"))
      .def("poses", checked(&PySimulation::poses),
           "Every body's pose now: numpy float64 (bodies, 7), a row per body in body_names' order: the shape "
           "origin's position (m) and the orientation quaternion (w, x, y, z).")
      .def("_render_view", checked(&PySimulation::renderView), py::arg("position"), py::arg("target"), py::arg("up"),
           py::arg("fov"), py::arg("width"), py::arg("height"))
      .def("step", checked(&PySimulation::step), py::arg("n") = 1, "Runs n steps.")
      .def("run", checked(&PySimulation::run),
           "Runs on to the scene's duration (round(duration / timestep) steps in all); returns the steps it ran.")
      .def_property_readonly("time", checked(&PySimulation::time), "Seconds simulated (the sum of the steps).")
      .def_property_readonly("steps", checked(&PySimulation::steps), "Steps run so far.")
      .def_property_readonly("total_steps", checked(&PySimulation::totalSteps), "The steps run() runs to.")
      .def_property_readonly("_scene_json", [](py::handle s) { return sceneJson(initialised(s).scene()).dump(); })
      .def_property_readonly("gl", checked(&PySimulation::glDescription),
                             "The OpenGL context in use (platform, renderer, version), or why there is none.")
      .def("bodies", checked(&PySimulation::bodies),
           "A list of dicts, one per body in the scene's order: summary.json's bodies (name, position (m), "
           "orientation [w, x, y, z], linear_velocity (m/s), angular_velocity (rad/s), center_of_mass, mass (kg), "
           "static, kinematic, asleep).")
      .def("events", checked(&PySimulation::events),
           "A list of dicts: the lines of events.jsonl so far (collisions and joint breaks, in the order of the run).")
      .def("height_map", checked(&PySimulation::heightMap), py::arg("name"),
           "The body's height map now: numpy float32 (rows, cols), 0.5 flat, 0 the deepest dent; the surface lies "
           "(h - 0.5) x bump_depth metres above the undented shape.")
      .def("normal_map", checked(&PySimulation::normalMap), py::arg("name"),
           "The body's tangent-space normal map now: numpy float32 (rows, cols, 3), components in [-1, 1].")
      .def("write_outputs", checked(&PySimulation::writeOutputs), py::arg("dir"))
      .def("render", checked(&PySimulation::render), py::arg("camera") = py::none(), py::arg("width") = 960,
           py::arg("height") = 540);
}
