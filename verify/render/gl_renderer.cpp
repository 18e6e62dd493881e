// SPDX-License-Identifier: Apache-2.0
#include "render/gl_renderer.hpp"

#include <algorithm>
#include <list>
#include <map>

#include "render/renderer.hpp"
#include "render/scene_data.hpp"

#ifndef GL_TEXTURE_CUBE_MAP_SEAMLESS
#define GL_TEXTURE_CUBE_MAP_SEAMLESS 0x884F  // desktop GL only; GLES 3 cube maps are always seamless
#endif

namespace kiln::render {
namespace {


struct GlMesh {
  GLuint vertices = 0, indices = 0;
  GLsizei index_count = 0;
};

// One program's resources as the manifest's GL records list them (both stages, merged).
struct GlBindings {
  struct Block {
    std::string name;
    bool storage = false;
    GLuint binding = 0;
  };
  struct Sampler {
    std::string name, texture, sampler;
    GLuint unit = 0;
  };
  std::vector<Block> blocks;
  std::vector<Sampler> samplers;
};

GlBindings manifest_bindings(const SelectedVariant& variant, bool gles) {
  GlBindings b;
  std::map<std::string, GLuint> seen;  // by name: a resource both stages read must have one binding
  auto add = [&](const std::string& name, GLuint binding) {
    auto [it, inserted] = seen.emplace(name, binding);
    if (!inserted && it->second != binding)
      render_error("the manifest binds '" + name + "' at " + std::to_string(it->second) + " in one stage and " +
                   std::to_string(binding) + " in the other");
    return inserted;
  };
  for (const StageView& stage : variant.stages) {
    if (!stage.reflection) continue;
    const kiln::GlBindings* records = stage.reflection->gl(gles);
    if (!records) continue;
    for (const kiln::GlBlock& r : records->blocks)
      if (add(r.name, r.binding)) b.blocks.push_back({r.name, r.kind == kiln::ResourceKind::StorageBuffer, r.binding});
    for (const kiln::GlCombinedSampler& r : records->combined_image_samplers)
      if (add(r.name, r.binding)) b.samplers.push_back({r.name, r.texture, r.sampler, r.binding});
  }
  for (size_t i = 0; i < b.samplers.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (b.samplers[i].unit == b.samplers[j].unit)
        render_error("'" + b.samplers[i].name + "' and '" + b.samplers[j].name + "' share texture unit " +
                     std::to_string(b.samplers[i].unit) + ", which GL cannot bind");
  return b;
}

// The manifest's records are what a user's engine binds by: the linked program must agree with them.
void check_bindings_against_driver(const GlFunctions& gl, GLuint program, const GlBindings& bindings) {
  auto mismatch = [](const std::string& name, GLuint recorded, GLint reported) {
    render_error("the manifest records binding " + std::to_string(recorded) + " for '" + name +
                 "' but the GL driver reports " + std::to_string(reported));
  };
  for (const auto& block : bindings.blocks) {
    GLint reported = -1;
    if (block.storage) {
      GLuint index = gl.GetProgramResourceIndex(program, GL_SHADER_STORAGE_BLOCK, block.name.c_str());
      if (index == GL_INVALID_INDEX) continue;  // removed by the driver's own dead-code elimination
      const GLenum property = GL_BUFFER_BINDING;
      gl.GetProgramResourceiv(program, GL_SHADER_STORAGE_BLOCK, index, 1, &property, 1, nullptr, &reported);
    } else {
      GLuint index = gl.GetUniformBlockIndex(program, block.name.c_str());
      if (index == GL_INVALID_INDEX) continue;
      gl.GetActiveUniformBlockiv(program, index, GL_UNIFORM_BLOCK_BINDING, &reported);
    }
    if (reported != GLint(block.binding)) mismatch(block.name, block.binding, reported);
  }
  for (const auto& sampler : bindings.samplers) {
    GLint location = gl.GetUniformLocation(program, sampler.name.c_str());
    if (location < 0) continue;
    GLint unit = -1;
    gl.GetUniformiv(program, location, &unit);
    if (unit != GLint(sampler.unit)) mismatch(sampler.name, sampler.unit, unit);
  }
}

std::string source(const StageView* stage, bool gles, const SelectedVariant& variant) {
  std::string_view text = stage ? (gles ? stage->gles : stage->glsl) : std::string_view();
  if (text.empty())
    render_error("variant " + variant.pass + " #" + std::to_string(variant.index) + " has no " +
                 (gles ? "GLSL ES" : "GLSL 450") + " output (build the pack with the " + (gles ? "gles" : "glsl") +
                 " target)");
  // A folded pack's specialization constants (kiln/folded_keywords.hpp): SPIRV-Cross's macros, after #version.
  std::string constants;
  const std::optional<Stage> which = parse_stage(stage->stage);
  for (const KeywordValue& v : variant.values)
    if (is_constant(v.kind) && v.sets() && which && (v.stages & stage_bit(*which)))
      constants += "#define SPIRV_CROSS_CONSTANT_ID_" + std::to_string(v.slot) + " " +
                   (v.kind == KeywordKind::SpecializationInteger ? std::to_string(v.data()) : v.on ? "true" : "false") + "\n";
  if (constants.empty()) return std::string(text);
  const size_t line_end = text.find('\n');
  if (!text.starts_with("#version") || line_end == std::string_view::npos)
    render_error("variant " + variant.pass + " #" + std::to_string(variant.index) + "'s GLSL does not start with #version");
  return std::string(text.substr(0, line_end + 1)) + constants + std::string(text.substr(line_end + 1));
}

}  // namespace

struct GlSceneRenderer::State {
  GlContext& context;
  const GlFunctions& gl;
  const bool gles;
  const PackReader& pack;
  SceneData data;
  GlMesh sphere, plane;
  GLuint vertex_array = 0;
  GLuint environment_map = 0, dfg = 0, additional_atlas = 0;
  GLuint linear_sampler = 0, compare_sampler = 0;
  std::vector<GLuint> per_material, per_object;
  GLuint lights = 0, tiles = 0, shadow_matrices = 0;
  // A --coverage pack's coverage buffer (kiln/coverage_map.hpp), and who reads it after each draw.
  GLuint coverage = 0;
  CoverageRecorder* recorder = nullptr;
  // A folded pack's dynamic branches: the keyword block, rewritten with each variant's bools before its draw.
  GLuint keywords = 0;
  GLsizeiptr keywords_size = 0;
  struct Frame {
    const SceneData::Frame* data = nullptr;
    GLuint per_frame = 0;
    GLuint main_atlas = 0;
  };
  std::map<int, Frame> frames;
  bool additional_rendered = false;
  GLuint color_framebuffer = 0, color_texture = 0, depth_texture = 0;
  // Everything created, deleted with the renderer.
  std::vector<GLuint> buffers, textures, samplers, framebuffers;
  // Image programs by their sources: variants whose GLSL is byte-identical for both stages draw with one
  // program, compiled and linked once. The most recently used few are kept (kiln test renders the variants
  // of one program one after another).
  struct CachedProgram {
    std::string pass;
    std::string_view vertex, fragment;  // GLSL (owned by the pack reader)
    std::vector<KeywordValue> constants;  // the variant's specialization constants (#define'd into the sources)
    GLuint program = 0;
    GlBindings bindings;
  };
  static constexpr size_t kCachedPrograms = 8;
  std::list<CachedProgram> programs;  // most recent first
  size_t programs_created = 0, programs_reused = 0;

