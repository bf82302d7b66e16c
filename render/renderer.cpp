#include "render/renderer.h"

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "render/camera.h"
#include "render/colour.h"
#include "render/gl_context.h"
#include "render/grid_lines.h"
#include "render/shaders.h"
#include "sim/core/errors.h"

namespace snowsim {

ColorBy parseColorBy(const std::string& name, const std::string& where) {
  if (name == "white") return ColorBy::White;
  if (name == "density") return ColorBy::Density;
  if (name == "speed") return ColorBy::Speed;
  if (name == "plastic") return ColorBy::Plastic;
  throw InputError(where + ": \"" + name +
                   "\" is not allowed; allowed: white, density, speed, plastic");
}

void validate(const RenderSettings& s) {
  if (s.width < 16 || s.width > 8192 || s.height < 16 || s.height > 8192)
    throw InputError("image size " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                     " is out of range; allowed: 16 to 8192 pixels each way");
  if (s.sphere_radius < 0) throw InputError("sphere radius must not be negative");
  if (!(s.camera.fov_degrees > 0 && s.camera.fov_degrees < 180))
    throw InputError("camera field of view " + std::to_string(s.camera.fov_degrees) +
                     " is out of range; allowed: (0, 180) degrees");
  if (s.camera.custom && s.camera.eye == s.camera.target)
    throw InputError("camera eye and target must differ");
  if (s.color_range && !(s.color_range->high > s.color_range->low))
    throw InputError("colour range [" + std::to_string(s.color_range->low) + ", " +
                     std::to_string(s.color_range->high) + "] is empty; allowed: low < high");
}

namespace {

// The shader files carry no #version line, so shared code (lighting.glsl) can follow it.
GLuint compile(GLenum type, std::vector<const char*> sources) {
  sources.insert(sources.begin(), "#version 330 core\n");
  const GLuint shader = glCreateShader(type);
  glShaderSource(shader, static_cast<GLsizei>(sources.size()), sources.data(), nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    throw std::runtime_error(std::string("shader compilation failed: ") + log);
  }
  return shader;
}

GLuint link(std::vector<const char*> vertex, std::vector<const char*> fragment) {
  const GLuint program = glCreateProgram();
  const GLuint v = compile(GL_VERTEX_SHADER, vertex), f = compile(GL_FRAGMENT_SHADER, fragment);
  glAttachShader(program, v);
  glAttachShader(program, f);
  glLinkProgram(program);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) throw std::runtime_error("shader linking failed");
  return program;
}

}  // namespace

struct Renderer::Gl {
  OffscreenContext context;
  GLuint msaa_fbo = 0, msaa_color = 0, msaa_depth = 0;
  GLuint resolve_fbo = 0, resolve_color = 0, resolve_depth = 0;  // also the single-sample target
  GLuint sphere_program = 0, point_program = 0, line_program = 0;
  GLuint sphere_vao = 0, corner_vbo = 0, instance_vbo = 0, line_vao = 0, line_vbo = 0;
  std::vector<float> instances, lines, cells;  // per frame, reused
};

Renderer::Renderer(const RenderSettings& settings)
    : settings_(settings), gl_(std::make_unique<Gl>()) {
  validate(settings_);
  Gl& g = *gl_;
  const int w = settings_.width, h = settings_.height;
  glGenRenderbuffers(1, &g.msaa_color);
  glBindRenderbuffer(GL_RENDERBUFFER, g.msaa_color);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, 4, GL_RGBA8, w, h);
  glGenRenderbuffers(1, &g.msaa_depth);
  glBindRenderbuffer(GL_RENDERBUFFER, g.msaa_depth);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, 4, GL_DEPTH_COMPONENT24, w, h);
  glGenFramebuffers(1, &g.msaa_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, g.msaa_fbo);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g.msaa_color);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, g.msaa_depth);
  glGenRenderbuffers(1, &g.resolve_color);
  glBindRenderbuffer(GL_RENDERBUFFER, g.resolve_color);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
  glGenRenderbuffers(1, &g.resolve_depth);
  glBindRenderbuffer(GL_RENDERBUFFER, g.resolve_depth);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
  glGenFramebuffers(1, &g.resolve_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, g.resolve_fbo);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g.resolve_color);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, g.resolve_depth);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw std::runtime_error("the off-screen framebuffer is incomplete");

  g.sphere_program = link({shaders::sphere_vert}, {shaders::lighting_glsl, shaders::sphere_frag});
  g.point_program = link({shaders::points_vert}, {shaders::lighting_glsl, shaders::points_frag});
  g.line_program = link({shaders::lines_vert}, {shaders::lines_frag});

  // Spheres: a shared quad (4 corners) and one instance per particle (centre, colour).
  const float corners[] = {-1, -1, 1, -1, -1, 1, 1, 1};
  glGenVertexArrays(1, &g.sphere_vao);
  glBindVertexArray(g.sphere_vao);
  glGenBuffers(1, &g.corner_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, g.corner_vbo);
  glBufferData(GL_ARRAY_BUFFER, sizeof corners, corners, GL_STATIC_DRAW);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(0);
  glGenBuffers(1, &g.instance_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, g.instance_vbo);
  for (int a = 1; a <= 2; ++a) {
    glVertexAttribPointer(a, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                          reinterpret_cast<void*>((a - 1) * 3 * sizeof(float)));
    glEnableVertexAttribArray(a);
    glVertexAttribDivisor(a, 1);
  }

  glGenVertexArrays(1, &g.line_vao);
  glBindVertexArray(g.line_vao);
  glGenBuffers(1, &g.line_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, g.line_vbo);
  for (int a = 0; a <= 1; ++a) {
    glVertexAttribPointer(a, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                          reinterpret_cast<void*>(a * 3 * sizeof(float)));
    glEnableVertexAttribArray(a);
  }
}

