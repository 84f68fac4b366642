#include <crumple/gl/context.h>

#include <epoxy/gl.h>
// epoxy's GL declarations first; GLFW must not pull in GL/gl.h.
#define GLFW_INCLUDE_NONE
#include <EGL/egl.h>
#include <EGL/eglext.h>
#if CRUMPLE_WITH_GLFW
#include <GLFW/glfw3.h>
#endif

#include <dlfcn.h>

#include <cstdlib>
#include <cstring>
#include <regex>
#include <vector>

#include <crumple/core/log.h>

namespace crumple::gl {

namespace {

void GLAPIENTRY debugCallback(GLenum source, GLenum type, GLuint id, GLenum severity, GLsizei, const GLchar* message,
                              const void*) {
  // The shader compiler's remarks (Mesa's "used uninitialized" for globals set in main) are not errors: a
  // program that fails to compile or link throws with its log (gl::Program).
  if (severity == GL_DEBUG_SEVERITY_NOTIFICATION ||
      (source == GL_DEBUG_SOURCE_SHADER_COMPILER && type != GL_DEBUG_TYPE_ERROR)) {
    logDebug("GL: ", message);
    return;
  }
  LogLevel level =
      (type == GL_DEBUG_TYPE_ERROR || severity == GL_DEBUG_SEVERITY_HIGH) ? LogLevel::Error : LogLevel::Warning;
  if (type == GL_DEBUG_TYPE_PERFORMANCE) level = LogLevel::Debug;
  logf(level, "GL [", id, "]: ", message);
}

bool hasExtension(const char* list, const char* name) {
  if (!list) return false;
  const size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)); p += n) {
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  }
  return false;
}

const char* eglErrorName(EGLint e) {
  switch (e) {
    case EGL_SUCCESS:
      return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED:
      return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
      return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
      return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
      return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
      return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
      return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY:
      return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
      return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER:
      return "EGL_BAD_PARAMETER";
    default:
      return "EGL error";
  }
}

class EglContext final : public GlContext {
 public:
  EglContext(EGLDisplay display, EGLContext context, std::string platform)
      : display_(display), context_(context), platform_(std::move(platform)) {}
  ~EglContext() override {
    if (eglGetCurrentContext() == context_) {
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    eglDestroyContext(display_, context_);
    // No eglTerminate: the display is shared process-wide (eglGetPlatformDisplay
    // returns the same handle each time), and terminating it unloads Mesa's
    // driver, which leaves its allocations unattributable to LeakSanitizer.
  }
  void makeCurrent() override {
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
      throw ContextError(std::string("eglMakeCurrent failed: ") + eglErrorName(eglGetError()));
    }
  }
  std::string description() const override { return "EGL " + platform_ + ", " + currentRendererString(); }

 private:
  EGLDisplay display_;
  EGLContext context_;
  std::string platform_;
};

// Tries to make a GL 4.5 core context on an initialised display. Returns
// EGL_NO_CONTEXT with `why` filled in on failure.
EGLContext createCoreContext(EGLDisplay display, bool debug, std::string& why) {
  const char* ext = eglQueryString(display, EGL_EXTENSIONS);
  if (!hasExtension(ext, "EGL_KHR_no_config_context") && !hasExtension(ext, "EGL_MESA_configless_context")) {
    why = "display lacks EGL_KHR_no_config_context";
    return EGL_NO_CONTEXT;
  }
  if (!eglBindAPI(EGL_OPENGL_API)) {
    why = "eglBindAPI(EGL_OPENGL_API) failed";
    return EGL_NO_CONTEXT;
  }
  const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                            4,
                            EGL_CONTEXT_MINOR_VERSION,
                            5,
                            EGL_CONTEXT_OPENGL_PROFILE_MASK,
                            EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                            EGL_CONTEXT_OPENGL_DEBUG,
                            debug ? EGL_TRUE : EGL_FALSE,
                            EGL_NONE};
  EGLContext ctx = eglCreateContext(display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs);
  if (ctx == EGL_NO_CONTEXT) {
    why = std::string("eglCreateContext(GL 4.5 core) failed: ") + eglErrorName(eglGetError());
    return EGL_NO_CONTEXT;
  }
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
    why = std::string("eglMakeCurrent without surface failed: ") + eglErrorName(eglGetError());
    eglDestroyContext(display, ctx);
    return EGL_NO_CONTEXT;
  }
  return ctx;
}

}  // namespace