  State(GlContext& c, const PackReader& p, const Scene& scene)
      : context(c), gl(c.gl()), gles(c.api() == GlApi::Gles32), pack(p), data(p, scene) {}
  ~State() {
    gl.DeleteBuffers(GLsizei(buffers.size()), buffers.data());
    gl.DeleteTextures(GLsizei(textures.size()), textures.data());
    gl.DeleteSamplers(GLsizei(samplers.size()), samplers.data());
    gl.DeleteFramebuffers(GLsizei(framebuffers.size()), framebuffers.data());
    gl.DeleteVertexArrays(1, &vertex_array);
    for (const CachedProgram& p : programs) gl.DeleteProgram(p.program);
  }

  const CachedProgram& image_program(const SelectedVariant& variant) {
    const StageView* vs = variant.stage("vertex");
    const StageView* fs = variant.stage("fragment");
    auto text = [&](const StageView* stage) { return stage ? (gles ? stage->gles : stage->glsl) : std::string_view(); };
    std::vector<KeywordValue> constants;
    for (const KeywordValue& v : variant.values)
      if (is_constant(v.kind)) constants.push_back(v);
    auto found = std::find_if(programs.begin(), programs.end(), [&](const CachedProgram& p) {
      return p.pass == variant.pass && p.vertex == text(vs) && p.fragment == text(fs) && p.constants == constants;
    });
    if (found != programs.end()) {
      programs.splice(programs.begin(), programs, found);
      ++programs_reused;
      return programs.front();
    }
    CachedProgram entry{variant.pass, text(vs), text(fs), std::move(constants), 0, {}};
    entry.program = link(variant, entry.bindings);
    ++programs_created;
    programs.push_front(std::move(entry));
    if (programs.size() > kCachedPrograms) {
      gl.DeleteProgram(programs.back().program);
      programs.pop_back();
    }
    return programs.front();
  }

