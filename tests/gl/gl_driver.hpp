// A real OpenGL driver for kiln's GLSL outputs: Mesa llvmpipe through EGL's surfaceless platform (no display,
// no window). Used by tests to compile and link every variant's GLSL 450 and GLSL ES output.
#pragma once

#include <memory>
#include <string>

namespace kiln::gl {

enum class Api { DesktopGl45, Gles32 };

class GlDriver {
 public:
  // Opens an EGL display on the surfaceless platform and makes a context of `api` current (no surface).
  // On failure returns null and says what is missing.
  static std::unique_ptr<GlDriver> open(Api api, std::string& error);
  ~GlDriver();
  GlDriver(const GlDriver&) = delete;
  GlDriver& operator=(const GlDriver&) = delete;

  std::string renderer() const;  // GL_RENDERER and GL_VERSION
  bool has_extension(const std::string& name) const;
  // Compiles both stages and links them; on failure `log` holds the driver's messages.
  bool compile_and_link(const std::string& vertex, const std::string& fragment, std::string& log);

 private:
  struct State;
  explicit GlDriver(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

}  // namespace kiln::gl
