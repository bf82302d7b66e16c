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

// Blue (low) through white to red (high), t in [0, 1].
glm::vec3 colormap(float t) {
  t = std::clamp(t, 0.f, 1.f);
  const glm::vec3 low(0.15f, 0.35f, 0.85f), mid(0.95f, 0.95f, 0.95f), high(0.85f, 0.15f, 0.1f);
  return t < 0.5f ? glm::mix(low, mid, 2 * t) : glm::mix(mid, high, 2 * t - 1);
}

const glm::vec3 snow_white(0.93f, 0.95f, 1.0f);

// The colour of particle i under the chosen attribute; scale normalises density and speed.
glm::vec3 particleColour(const Snapshot& s, int i, ColorBy by, float scale) {
  auto speed = [&] { return std::hypot(s.velocity[i][0], s.velocity[i][1], s.velocity[i][2]); };
  switch (by) {
    case ColorBy::Density:
      return scale > 0 ? colormap(s.density[i] / scale) : snow_white;
    case ColorBy::Speed:
      return scale > 0 ? colormap(speed() / scale) : snow_white;
    case ColorBy::Plastic:
      // J_P = 1 white; 0.8 (compressed by a fifth) full red; 1.2 full blue.
      return colormap(0.5f + 2.5f * (1.f - s.plastic_j[i]));
    case ColorBy::White:
      break;
  }
  return snow_white;
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

struct View {
  glm::mat4 view, projection;
};

// 2D: the whole domain, orthographic, with a margin. 3D: the scene's camera, or by default a
// perspective view of the whole domain from the front, above and to the right.
View cameraFor(const Snapshot& s, const RenderSettings& settings, glm::vec3 extent) {
  const glm::vec3 centre = 0.5f * extent;
  const float aspect = float(settings.width) / float(settings.height);
  if (s.grid.dimension == 2) {
    const float half_height = 0.55f * std::max(extent.y, extent.x / aspect);
    return {glm::translate(glm::mat4(1), -glm::vec3(centre.x, centre.y, 1.f)),
            glm::ortho(-half_height * aspect, half_height * aspect, -half_height, half_height,
                       0.01f, 10.f)};
  }
  const float size = std::max({extent.x, extent.y, extent.z});
  const Camera& c = settings.camera;
  auto vec = [](const std::array<double, 3>& a) { return glm::vec3(a[0], a[1], a[2]); };
  const glm::vec3 eye =
      c.custom ? vec(c.eye) : centre + glm::vec3(0.6f * size, 0.5f * size, 2.2f * size);
  const glm::vec3 target = c.custom ? vec(c.target) : centre;
  const float distance = glm::length(eye - target) + size;
  return {
      glm::lookAt(eye, target, c.custom ? vec(c.up) : glm::vec3(0, 1, 0)),
      glm::perspective(glm::radians(float(c.fov_degrees)), aspect, 0.01f * size, 4.f * distance)};
}

// Appends one line segment (two vertices of position and colour).
void addLine(std::vector<float>& out, glm::vec3 a, glm::vec3 b, glm::vec3 colour) {
  for (const glm::vec3& p : {a, b})
    out.insert(out.end(), {p.x, p.y, p.z, colour.r, colour.g, colour.b});
}

// The grid: thin cell lines on the back plane, the walls and the ground drawn brighter.
void gridLines(const Snapshot& s, glm::vec3 extent, std::vector<float>& out) {
  const float cell = static_cast<float>(s.grid.cell_size);
  const glm::vec3 thin(0.36f, 0.39f, 0.45f), wall(0.75f, 0.78f, 0.85f), ground(0.55f, 0.42f, 0.3f);
  for (int i = 0; i <= s.grid.cells[0]; ++i) {
    const bool edge = i == 0 || i == s.grid.cells[0];
    addLine(out, {i * cell, 0, 0}, {i * cell, extent.y, 0}, edge ? wall : thin);
  }
  for (int j = 0; j <= s.grid.cells[1]; ++j) {
    const bool edge = j == s.grid.cells[1];
    addLine(out, {0, j * cell, 0}, {extent.x, j * cell, 0}, j == 0 ? ground : edge ? wall : thin);
  }
  if (s.grid.dimension == 3)
    for (int k = 0; k <= s.grid.cells[2]; ++k)
      addLine(out, {0, 0, k * cell}, {extent.x, 0, k * cell}, ground);
}

// 2D: each node's cell (side h, centred on the node, clipped to the domain) shaded by its density
// against the critical density: the background turning blue below it, amber at or above it.
void densityCells(const Snapshot& s, glm::vec3 extent, std::vector<float>& out) {
  const auto& d = s.grid.node_density;
  const int nx = s.grid.cells[0] + 1, ny = s.grid.cells[1] + 1;
  if (s.grid.dimension != 2 || static_cast<int>(d.size()) != nx * ny) return;
  float reference = static_cast<float>(s.grid.critical_density);
  if (!(reference > 0)) reference = *std::max_element(d.begin(), d.end());
  if (!(reference > 0)) return;
  const float h = static_cast<float>(s.grid.cell_size), z = -0.002f;  // just behind the lines
  const glm::vec3 background(0.2f, 0.22f, 0.27f), loose(0.25f, 0.45f, 0.75f),
      critical(0.95f, 0.62f, 0.15f);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const float ratio = d[static_cast<size_t>(j) * nx + i] / reference;
      if (ratio <= 0) continue;
      const glm::vec3 colour =
          ratio >= 1 ? critical : glm::mix(background, loose, std::min(ratio, 1.f));
      const float x0 = std::max(0.f, (i - 0.5f) * h), x1 = std::min(extent.x, (i + 0.5f) * h);
      const float y0 = std::max(0.f, (j - 0.5f) * h), y1 = std::min(extent.y, (j + 0.5f) * h);
      for (const glm::vec2& p : {glm::vec2(x0, y0), glm::vec2(x1, y0), glm::vec2(x1, y1),
                                 glm::vec2(x0, y0), glm::vec2(x1, y1), glm::vec2(x0, y1)})
        out.insert(out.end(), {p.x, p.y, z, colour.r, colour.g, colour.b});
    }
}

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
  if (settings_.show_grid) gridLines(s, extent, g.lines);
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
    // Colour scale: density against twice the critical density (or the frame's largest), speed
    // against the frame's largest speed.
    float scale = 0;
    for (int i = 0; i < s.size(); ++i) {
      if (settings_.color_by == ColorBy::Density && !s.density.empty())
        scale = std::max(scale, s.density[i]);
      if (settings_.color_by == ColorBy::Speed)
        scale = std::max(scale, std::hypot(s.velocity[i][0], s.velocity[i][1], s.velocity[i][2]));
    }
    if (settings_.color_by == ColorBy::Density && s.grid.critical_density > 0)
      scale = static_cast<float>(2 * s.grid.critical_density);
    const ColorBy by = settings_.color_by == ColorBy::Density && s.density.empty()
                           ? ColorBy::White
                           : settings_.color_by;
    g.instances.resize(6 * static_cast<size_t>(s.size()));
    for (int i = 0; i < s.size(); ++i) {
      const glm::vec3 colour = particleColour(s, i, by, scale);
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
