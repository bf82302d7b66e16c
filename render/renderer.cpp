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
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "render/gl_context.h"
#include "render/shaders.h"
#include "sim/errors.h"

namespace snowsim {

ColorBy parseColorBy(const std::string& name) {
  if (name == "white") return ColorBy::White;
  if (name == "density") return ColorBy::Density;
  if (name == "speed") return ColorBy::Speed;
  throw InputError("--color-by: \"" + name + "\" is not allowed; allowed: white, density, speed");
}

void validate(const RenderSettings& s) {
  if (s.width < 16 || s.width > 8192 || s.height < 16 || s.height > 8192)
    throw InputError("image size " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                     " is out of range; allowed: 16 to 8192 pixels each way");
  if (s.sphere_radius < 0) throw InputError("sphere radius must not be negative");
}

namespace {

GLuint compile(GLenum type, const char* source) {
  const GLuint shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, nullptr);
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

GLuint link(const char* vertex, const char* fragment) {
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

// Blue (low) through white to red (high), t in [0, 1].
glm::vec3 colormap(float t) {
  t = std::clamp(t, 0.f, 1.f);
  const glm::vec3 low(0.15f, 0.35f, 0.85f), mid(0.95f, 0.95f, 0.95f), high(0.85f, 0.15f, 0.1f);
  return t < 0.5f ? glm::mix(low, mid, 2 * t) : glm::mix(mid, high, 2 * t - 1);
}

}  // namespace

struct Renderer::Gl {
  OffscreenContext context;
  GLuint msaa_fbo = 0, msaa_color = 0, msaa_depth = 0, resolve_fbo = 0, resolve_color = 0;
  GLuint sphere_program = 0, line_program = 0;
  GLuint sphere_vao = 0, corner_vbo = 0, instance_vbo = 0, line_vao = 0, line_vbo = 0;
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
  glGenFramebuffers(1, &g.resolve_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, g.resolve_fbo);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, g.resolve_color);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw std::runtime_error("the off-screen framebuffer is incomplete");

  g.sphere_program = link(shaders::sphere_vert, shaders::sphere_frag);
  g.line_program = link(shaders::lines_vert, shaders::lines_frag);

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

Image Renderer::render(const Snapshot& s) {
  Gl& g = *gl_;
  const int w = settings_.width, h = settings_.height;
  const float cell = static_cast<float>(s.grid.cell_size);
  const glm::vec3 extent(s.grid.cells[0] * cell, s.grid.cells[1] * cell,
                         s.grid.dimension == 3 ? s.grid.cells[2] * cell : 0.f);
  const glm::vec3 centre = 0.5f * extent;
  const float aspect = float(w) / float(h);

  // Camera: the whole domain in view with a margin.
  glm::mat4 view, projection;
  if (s.grid.dimension == 2) {
    const float half_height = 0.55f * std::max(extent.y, extent.x / aspect);
    view = glm::translate(glm::mat4(1), -glm::vec3(centre.x, centre.y, 1.f));
    projection = glm::ortho(-half_height * aspect, half_height * aspect, -half_height, half_height,
                            0.01f, 10.f);
  } else {
    const float size = std::max({extent.x, extent.y, extent.z});
    const glm::vec3 eye = centre + glm::vec3(0.6f * size, 0.5f * size, 2.2f * size);
    view = glm::lookAt(eye, centre, glm::vec3(0, 1, 0));
    projection = glm::perspective(glm::radians(35.f), aspect, 0.01f * size, 10.f * size);
  }

  glBindFramebuffer(GL_FRAMEBUFFER, g.msaa_fbo);
  glViewport(0, 0, w, h);
  glClearColor(0.2f, 0.22f, 0.27f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);

  // The grid: thin cell lines on the back plane, the walls and the ground drawn brighter.
  if (settings_.show_grid) {
    std::vector<float> lines;
    auto line = [&](glm::vec3 a, glm::vec3 b, glm::vec3 colour) {
      for (const glm::vec3& p : {a, b})
        lines.insert(lines.end(), {p.x, p.y, p.z, colour.r, colour.g, colour.b});
    };
    const glm::vec3 thin(0.36f, 0.39f, 0.45f), wall(0.75f, 0.78f, 0.85f),
        ground(0.55f, 0.42f, 0.3f);
    for (int i = 0; i <= s.grid.cells[0]; ++i) {
      const bool edge = i == 0 || i == s.grid.cells[0];
      line({i * cell, 0, 0}, {i * cell, extent.y, 0}, edge ? wall : thin);
    }
    for (int j = 0; j <= s.grid.cells[1]; ++j) {
      const bool edge = j == s.grid.cells[1];
      line({0, j * cell, 0}, {extent.x, j * cell, 0}, j == 0 ? ground : edge ? wall : thin);
    }
    if (s.grid.dimension == 3)
      for (int k = 0; k <= s.grid.cells[2]; ++k)
        line({0, 0, k * cell}, {extent.x, 0, k * cell}, ground);
    glUseProgram(g.line_program);
    glUniformMatrix4fv(glGetUniformLocation(g.line_program, "view"), 1, GL_FALSE,
                       glm::value_ptr(view));
    glUniformMatrix4fv(glGetUniformLocation(g.line_program, "projection"), 1, GL_FALSE,
                       glm::value_ptr(projection));
    glBindVertexArray(g.line_vao);
    glBindBuffer(GL_ARRAY_BUFFER, g.line_vbo);
    glBufferData(GL_ARRAY_BUFFER, lines.size() * sizeof(float), lines.data(), GL_STREAM_DRAW);
    glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(lines.size() / 6));
  }

