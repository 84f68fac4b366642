// GL contexts behind one interface (after Filament's platforms): a headless EGL
// context for tests and batch runs, a GLFW window for the sandbox. Whatever made
// the context, the renderer and the deformation passes use the same GL objects.
#pragma once
#include <memory>
#include <stdexcept>
#include <string>

struct GLFWwindow;

namespace crumple::gl {

struct ContextError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class GlContext {
 public:
  virtual ~GlContext() = default;
  virtual void makeCurrent() = 0;
  // Human-readable: platform, GL_RENDERER and GL_VERSION.
  virtual std::string description() const = 0;
};

struct HeadlessOptions {
  bool preferGpu = true;  // EGL device platform with a hardware device if one exists
  bool debug = true;      // KHR_debug messages routed to the log
  // Which GPU: -1 takes the environment's CRUMPLE_EGL_DEVICE when set, else the first hardware EGL device that
  // works, else Mesa's surfaceless platform (software). N >= 0 asks for the N-th hardware EGL device (software
  // devices not counted) and nothing else: there is no fallback when it is missing or fails.
  int device = -1;
};

// OpenGL 4.5 core without a window. Throws ContextError (with the reason) when
// no context can be made (or the device asked for is missing); never crashes.
std::unique_ptr<GlContext> createHeadlessContext(const HeadlessOptions& options = {});

struct WindowOptions {
  int width = 1280;
  int height = 720;
  std::string title = "crumple";
  bool visible = true;
  bool debug = true;
  bool vsync = true;
};

// A GLFW window with an OpenGL 4.5 core context. Throws ContextError when none can be made, and always
// when crumple was built without GLFW (CRUMPLE_WITH_GLFW=OFF).
class WindowContext : public GlContext {
 public:
  explicit WindowContext(const WindowOptions& options);
  ~WindowContext() override;
  WindowContext(const WindowContext&) = delete;
  WindowContext& operator=(const WindowContext&) = delete;
  void makeCurrent() override;
  std::string description() const override;
  GLFWwindow* window() const { return window_; }
  bool shouldClose() const;
  void swapBuffers();
  void pollEvents();
  void framebufferSize(int& width, int& height) const;

 private:
  GLFWwindow* window_ = nullptr;
};

// Installs the KHR_debug callback on the current context (no-op when absent).
void installDebugOutput();
// GL_RENDERER / GL_VERSION of the current context.
std::string currentRendererString();
// Whether a GL_RENDERER string names a GPU whose graphics stages (vertex, fragment, raster) run on a few of its
// multiprocessors, where compute shaders do such work many times faster: NVIDIA's GH100 (H100, H200, H800, H20),
// GA100 (A100, A800, A30) and GB100 (B100, B200). The address raster's and the renderer's Auto choose by it.
bool fewGraphicsUnits(const char* renderer);

}  // namespace crumple::gl
