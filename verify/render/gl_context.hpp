// SPDX-License-Identifier: Apache-2.0
// A real OpenGL driver with no display: Mesa llvmpipe through EGL's surfaceless platform
// (EGL_PLATFORM_SURFACELESS_MESA), as an OpenGL 4.5 core or an OpenGL ES 3.2 context, current on the calling
// thread. The entry points have the same signatures in desktop GL and GLES; they are fetched with
// eglGetProcAddress, so one binary drives both APIs without linking libOpenGL or libGLESv2.
#pragma once

#include <GLES3/gl32.h>

#include <memory>
#include <string>

#include "kiln/result.hpp"

namespace kiln::render {

enum class GlApi { DesktopGl45, Gles32 };

// X(name): the GL entry points kiln uses, fetched as `gl<name>`.
#define KILN_GL_FUNCTIONS(X)                                                                                 \
  X(GetError) X(GetString) X(GetStringi) X(GetIntegerv) X(Enable) X(Disable) X(Finish)                        \
  X(CreateShader) X(ShaderSource) X(CompileShader) X(GetShaderiv) X(GetShaderInfoLog) X(DeleteShader)       \
  X(CreateProgram) X(AttachShader) X(LinkProgram) X(GetProgramiv) X(GetProgramInfoLog) X(DeleteProgram)     \
  X(UseProgram) X(GetUniformBlockIndex) X(GetActiveUniformBlockiv) X(GetProgramResourceIndex)               \
  X(GetProgramResourceiv) X(GetUniformLocation) X(GetUniformiv)                                             \
  X(GenBuffers) X(DeleteBuffers) X(BindBuffer) X(BufferData) X(BindBufferBase)                              \
  X(GenTextures) X(DeleteTextures) X(BindTexture) X(ActiveTexture) X(TexStorage2D) X(TexSubImage2D)         \
  X(TexParameteri) X(GenSamplers) X(DeleteSamplers) X(BindSampler) X(SamplerParameteri) X(SamplerParameterf) \
  X(GenFramebuffers) X(DeleteFramebuffers) X(BindFramebuffer) X(FramebufferTexture2D)                      \
  X(CheckFramebufferStatus) X(DrawBuffers) X(ReadBuffer) X(ReadPixels) X(PixelStorei)                      \
  X(GenVertexArrays) X(DeleteVertexArrays) X(BindVertexArray) X(VertexAttribPointer)                        \
  X(EnableVertexAttribArray) X(Viewport) X(Scissor) X(DepthFunc) X(DepthMask) X(FrontFace)                  \
  X(ClearBufferfv) X(DrawElements) X(MapBufferRange) X(UnmapBuffer) X(MemoryBarrier)

struct GlFunctions {
#define KILN_GL_MEMBER(name) decltype(&::gl##name) name = nullptr;
  KILN_GL_FUNCTIONS(KILN_GL_MEMBER)
#undef KILN_GL_MEMBER
};

class GlContext {
 public:
  // Opens an EGL display on the surfaceless platform and makes a context of `api` current (no surface).
  // The error says what is missing.
  static Result<std::unique_ptr<GlContext>> open(GlApi api);
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  GlApi api() const { return api_; }
  const GlFunctions& gl() const { return gl_; }
  std::string renderer() const;  // GL_RENDERER and GL_VERSION
  bool has_extension(const std::string& name) const;
  // Throws a VerifyError (K2007) naming `what` if the driver recorded an error.
  void check(const char* what) const;

  // Compiles both stages and links them; returns the program, or 0 with the driver's messages in `log`.
  unsigned compile_and_link(const std::string& vertex, const std::string& fragment, std::string& log) const;

 private:
  GlContext() = default;
  GlApi api_ = GlApi::DesktopGl45;
  void* display_ = nullptr;
  void* context_ = nullptr;
  GlFunctions gl_;
};

}  // namespace kiln::render