  if (s.size() > 0) {
    // Colour scale: density against the critical density (or the frame's largest), speed against
    // the frame's largest speed.
    float scale = 0;
    for (int i = 0; i < s.size(); ++i) {
      if (settings_.color_by == ColorBy::Density && !s.density.empty())
        scale = std::max(scale, s.density[i]);
      if (settings_.color_by == ColorBy::Speed)
        scale = std::max(scale, std::hypot(s.velocity[i][0], s.velocity[i][1], s.velocity[i][2]));
    }
    if (settings_.color_by == ColorBy::Density && s.grid.critical_density > 0)
      scale = static_cast<float>(2 * s.grid.critical_density);
    std::vector<float> instances;
    instances.reserve(6 * s.size());
    for (int i = 0; i < s.size(); ++i) {
      glm::vec3 colour(0.93f, 0.95f, 1.0f);
      if (settings_.color_by == ColorBy::Density && scale > 0 && !s.density.empty())
        colour = colormap(s.density[i] / scale);
      if (settings_.color_by == ColorBy::Speed && scale > 0)
        colour = colormap(std::hypot(s.velocity[i][0], s.velocity[i][1], s.velocity[i][2]) / scale);
      instances.insert(instances.end(), {s.position[i][0], s.position[i][1], s.position[i][2],
                                         colour.r, colour.g, colour.b});
    }
    const double spacing =
        s.grid.particle_spacing > 0 ? s.grid.particle_spacing : s.grid.cell_size / 3;
    const float radius =
        static_cast<float>(settings_.sphere_radius > 0 ? settings_.sphere_radius : 0.5 * spacing);
    glUseProgram(g.sphere_program);
    glUniformMatrix4fv(glGetUniformLocation(g.sphere_program, "view"), 1, GL_FALSE,
                       glm::value_ptr(view));
    glUniformMatrix4fv(glGetUniformLocation(g.sphere_program, "projection"), 1, GL_FALSE,
                       glm::value_ptr(projection));
    glUniform1f(glGetUniformLocation(g.sphere_program, "radius"), radius);
    glUniform3f(glGetUniformLocation(g.sphere_program, "light_direction"), -0.4f, 0.7f, 0.6f);
    glBindVertexArray(g.sphere_vao);
    glBindBuffer(GL_ARRAY_BUFFER, g.instance_vbo);
    glBufferData(GL_ARRAY_BUFFER, instances.size() * sizeof(float), instances.data(),
                 GL_STREAM_DRAW);
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, s.size());
  }

  // Resolve the samples and read back, flipping OpenGL's bottom-up rows.
  glBindFramebuffer(GL_READ_FRAMEBUFFER, g.msaa_fbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, g.resolve_fbo);
  glBlitFramebuffer(0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
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