std::string currentRendererString() {
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const auto* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  return std::string(renderer ? renderer : "?") + ", GL " + (version ? version : "?");
}

bool fewGraphicsUnits(const char* renderer) {
  static const std::regex dataCentre(R"(\b(G?H(100|200|800|20)|A(100|800|30)|G?B(100|200))\b)");
  return renderer && std::regex_search(renderer, dataCentre);
}

void installDebugOutput() {
  if (!epoxy_has_gl_extension("GL_KHR_debug") && epoxy_gl_version() < 43) return;
  glEnable(GL_DEBUG_OUTPUT);
  glEnable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
  glDebugMessageCallback(debugCallback, nullptr);
}

std::unique_ptr<GlContext> createHeadlessContext(const HeadlessOptions& options) {
  const char* clientExt = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!clientExt) throw ContextError("EGL client extensions unavailable (no EGL 1.5 / libglvnd?)");
  auto getPlatformDisplay =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!getPlatformDisplay) throw ContextError("eglGetPlatformDisplayEXT is missing");

  std::string reasons;
  auto tryDisplay = [&](EGLDisplay display, const std::string& platform) -> std::unique_ptr<GlContext> {
    if (display == EGL_NO_DISPLAY) {
      reasons += "\n  " + platform + ": no display";
      return nullptr;
    }
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) {
      reasons += "\n  " + platform + ": eglInitialize failed (" + eglErrorName(eglGetError()) + ")";
      return nullptr;
    }
    std::string why;
    EGLContext ctx = createCoreContext(display, options.debug, why);
    if (ctx == EGL_NO_CONTEXT) {
      reasons += "\n  " + platform + ": " + why;
      eglTerminate(display);
      return nullptr;
    }
    auto context = std::make_unique<EglContext>(display, ctx, platform);
    if (options.debug) installDebugOutput();
    return context;
  };

  // The device asked for: the option, else CRUMPLE_EGL_DEVICE (one GPU per worker process of a sweep).
  int wanted = options.device;
  if (wanted < 0) {
    if (const char* env = std::getenv("CRUMPLE_EGL_DEVICE"); env && *env) {
      char* end = nullptr;
      const long v = std::strtol(env, &end, 10);
      if (*end != '\0' || v < 0 || v > 1023)
        throw ContextError(std::string("CRUMPLE_EGL_DEVICE must be a device number (0, 1, ...), got '") + env + "'");
      wanted = static_cast<int>(v);
    }
  }
  if (wanted >= 0) {
    if (!hasExtension(clientExt, "EGL_EXT_platform_device"))
      throw ContextError("EGL device " + std::to_string(wanted) + " asked for, but EGL_EXT_platform_device is missing");
    auto queryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto queryDeviceString =
        reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    EGLint count = 0;
    std::vector<EGLDeviceEXT> devices;
    if (queryDevices && queryDevices(0, nullptr, &count) && count > 0) {
      devices.resize(static_cast<size_t>(count));
      queryDevices(count, devices.data(), &count);
    }
    int hardware = 0;
    for (EGLint i = 0; i < count; ++i) {
      const char* devExt =
          queryDeviceString ? queryDeviceString(devices[static_cast<size_t>(i)], EGL_EXTENSIONS) : nullptr;
      if (hasExtension(devExt, "EGL_MESA_device_software")) continue;
      if (hardware++ != wanted) continue;
      EGLDisplay display = getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[static_cast<size_t>(i)], nullptr);
      if (auto c = tryDisplay(display, "device " + std::to_string(i) + " (GPU " + std::to_string(wanted) + ")"))
        return c;
      throw ContextError("EGL device " + std::to_string(wanted) + " gave no OpenGL 4.5 core context:" + reasons);
    }
    throw ContextError(
        "EGL device " + std::to_string(wanted) + " asked for, but there " +
        (hardware == 1 ? "is 1 hardware EGL device" : "are " + std::to_string(hardware) + " hardware EGL devices") +
        " (counting from 0)");
  }

  // A real GPU through the device platform, skipping Mesa's software device.
  if (options.preferGpu && hasExtension(clientExt, "EGL_EXT_platform_device")) {
    auto queryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto queryDeviceString =
        reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    EGLint count = 0;
    if (queryDevices && queryDevices(0, nullptr, &count) && count > 0) {
      std::vector<EGLDeviceEXT> devices(static_cast<size_t>(count));
      queryDevices(count, devices.data(), &count);
      for (EGLint i = 0; i < count; ++i) {
        const char* devExt = queryDeviceString ? queryDeviceString(devices[i], EGL_EXTENSIONS) : nullptr;
        if (hasExtension(devExt, "EGL_MESA_device_software")) continue;
        EGLDisplay display = getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (auto c = tryDisplay(display, "device " + std::to_string(i))) return c;
      }
    }
  }
  if (hasExtension(clientExt, "EGL_MESA_platform_surfaceless")) {
    EGLDisplay display = getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (auto c = tryDisplay(display, "surfaceless")) return c;
  } else {
    reasons += "\n  surfaceless: EGL_MESA_platform_surfaceless not offered";
  }
  throw ContextError("no headless OpenGL 4.5 core context could be made:" + reasons);
}