Renderer::~Renderer() = default;

namespace {

void setCamera(GLuint program, const View& v) {
  glUseProgram(program);
  glUniformMatrix4fv(glGetUniformLocation(program, "view"), 1, GL_FALSE, glm::value_ptr(v.view));
  glUniformMatrix4fv(glGetUniformLocation(program, "projection"), 1, GL_FALSE,
                     glm::value_ptr(v.projection));
}

}  // namespace

Image Renderer::render(const Snapshot& s) {
  Gl& g = *gl_;
  g.context.makeCurrent();
  const int w = settings_.width, h = settings_.height;
  const float cell = static_cast<float>(s.grid.cell_size);
  const glm::vec3 extent(s.grid.cells[0] * cell, s.grid.cells[1] * cell,
                         s.grid.dimension == 3 ? s.grid.cells[2] * cell : 0.f);
  const View camera = cameraFor(s, settings_, extent);

  // Level of detail, for the whole frame from the projected radius at the domain's centre: small
  // spheres become point sprites, and such a frame is drawn single-sampled (llvmpipe's 4x MSAA
  // doubles its cost; docs/rendering.md).
  const double spacing =
      s.grid.particle_spacing > 0 ? s.grid.particle_spacing : s.grid.cell_size / 3;
  const float radius =
      static_cast<float>(settings_.sphere_radius > 0 ? settings_.sphere_radius : 0.5 * spacing);
  const glm::vec4 centre_clip = camera.projection * camera.view * glm::vec4(0.5f * extent, 1.f);
  const float radius_pixels = radius * camera.projection[1][1] * 0.5f * h / centre_clip.w;
  const bool sprites = s.size() > 0 && radius_pixels < settings_.lod_pixels;

  glBindFramebuffer(GL_FRAMEBUFFER, sprites ? g.resolve_fbo : g.msaa_fbo);
  glViewport(0, 0, w, h);
  glClearColor(0.2f, 0.22f, 0.27f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);

  g.cells.clear();
  if (settings_.density_cells) densityCells(s, extent, g.cells);
  g.lines.clear();
  if (settings_.show_grid) gridLines(s, extent, camera, w, h, g.lines);
  if (!g.cells.empty() || !g.lines.empty()) {
    setCamera(g.line_program, camera);
    glBindVertexArray(g.line_vao);
    glBindBuffer(GL_ARRAY_BUFFER, g.line_vbo);
    for (const auto& [vertices, mode] : {std::pair(&g.cells, GL_TRIANGLES), {&g.lines, GL_LINES}}) {
      if (vertices->empty()) continue;
      glBufferData(GL_ARRAY_BUFFER, vertices->size() * sizeof(float), vertices->data(),
                   GL_STREAM_DRAW);
      glDrawArrays(mode, 0, static_cast<GLsizei>(vertices->size() / 6));
    }
  }

  if (s.size() > 0) {
    if (settings_.color_by == ColorBy::Plastic && static_cast<int>(s.plastic_j.size()) != s.size())
      throw InputError("--color-by plastic: frame " + std::to_string(s.frame) +
                       " has no plastic compression (J_P); only MPM runs carry it");
    const ColourRange range = colourRange(settings_, s);
    const ColorBy by = settings_.color_by == ColorBy::Density && s.density.empty()
                           ? ColorBy::White
                           : settings_.color_by;
    g.instances.resize(6 * static_cast<size_t>(s.size()));
    for (int i = 0; i < s.size(); ++i) {
      const glm::vec3 colour = particleColour(s, i, by, range);
      std::copy_n(s.position[i].data(), 3, &g.instances[6 * static_cast<size_t>(i)]);
      std::copy_n(&colour.r, 3, &g.instances[6 * static_cast<size_t>(i) + 3]);
    }
    const GLuint program = sprites ? g.point_program : g.sphere_program;
    setCamera(program, camera);
    glUniform1f(glGetUniformLocation(program, "radius"), radius);
    glUniform1f(glGetUniformLocation(program, "viewport_height"), float(h));
    glUniform3f(glGetUniformLocation(program, "light_direction"), -0.4f, 0.7f, 0.6f);
    glBindVertexArray(g.sphere_vao);
    glBindBuffer(GL_ARRAY_BUFFER, g.instance_vbo);
    glBufferData(GL_ARRAY_BUFFER, g.instances.size() * sizeof(float), g.instances.data(),
                 GL_STREAM_DRAW);
    if (sprites) {
      // One vertex per particle: the per-instance attributes read as per-vertex ones.
      glEnable(GL_PROGRAM_POINT_SIZE);
      for (int a = 1; a <= 2; ++a) glVertexAttribDivisor(a, 0);
      glDrawArrays(GL_POINTS, 0, s.size());
      for (int a = 1; a <= 2; ++a) glVertexAttribDivisor(a, 1);
    } else {
      glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, s.size());
    }
  }

  // Resolve the samples (if any) and read back, flipping OpenGL's bottom-up rows.
  if (!sprites) {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, g.msaa_fbo);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, g.resolve_fbo);
    glBlitFramebuffer(0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  }
  glBindFramebuffer(GL_READ_FRAMEBUFFER, g.resolve_fbo);
  Image image{w, h, std::vector<std::uint8_t>(static_cast<size_t>(w) * h * 4)};
  std::vector<std::uint8_t> rows(image.rgba.size());
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rows.data());
  for (int y = 0; y < h; ++y)
    std::copy_n(&rows[static_cast<size_t>(h - 1 - y) * w * 4], w * 4,
                &image.rgba[static_cast<size_t>(y) * w * 4]);
  return image;
}

}  // namespace snowsim