  GLuint buffer(GLenum target, const void* bytes, size_t size) {
    GLuint b = 0;
    gl.GenBuffers(1, &b);
    gl.BindBuffer(target, b);
    // At least 16 bytes: an empty list (no lights) still has to be bound.
    std::vector<uint8_t> padded(std::max<size_t>(size, 16), 0);
    if (size) std::copy_n(static_cast<const uint8_t*>(bytes), size, padded.begin());
    gl.BufferData(target, GLsizeiptr(padded.size()), padded.data(), GL_STATIC_DRAW);
    buffers.push_back(b);
    return b;
  }
  GLuint buffer(const Bytes& bytes) { return buffer(GL_UNIFORM_BUFFER, bytes.data(), bytes.size()); }

  GLuint texture(GLenum target, GLsizei levels, GLenum format, GLsizei width, GLsizei height) {
    GLuint t = 0;
    gl.GenTextures(1, &t);
    gl.BindTexture(target, t);
    gl.TexStorage2D(target, levels, format, width, height);
    textures.push_back(t);
    return t;
  }

  GLuint depth_target(GLuint depth) {
    GLuint fb = 0;
    gl.GenFramebuffers(1, &fb);
    gl.BindFramebuffer(GL_FRAMEBUFFER, fb);
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
    framebuffers.push_back(fb);
    return fb;
  }

  GLuint buffer_for(const std::string& name, size_t object, const Frame& frame) const {
    if (name == "PerFrame") return frame.per_frame;
    if (name == "PerMaterial") return per_material.at(object);
    if (name == "PerObject") return per_object.at(object);
    if (name == "_AdditionalLights") return lights;
    if (name == "_TileLightIndices") return tiles;
    if (name == "_AdditionalShadowMatrices") return shadow_matrices;
    if (name == kCoverageBufferName && coverage) return coverage;
    if (name == kKeywordBlockName && keywords) return keywords;
    render_error("the program binds '" + name + "', which the renderer does not provide");
  }

