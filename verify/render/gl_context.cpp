// SPDX-License-Identifier: Apache-2.0
#include "render/gl_context.hpp"
#include "scene/verify_error.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstdio>
#include <stdexcept>
#include <vector>

namespace kiln::render {

Result<std::unique_ptr<GlContext>> GlContext::open(GlApi api) {
  std::unique_ptr<GlContext> gl(new GlContext());
  gl->api_ = api;
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!get_platform_display) {
    return failure("EGL lacks eglGetPlatformDisplayEXT (install libegl1 and libegl-mesa0)");
  }
  EGLDisplay display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  EGLint major = 0, minor = 0;
  if (display == EGL_NO_DISPLAY || !eglInitialize(display, &major, &minor)) {
    return failure("cannot open an EGL surfaceless display (install libegl-mesa0 and libgl1-mesa-dri)");
  }
  gl->display_ = display;
  const bool gles = api == GlApi::Gles32;
  if (!eglBindAPI(gles ? EGL_OPENGL_ES_API : EGL_OPENGL_API)) {
    return failure(gles ? "EGL cannot bind OpenGL ES" : "EGL cannot bind desktop OpenGL");
  }
  const EGLint config_attributes[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                                      gles ? EGL_OPENGL_ES3_BIT : EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  if (!eglChooseConfig(display, config_attributes, &config, 1, &configs) || configs == 0) {
    return failure("no EGL config for the requested API");
  }
  std::vector<EGLint> context_attributes = {EGL_CONTEXT_MAJOR_VERSION, gles ? 3 : 4, EGL_CONTEXT_MINOR_VERSION,
                                            gles ? 2 : 5};
  if (!gles)
    context_attributes.insert(context_attributes.end(),
                              {EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT});
  context_attributes.push_back(EGL_NONE);
  EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attributes.data());
  if (context == EGL_NO_CONTEXT) {
    return failure(gles ? "cannot create an OpenGL ES 3.2 context" : "cannot create an OpenGL 4.5 core context");
  }
  gl->context_ = context;
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
    return failure("cannot make the context current without a surface (EGL_KHR_surfaceless_context)");
  }
  std::string missing;  // the first function the driver lacks
#define KILN_GL_LOAD(name)                                                                         \
  gl->gl_.name = reinterpret_cast<decltype(&::gl##name)>(eglGetProcAddress("gl" #name));           \
  if (!gl->gl_.name && missing.empty()) missing = "gl" #name;
  KILN_GL_FUNCTIONS(KILN_GL_LOAD)
#undef KILN_GL_LOAD
  if (!missing.empty()) return failure("the GL driver lacks " + missing);
  return gl;
}

GlContext::~GlContext() {
  if (!display_) return;
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (context_) eglDestroyContext(display_, context_);
  eglTerminate(display_);
}

std::string GlContext::renderer() const {
  auto text = [&](GLenum name) {
    const auto* value = reinterpret_cast<const char*>(gl_.GetString(name));
    return std::string(value ? value : "?");
  };
  return text(GL_RENDERER) + ", " + text(GL_VERSION);
}

bool GlContext::has_extension(const std::string& name) const {
  GLint count = 0;
  gl_.GetIntegerv(GL_NUM_EXTENSIONS, &count);
  for (GLint i = 0; i < count; ++i)
    if (name == reinterpret_cast<const char*>(gl_.GetStringi(GL_EXTENSIONS, GLuint(i)))) return true;
  return false;
}

void GlContext::check(const char* what) const {
  GLenum error = gl_.GetError();
  if (error == GL_NO_ERROR) return;
  char code[16];
  std::snprintf(code, sizeof code, "0x%04x", error);
  fail(DiagId::DriverCallFailed, {}, std::string("OpenGL error ") + code + " after " + what);
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

unsigned GlContext::compile_and_link(const std::string& vertex, const std::string& fragment, std::string& log) const {
  auto compile = [&](GLenum type, const std::string& source, const char* what) -> GLuint {
    GLuint shader = gl_.CreateShader(type);
    const char* text = source.c_str();
    gl_.ShaderSource(shader, 1, &text, nullptr);
    gl_.CompileShader(shader);
    if (succeeded(shader, GL_COMPILE_STATUS, gl_.GetShaderiv, gl_.GetShaderInfoLog, what, log)) return shader;
    gl_.DeleteShader(shader);
    return 0;
  };
  GLuint vs = compile(GL_VERTEX_SHADER, vertex, "vertex");
  GLuint fs = compile(GL_FRAGMENT_SHADER, fragment, "fragment");
  GLuint program = 0;
  if (vs && fs) {
    program = gl_.CreateProgram();
    gl_.AttachShader(program, vs);
    gl_.AttachShader(program, fs);
    gl_.LinkProgram(program);
    if (!succeeded(program, GL_LINK_STATUS, gl_.GetProgramiv, gl_.GetProgramInfoLog, "link", log)) {
      gl_.DeleteProgram(program);
      program = 0;
    }
  }
  if (vs) gl_.DeleteShader(vs);
  if (fs) gl_.DeleteShader(fs);
  return program;
}

}  // namespace kiln::render