// ---- GLFW window -----------------------------------------------------------

#if CRUMPLE_WITH_GLFW

namespace {
int gGlfwUsers = 0;
void glfwErrorCallback(int code, const char* message) { logError("GLFW error ", code, ": ", message); }
}  // namespace

WindowContext::WindowContext(const WindowOptions& options) {
  if (gGlfwUsers++ == 0) {
    glfwSetErrorCallback(glfwErrorCallback);
    if (!glfwInit()) {
      gGlfwUsers = 0;
      throw ContextError("glfwInit failed (no display? run under xvfb-run -a)");
    }
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, options.debug ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_SRGB_CAPABLE, GLFW_TRUE);
  window_ = glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
  if (!window_) {
    if (--gGlfwUsers == 0) glfwTerminate();
    throw ContextError("glfwCreateWindow with an OpenGL 4.5 core context failed");
  }
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(options.vsync ? 1 : 0);
  if (options.debug) installDebugOutput();
}

namespace {
// Keeps the GL driver libraries mapped after glfwTerminate unloads them, so
// that what Mesa keeps for the life of the process stays attributable (the
// sanitizer build's leak report names the library; see tools/lsan.supp).
void pinGlDriver() {
  for (const char* lib : {"libGL.so.1", "libGLX.so.0", "libGLX_mesa.so.0", "libgallium_dri.so",
                          "/usr/lib/x86_64-linux-gnu/dri/swrast_dri.so"}) {
    if (void* h = dlopen(lib, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE)) dlclose(h);
  }
}
}  // namespace

WindowContext::~WindowContext() {
  pinGlDriver();
  glfwDestroyWindow(window_);
  if (--gGlfwUsers == 0) glfwTerminate();
}

void WindowContext::makeCurrent() { glfwMakeContextCurrent(window_); }
std::string WindowContext::description() const { return "GLFW window, " + currentRendererString(); }
bool WindowContext::shouldClose() const { return glfwWindowShouldClose(window_); }
void WindowContext::swapBuffers() { glfwSwapBuffers(window_); }
void WindowContext::pollEvents() { glfwPollEvents(); }
void WindowContext::framebufferSize(int& width, int& height) const { glfwGetFramebufferSize(window_, &width, &height); }

#else  // built with CRUMPLE_WITH_GLFW=OFF: no windows, headless contexts only

WindowContext::WindowContext(const WindowOptions&) {
  throw ContextError("crumple was built without GLFW (CRUMPLE_WITH_GLFW=OFF): no window contexts");
}
WindowContext::~WindowContext() = default;
void WindowContext::makeCurrent() {}
std::string WindowContext::description() const { return "no window (built without GLFW)"; }
bool WindowContext::shouldClose() const { return true; }
void WindowContext::swapBuffers() {}
void WindowContext::pollEvents() {}
void WindowContext::framebufferSize(int& width, int& height) const { width = height = 0; }

#endif

}  // namespace crumple::gl