  // Binds a program's resources for one object and draws it; `extra` names a block bound to `extra_buffer`.
  void draw_objects(GLuint program, const SelectedVariant& variant, const GlBindings& bindings, const Frame& frame,
                    const std::string& extra = {}, GLuint extra_buffer = 0) {
    gl.UseProgram(program);
    gl.BindVertexArray(vertex_array);
    const std::vector<MeshAttribute> attributes = mesh_attributes(*variant.stage("vertex"));
    for (const auto& s : bindings.samplers) {
      GLenum target = GL_TEXTURE_2D;
      GLuint texture = 0;
      if (s.texture == "_MainLightShadowMap") texture = frame.main_atlas;
      else if (s.texture == "_AdditionalLightsShadowMap") texture = additional_atlas;
      else if (s.texture == "_DFG") texture = dfg;
      else if (s.texture == "_EnvironmentMap") texture = environment_map, target = GL_TEXTURE_CUBE_MAP;
      else render_error("the program samples '" + s.texture + "', which the renderer does not provide");
      GLuint sampler = s.sampler == "sampler_ShadowCompare" ? compare_sampler
                       : s.sampler == "sampler_LinearClamp" ? linear_sampler
                                                            : 0;
      if (!sampler) render_error("the program samples with '" + s.sampler + "', which the renderer does not provide");
      gl.ActiveTexture(GL_TEXTURE0 + s.unit);
      gl.BindTexture(target, texture);
      gl.BindSampler(s.unit, sampler);
    }
    const Scene& scene = data.scene();
    for (size_t i = 0; i < scene.objects.size(); ++i) {
      for (const auto& b : bindings.blocks) {
        GLuint buffer = b.name == extra && extra_buffer ? extra_buffer : buffer_for(b.name, i, frame);
        gl.BindBufferBase(b.storage ? GL_SHADER_STORAGE_BUFFER : GL_UNIFORM_BUFFER, b.binding, buffer);
      }
      const GlMesh& mesh = scene.objects[i].shape == Object::Shape::Plane ? plane : sphere;
      gl.BindBuffer(GL_ARRAY_BUFFER, mesh.vertices);
      for (const MeshAttribute& a : attributes) {
        gl.EnableVertexAttribArray(a.location);
        gl.VertexAttribPointer(a.location, GLint(a.components), GL_FLOAT, GL_FALSE, kVertexFloats * 4,
                               reinterpret_cast<const void*>(uintptr_t(a.offset)));
      }
      gl.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, mesh.indices);
      gl.DrawElements(GL_TRIANGLES, mesh.index_count, GL_UNSIGNED_INT, nullptr);
    }
    context.check("drawing the scene");
  }

  GLuint link(const SelectedVariant& variant, GlBindings& bindings) {
    std::string log;
    GLuint program = context.compile_and_link(source(variant.stage("vertex"), gles, variant),
                                              source(variant.stage("fragment"), gles, variant), log);
    if (!program)
      render_error(DiagId::DriverCallFailed, "the GL driver rejects " + variant.pass + " #" + std::to_string(variant.index) + ": " + log);
    bindings = manifest_bindings(variant, gles);
    check_bindings_against_driver(gl, program, bindings);
    return program;
  }

  // After a draw with `variant`'s program: the words its stages set in the coverage buffer, to the recorder, which
  // clears them. The GLSL is the instrumented SPIR-V's translation: the same words, so the SPIR-V's maps.
  void credit_coverage(const SelectedVariant& variant, std::string_view role = {}) {
    if (!recorder || !coverage) return;
    gl.MemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    gl.BindBuffer(GL_SHADER_STORAGE_BUFFER, coverage);
    void* words = gl.MapBufferRange(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr{kCoverageBufferWords} * 4, GL_MAP_READ_BIT | GL_MAP_WRITE_BIT);
    if (!words) render_error(DiagId::DriverCallFailed, "the GL driver cannot map the coverage buffer");
    std::vector<std::string_view> modules;
    for (const StageView& stage : variant.stages) modules.push_back(stage.spirv);
    recorder->credit(modules, static_cast<uint32_t*>(words), kCoverageBufferWords, role);
    gl.UnmapBuffer(GL_SHADER_STORAGE_BUFFER);
    context.check("reading the coverage buffer");
  }

