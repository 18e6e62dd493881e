#include "gl_driver.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl32.h>

#include <cstring>
#include <vector>

namespace kiln::gl {

// The entry points used here have the same signatures in desktop GL and GLES; they are fetched with
// eglGetProcAddress so that one binary drives both APIs without linking libOpenGL and libGLESv2.
struct GlDriver::State {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  PFNGLCREATESHADERPROC CreateShader = nullptr;
  PFNGLSHADERSOURCEPROC ShaderSource = nullptr;
  PFNGLCOMPILESHADERPROC CompileShader = nullptr;
  PFNGLGETSHADERIVPROC GetShaderiv = nullptr;
  PFNGLGETSHADERINFOLOGPROC GetShaderInfoLog = nullptr;
  PFNGLDELETESHADERPROC DeleteShader = nullptr;
  PFNGLCREATEPROGRAMPROC CreateProgram = nullptr;
  PFNGLATTACHSHADERPROC AttachShader = nullptr;
  PFNGLLINKPROGRAMPROC LinkProgram = nullptr;
  PFNGLGETPROGRAMIVPROC GetProgramiv = nullptr;
  PFNGLGETPROGRAMINFOLOGPROC GetProgramInfoLog = nullptr;
  PFNGLDELETEPROGRAMPROC DeleteProgram = nullptr;
  PFNGLGETSTRINGPROC GetString = nullptr;
  PFNGLGETSTRINGIPROC GetStringi = nullptr;
  PFNGLGETINTEGERVPROC GetIntegerv = nullptr;

  ~State() {
    if (display != EGL_NO_DISPLAY) {
      eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
      eglTerminate(display);
    }
  }
};

GlDriver::GlDriver(std::unique_ptr<State> state) : state_(std::move(state)) {}
GlDriver::~GlDriver() = default;

namespace {

template <typename T>
bool load(T& function, const char* name) {
  function = reinterpret_cast<T>(eglGetProcAddress(name));
  return function != nullptr;
}

}  // namespace

std::unique_ptr<GlDriver> GlDriver::open(Api api, std::string& error) {
  auto state = std::make_unique<State>();
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!get_platform_display) {
    error = "EGL lacks eglGetPlatformDisplayEXT (install libegl1 and libegl-mesa0)";
    return nullptr;
  }
  state->display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  if (state->display == EGL_NO_DISPLAY || !eglInitialize(state->display, &major, &minor)) {
    error = "cannot open an EGL surfaceless display (install libegl-mesa0 and libgl1-mesa-dri)";
    state->display = EGL_NO_DISPLAY;
    return nullptr;
  }
  const bool gles = api == Api::Gles32;
  if (!eglBindAPI(gles ? EGL_OPENGL_ES_API : EGL_OPENGL_API)) {
    error = gles ? "EGL cannot bind OpenGL ES" : "EGL cannot bind desktop OpenGL";
    return nullptr;
  }
  const EGLint config_attributes[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                                      gles ? EGL_OPENGL_ES3_BIT : EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  if (!eglChooseConfig(state->display, config_attributes, &config, 1, &configs) || configs == 0) {
    error = "no EGL config for the requested API";
    return nullptr;
  }
  std::vector<EGLint> context_attributes = {EGL_CONTEXT_MAJOR_VERSION, gles ? 3 : 4, EGL_CONTEXT_MINOR_VERSION,
                                            gles ? 2 : 5};
  if (!gles) context_attributes.insert(context_attributes.end(),
                                       {EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT});
  context_attributes.push_back(EGL_NONE);
  state->context = eglCreateContext(state->display, config, EGL_NO_CONTEXT, context_attributes.data());
  if (state->context == EGL_NO_CONTEXT) {
    error = gles ? "cannot create an OpenGL ES 3.2 context" : "cannot create an OpenGL 4.5 core context";
    return nullptr;
  }
  if (!eglMakeCurrent(state->display, EGL_NO_SURFACE, EGL_NO_SURFACE, state->context)) {
    error = "cannot make the context current without a surface (EGL_KHR_surfaceless_context)";
    return nullptr;
  }
  State& s = *state;
  bool ok = load(s.CreateShader, "glCreateShader") && load(s.ShaderSource, "glShaderSource") &&
            load(s.CompileShader, "glCompileShader") && load(s.GetShaderiv, "glGetShaderiv") &&
            load(s.GetShaderInfoLog, "glGetShaderInfoLog") && load(s.DeleteShader, "glDeleteShader") &&
            load(s.CreateProgram, "glCreateProgram") && load(s.AttachShader, "glAttachShader") &&
            load(s.LinkProgram, "glLinkProgram") && load(s.GetProgramiv, "glGetProgramiv") &&
            load(s.GetProgramInfoLog, "glGetProgramInfoLog") && load(s.DeleteProgram, "glDeleteProgram") &&
            load(s.GetString, "glGetString") && load(s.GetStringi, "glGetStringi") &&
            load(s.GetIntegerv, "glGetIntegerv");
  if (!ok) {
    error = "the GL driver lacks a core entry point";
    return nullptr;
  }
  return std::unique_ptr<GlDriver>(new GlDriver(std::move(state)));
}

std::string GlDriver::renderer() const {
  auto text = [&](GLenum name) {
    const auto* value = reinterpret_cast<const char*>(state_->GetString(name));
    return std::string(value ? value : "?");
  };
  return text(GL_RENDERER) + ", " + text(GL_VERSION);
}

bool GlDriver::has_extension(const std::string& name) const {
  GLint count = 0;
  state_->GetIntegerv(GL_NUM_EXTENSIONS, &count);
  for (GLint i = 0; i < count; ++i)
    if (name == reinterpret_cast<const char*>(state_->GetStringi(GL_EXTENSIONS, GLuint(i)))) return true;
  return false;
}

namespace {

// glGetShaderiv/glGetShaderInfoLog and glGetProgramiv/glGetProgramInfoLog are twins: one check for both.
template <typename GetIv, typename GetLog>
bool succeeded(GLuint object, GLenum status, GetIv get_iv, GetLog get_log, const char* what, std::string& log) {
  GLint ok = 0;
  get_iv(object, status, &ok);
  if (!ok) {
    char buffer[4096] = {};
    get_log(object, sizeof buffer, nullptr, buffer);
    log += std::string(what) + ": " + buffer;
  }
  return ok != 0;
}

}  // namespace

bool GlDriver::compile_and_link(const std::string& vertex, const std::string& fragment, std::string& log) {
  State& s = *state_;
  auto compile = [&](GLenum type, const std::string& source, const char* what) -> GLuint {
    GLuint shader = s.CreateShader(type);
    const char* text = source.c_str();
    s.ShaderSource(shader, 1, &text, nullptr);
    s.CompileShader(shader);
    if (succeeded(shader, GL_COMPILE_STATUS, s.GetShaderiv, s.GetShaderInfoLog, what, log)) return shader;
    s.DeleteShader(shader);
    return 0;
  };
  GLuint vs = compile(GL_VERTEX_SHADER, vertex, "vertex");
  GLuint fs = compile(GL_FRAGMENT_SHADER, fragment, "fragment");
  bool linked = false;
  if (vs && fs) {
    GLuint program = s.CreateProgram();
    s.AttachShader(program, vs);
    s.AttachShader(program, fs);
    s.LinkProgram(program);
    linked = succeeded(program, GL_LINK_STATUS, s.GetProgramiv, s.GetProgramInfoLog, "link", log);
    s.DeleteProgram(program);
  }
  if (vs) s.DeleteShader(vs);
  if (fs) s.DeleteShader(fs);
  return linked;
}

}  // namespace kiln::gl