  // Draws the ShadowCaster pass's GL output into a depth atlas, one viewport per shadow view.
  void render_atlas(GLuint atlas, GLsizei size_x, GLsizei size_y, const std::vector<ShadowView>& views, bool punctual,
                    const Frame& frame) {
    depth_target(atlas);  // bound
    const GLenum none = GL_NONE;
    gl.DrawBuffers(1, &none);
    gl.ReadBuffer(GL_NONE);
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      render_error(DiagId::DeviceUnavailable, "the GL driver cannot render into a DEPTH_COMPONENT32F shadow atlas");
    gl.Viewport(0, 0, size_x, size_y);
    gl.Disable(GL_SCISSOR_TEST);
    const GLfloat one = 1.0f;
    gl.ClearBufferfv(GL_DEPTH, 0, &one);
    if (!views.empty()) {
      SelectedVariant variant = pack.select(
          "ShadowCaster", punctual ? std::vector<std::string>{"_CASTING_PUNCTUAL_LIGHT_SHADOW"} : std::vector<std::string>{});
      GlBindings bindings;
      GLuint program = link(variant, bindings);
      gl.Enable(GL_SCISSOR_TEST);
      for (const ShadowView& view : views) {
        gl.Viewport(GLint(view.x), GLint(view.y), GLsizei(view.size), GLsizei(view.size));
        gl.Scissor(GLint(view.x), GLint(view.y), GLsizei(view.size), GLsizei(view.size));
        GLuint constants = buffer(data.caster_constants(view));
        draw_objects(program, variant, bindings, frame, "ShadowCaster", constants);
      }
      credit_coverage(variant, "(shadow caster)");
      gl.Disable(GL_SCISSOR_TEST);
      gl.DeleteProgram(program);
    }
    gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
    context.check("drawing a shadow atlas");
  }

};

GlSceneRenderer::GlSceneRenderer(GlContext& context, const PackReader& pack, const Scene& scene, uint32_t width,
                                 uint32_t height)
    : scene_(scene), width_(width ? width : scene.width), height_(height ? height : scene.height) {
  scene_.width = width_;
  scene_.height = height_;
  const GlFunctions& gl = context.gl();
  if (context.api() == GlApi::Gles32) {
    for (const char* extension : {"GL_EXT_color_buffer_float", "GL_OES_texture_float_linear"})
      if (!context.has_extension(extension))
        render_error(DiagId::DeviceUnavailable, std::string("the OpenGL ES driver lacks ") + extension + " (float render targets and filtering)");
  } else {
    gl.Enable(GL_TEXTURE_CUBE_MAP_SEAMLESS);  // Vulkan's cube sampling is seamless
  }
  state_ = std::make_unique<State>(context, pack, scene_);
  State& s = *state_;
  gl.GenVertexArrays(1, &s.vertex_array);
  auto upload_mesh = [&](const Mesh& mesh) {
    GlMesh m;
    m.vertices = s.buffer(GL_ARRAY_BUFFER, mesh.vertices.data(), mesh.vertices.size() * 4);
    m.indices = s.buffer(GL_ELEMENT_ARRAY_BUFFER, mesh.indices.data(), mesh.indices.size() * 4);
    m.index_count = GLsizei(mesh.indices.size());
    return m;
  };
  gl.BindVertexArray(s.vertex_array);
  s.sphere = upload_mesh(make_sphere(64, 32));
  s.plane = upload_mesh(make_plane(32));

  // The environment cube (prefiltered mips; the same faces and rows as the Vulkan layers) and the DFG table.
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
  const Environment& environment = s.data.environment();
  s.environment_map = s.texture(GL_TEXTURE_CUBE_MAP, GLsizei(environment.mips), GL_RGBA32F, GLsizei(environment.size),
                                GLsizei(environment.size));
  for (uint32_t m = 0; m < environment.mips; ++m) {
    const uint32_t n = environment.level_size(m);
    for (uint32_t face = 0; face < 6; ++face)
      gl.TexSubImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + face, GLint(m), 0, 0, GLsizei(n), GLsizei(n), GL_RGBA, GL_FLOAT,
                       environment.levels[m].data() + size_t(face) * n * n * 4);
  }
  const DfgTable& dfg = s.data.dfg();
  s.dfg = s.texture(GL_TEXTURE_2D, 1, GL_RG32F, GLsizei(dfg.width), GLsizei(dfg.height));
  gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, GLsizei(dfg.width), GLsizei(dfg.height), GL_RG, GL_FLOAT, dfg.rg.data());

  // The samplers of the Vulkan renderer: trilinear clamped, and nearest compared taps (LESS_OR_EQUAL).
  GLuint samplers[2];
  gl.GenSamplers(2, samplers);
  s.samplers.assign(samplers, samplers + 2);
  s.linear_sampler = samplers[0];
  gl.SamplerParameteri(s.linear_sampler, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  gl.SamplerParameteri(s.linear_sampler, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  s.compare_sampler = samplers[1];
  gl.SamplerParameteri(s.compare_sampler, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  gl.SamplerParameteri(s.compare_sampler, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  gl.SamplerParameteri(s.compare_sampler, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  gl.SamplerParameteri(s.compare_sampler, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  for (GLuint sampler : samplers)
    for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
      gl.SamplerParameteri(sampler, wrap, GL_CLAMP_TO_EDGE);
  gl.SamplerParameterf(s.linear_sampler, GL_TEXTURE_MAX_LOD, 16.0f);

  const SceneData::Frame& base = s.data.frame(1);
  for (size_t i = 0; i < scene_.objects.size(); ++i) {
    s.per_material.push_back(s.buffer(s.data.buffer("PerMaterial", i, base)));
    s.per_object.push_back(s.buffer(s.data.buffer("PerObject", i, base)));
  }
  for (auto [name, slot] : {std::pair{"_AdditionalLights", &s.lights}, std::pair{"_TileLightIndices", &s.tiles},
                            std::pair{"_AdditionalShadowMatrices", &s.shadow_matrices}}) {
    const Bytes& bytes = s.data.buffer(name, 0, base);
    *slot = s.buffer(GL_SHADER_STORAGE_BUFFER, bytes.data(), bytes.size());
  }
  for (const ManifestPass& pass : pack.manifest().passes)
    for (const Resource& r : pass.layout.resources)
      if (r.name == kKeywordBlockName && r.kind == ResourceKind::UniformBuffer && !s.keywords) {
        s.keywords_size = GLsizeiptr(std::max<uint64_t>(r.size, 16));
        const std::vector<uint8_t> zeros(size_t(s.keywords_size), 0);
        s.keywords = s.buffer(GL_UNIFORM_BUFFER, zeros.data(), zeros.size());
      } else if (r.name == kCoverageBufferName && !s.coverage) {
        const std::vector<uint32_t> zeros(kCoverageBufferWords, 0);
        s.coverage = s.buffer(GL_SHADER_STORAGE_BUFFER, zeros.data(), zeros.size() * 4);
      }
  s.additional_atlas = s.texture(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT32F,
                                 GLsizei(std::max(1u, base.setup.additional_atlas_width)),
                                 GLsizei(std::max(1u, base.setup.additional_atlas_height)));

  // The float color target and its depth buffer.
  s.color_texture = s.texture(GL_TEXTURE_2D, 1, GL_RGBA32F, GLsizei(width_), GLsizei(height_));
  s.depth_texture = s.texture(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT32F, GLsizei(width_), GLsizei(height_));
  s.color_framebuffer = s.depth_target(s.depth_texture);
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, s.color_texture, 0);
  const GLenum color = GL_COLOR_ATTACHMENT0;
  gl.DrawBuffers(1, &color);
  if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    render_error(DiagId::DeviceUnavailable, "the GL driver cannot render into an RGBA32F target with a DEPTH_COMPONENT32F depth buffer");
  gl.BindFramebuffer(GL_FRAMEBUFFER, 0);

  // Fixed state shared by every pass: depth test LESS (Vulkan's), no culling, Vulkan's front face.
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LESS);
  gl.DepthMask(GL_TRUE);
  gl.Disable(GL_CULL_FACE);
  gl.FrontFace(GL_CW);
  context.check("setting up the scene");
}

GlSceneRenderer::~GlSceneRenderer() = default;

size_t GlSceneRenderer::pipelines_created() const { return state_->programs_created; }
void GlSceneRenderer::record_coverage(CoverageRecorder* recorder) { state_->recorder = recorder; }
size_t GlSceneRenderer::pipelines_reused() const { return state_->programs_reused; }

Image GlSceneRenderer::render(const std::vector<std::string>& keywords) {
  return render(state_->pack.select("Forward", keywords));
}

Image GlSceneRenderer::render(const SelectedVariant& variant) {
  State& s = *state_;
  const GlFunctions& gl = s.gl;
  if (variant.pass == "ShadowCaster") render_error(DiagId::VerifyArgument, "the ShadowCaster pass draws shadow maps, not images");
  const int cascades = cascades_for(variant.keywords, scene_);
  State::Frame& f = s.frames[cascades];
  if (!f.data) {
    f.data = &s.data.frame(cascades);
    f.per_frame = s.buffer(f.data->per_frame);
    const FrameSetup& setup = f.data->setup;
    f.main_atlas = s.texture(GL_TEXTURE_2D, 1, GL_DEPTH_COMPONENT32F, GLsizei(setup.main_atlas_size),
                             GLsizei(setup.main_atlas_size));
    s.render_atlas(f.main_atlas, GLsizei(setup.main_atlas_size), GLsizei(setup.main_atlas_size), setup.main_views,
                   false, f);
    if (!s.additional_rendered) {
      s.additional_rendered = true;
      // Without shadowed lights (or punctual casters in the pack) the atlas stays cleared: fully lit.
      const bool draw = !setup.additional_views.empty() && s.data.has_punctual_caster();
      s.render_atlas(s.additional_atlas, GLsizei(std::max(1u, setup.additional_atlas_width)),
                     GLsizei(std::max(1u, setup.additional_atlas_height)),
                     draw ? setup.additional_views : std::vector<ShadowView>{}, true, f);
    }
  }
  const State::CachedProgram& cached = s.image_program(variant);
  gl.BindFramebuffer(GL_FRAMEBUFFER, s.color_framebuffer);
  gl.Viewport(0, 0, GLsizei(width_), GLsizei(height_));
  const GLfloat zero[4] = {0, 0, 0, 0}, one = 1.0f;
  gl.ClearBufferfv(GL_DEPTH, 0, &one);
  gl.ClearBufferfv(GL_COLOR, 0, zero);
  if (s.keywords) {  // the variant's dynamic branches
    std::vector<uint8_t> block(size_t(s.keywords_size), 0);
    for (const KeywordValue& v : variant.values)
      if (v.kind == KeywordKind::DynamicBranch && v.slot + 4 <= block.size()) block[v.slot] = static_cast<uint8_t>(v.data());
    gl.BindBuffer(GL_UNIFORM_BUFFER, s.keywords);
    gl.BufferData(GL_UNIFORM_BUFFER, s.keywords_size, block.data(), GL_DYNAMIC_DRAW);
  }
  s.draw_objects(cached.program, variant, cached.bindings, f);
  s.credit_coverage(variant);
  // Bottom row first: row 0 is NDC y = -1 in both APIs, so this is the Vulkan image's row order.
  Image out{width_, height_, {}};
  out.rgba.resize(size_t(width_) * height_ * 4);
  gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
  gl.ReadPixels(0, 0, GLsizei(width_), GLsizei(height_), GL_RGBA, GL_FLOAT, out.rgba.data());
  gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
  s.context.check("reading the image back");
  return out;
}

}  // namespace kiln::render
