#include "render/renderer.h"

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "render/buried_particles.h"
#include "render/camera.h"
#include "render/colour.h"
#include "render/gl_context.h"
#include "render/grid_lines.h"
#include "render/meshes.h"
#include "render/shaders.h"
#include "render/snow_volume.h"
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

Look parseLook(const std::string& name, const std::string& where) {
  if (name == "studio") return Look::Studio;
  if (name == "figure") return Look::Figure;
  if (name == "surface") return Look::Surface;
  if (name == "volume") return Look::Volume;
  throw InputError(where + ": \"" + name +
                   "\" is not allowed; allowed: studio, figure, surface, volume");
}

std::string lookName(Look look) {
  switch (look) {
    case Look::Studio:
      return "studio";
    case Look::Figure:
      return "figure";
    case Look::Surface:
      return "surface";
    case Look::Volume:
      return "volume";
  }
  return "";
}

void validate(const RenderSettings& s) {
  if (s.width < 16 || s.width > 8192 || s.height < 16 || s.height > 8192)
    throw InputError("image size (--width, --height; render.width, render.height) " +
                     std::to_string(s.width) + "x" + std::to_string(s.height) +
                     " is out of range; allowed: 16 to 8192 pixels each way");
  if (!(s.sphere_radius >= 0 && s.sphere_radius <= 10))
    throw InputError("sphere radius (--sphere-radius, render.sphere_radius) " +
                     numberText(s.sphere_radius) +
                     " is out of range; allowed: 0 to 10 m (0: half the particle spacing)");
  if (!(s.camera.fov_degrees > 0 && s.camera.fov_degrees < 180))
    throw InputError("camera field of view (--fov, render.camera.fov) " +
                     numberText(s.camera.fov_degrees) +
                     " is out of range; allowed: (0, 180) degrees");
  if (s.camera.custom && s.camera.eye == s.camera.target)
    throw InputError(
        "camera eye and target (--camera-eye, --camera-target; render.camera) must differ");
  if (const auto& b = s.background)
    for (double c : *b)
      if (!(c >= 0 && c <= 1))
        throw InputError("background colour (--background, render.background): " + numberText(c) +
                         " is out of range; allowed: 0 to 1 (red, green, blue)");
  if (s.color_range && !(s.color_range->high > s.color_range->low))
    throw InputError("colour range (--color-range, render.color_range) [" +
                     numberText(s.color_range->low) + ", " + numberText(s.color_range->high) +
                     "] is empty; allowed: low < high");
  if (s.color_range && s.color_by == ColorBy::Plastic &&
      !(s.color_range->low > 0 && s.color_range->low < 1 && s.color_range->high > 1))
    throw InputError("colour range (--color-range, render.color_range) [" +
                     numberText(s.color_range->low) + ", " + numberText(s.color_range->high) +
                     "] for --color-by plastic must hold J_P = 1 (no plastic change, the map's "
                     "neutral middle); allowed: 0 < low < 1 < high");
  validate(s.surface, "--surface-");
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

namespace {

void setCamera(GLuint program, const View& v) {
  glUseProgram(program);
  glUniformMatrix4fv(glGetUniformLocation(program, "view"), 1, GL_FALSE, glm::value_ptr(v.view));
  glUniformMatrix4fv(glGetUniformLocation(program, "projection"), 1, GL_FALSE,
                     glm::value_ptr(v.projection));
}

// The colours and light of a look (RenderSettings::look).
struct Palette {
  glm::vec3 background, ground, collider, key, sky, bounce;
};

Palette paletteFor(const RenderSettings& settings) {
  Palette p = settings.look == Look::Figure
                  ? Palette{{1, 1, 1},
                            {0.94f, 0.94f, 0.95f},
                            {0.62f, 0.66f, 0.74f},
                            {0.62f, 0.6f, 0.57f},
                            {0.5f, 0.52f, 0.56f},
                            {0.3f, 0.3f, 0.31f}}
                  : Palette{{0.2f, 0.22f, 0.27f}, {0.46f, 0.47f, 0.5f},  {0.58f, 0.62f, 0.7f},
                            {0.66f, 0.64f, 0.6f}, {0.42f, 0.45f, 0.52f}, {0.18f, 0.18f, 0.2f}};
  if (const auto& b = settings.background) p.background = glm::vec3((*b)[0], (*b)[1], (*b)[2]);
  return p;
}

// Towards the key light, in world space: from above, the left and the front, so the default
// camera sees lit faces and the shadows fall to the right, behind the snow.
const glm::vec3 key_light = glm::normalize(glm::vec3(-0.6f, 1.0f, 0.8f));

// Where the key light's shadow map looks from: an orthographic view along the light fitted to
// the domain box, at about one texel per sphere radius (a shadow of the snow's mass, not of each
// sphere's outline), 512 to 2048 texels square.
struct KeyLight {
  View camera;
  int size = 512;
  float texel = 0;        // world metres
  float depth_range = 1;  // world metres from near to far
};

KeyLight keyLightFor(glm::vec3 extent, float radius) {
  const glm::vec3 centre = 0.5f * extent;
  const float reach = glm::length(extent) + 1e-6f;
  KeyLight light;
  light.camera.view = glm::lookAt(centre + reach * key_light, centre, glm::vec3(0, 1, 0));
  glm::vec3 low(1e30f), high(-1e30f);
  for (int corner = 0; corner < 8; ++corner) {
    const glm::vec3 p(corner & 1 ? extent.x : 0, corner & 2 ? extent.y : 0,
                      corner & 4 ? extent.z : 0);
    const glm::vec3 q = glm::vec3(light.camera.view * glm::vec4(p, 1));
    low = glm::min(low, q), high = glm::max(high, q);
  }
  const float width = std::max(high.x - low.x, high.y - low.y) + 4 * radius;
  const float wanted = std::exp2(std::ceil(std::log2(width / std::max(radius, 1e-9f))));
  light.size = static_cast<int>(std::clamp(wanted, 512.f, 2048.f));
  light.texel = width / light.size;
  const glm::vec2 middle = 0.5f * (glm::vec2(low) + glm::vec2(high));
  const float near = -high.z - 2 * radius, far = -low.z + 2 * radius;
  light.depth_range = far - near;
  light.camera.projection = glm::ortho(middle.x - 0.5f * width, middle.x + 0.5f * width,
                                       middle.y - 0.5f * width, middle.y + 0.5f * width, near, far);
  return light;
}

GLuint makeTexture(GLenum internal_format, int width, int height, GLenum format, GLenum type,
                   GLenum filter) {
  GLuint texture = 0;
  glGenTextures(1, &texture);
  glBindTexture(GL_TEXTURE_2D, texture);
  glTexImage2D(GL_TEXTURE_2D, 0, internal_format, width, height, 0, format, type, nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, filter);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, filter);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
}

// A framebuffer of the given colour textures (drawn to in order) and depth texture (0: none).
GLuint makeFramebuffer(std::vector<GLuint> colours, GLuint depth) {
  GLuint fbo = 0;
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  std::vector<GLenum> buffers;
  for (size_t i = 0; i < colours.size(); ++i) {
    buffers.push_back(GL_COLOR_ATTACHMENT0 + static_cast<GLenum>(i));
    glFramebufferTexture2D(GL_FRAMEBUFFER, buffers.back(), GL_TEXTURE_2D, colours[i], 0);
  }
  if (depth) glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
  if (buffers.empty())
    glDrawBuffer(GL_NONE);
  else
    glDrawBuffers(static_cast<GLsizei>(buffers.size()), buffers.data());
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw std::runtime_error("an off-screen framebuffer is incomplete");
  return fbo;
}

// A vertex array of one buffer (made into `vbo`) holding `attributes` vec3 attributes a vertex.
GLuint makeVertexArray(GLuint& vbo, int attributes) {
  GLuint vao = 0;
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glGenBuffers(1, &vbo);
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  for (int a = 0; a < attributes; ++a) {
    glVertexAttribPointer(a, 3, GL_FLOAT, GL_FALSE, 3 * attributes * sizeof(float),
                          reinterpret_cast<void*>(a * 3 * sizeof(float)));
    glEnableVertexAttribArray(a);
  }
  return vao;
}

void setUniform(GLuint program, const char* name, float value) {
  glUniform1f(glGetUniformLocation(program, name), value);
}
void setUniform(GLuint program, const char* name, glm::vec3 value) {
  glUniform3fv(glGetUniformLocation(program, name), 1, glm::value_ptr(value));
}
void setUniform(GLuint program, const char* name, const glm::mat4& value) {
  glUniformMatrix4fv(glGetUniformLocation(program, name), 1, GL_FALSE, glm::value_ptr(value));
}
void setTexture(GLuint program, const char* name, int unit, GLuint texture) {
  glActiveTexture(GL_TEXTURE0 + unit);
  glBindTexture(GL_TEXTURE_2D, texture);
  glUniform1i(glGetUniformLocation(program, name), unit);
}

// Whether a 3D frame is drawn at 2x2 its size and filtered down, its anti-aliasing: the surface
// look's (the grain of its mesh and its small loose grains need it; its cost is in building the
// surface) and, with --supersample, impostor frames'. Other impostor frames are anti-aliased by
// FXAA at their size, at a third of the cost; sprite frames not at all (a sprite frame's cost is
// in its many particles, and FXAA would blur them; docs/rendering.md).
bool supersampled(const RenderSettings& settings, bool sprites) {
  return settings.look == Look::Surface || (settings.supersample && !sprites);
}

// The programs for each pass: forward (2D), G-buffer and shadow map (3D), and the screen passes.
struct Programs {
  GLuint sphere_forward, point_forward, mesh_forward, line;
  GLuint sphere_gbuffer, point_gbuffer, mesh_gbuffer, snow_gbuffer;
  GLuint point_depth, mesh_depth;  // the key light's shadow map
  GLuint occlusion, compose;
  GLuint fxaa;    // anti-aliasing of 3D impostor frames drawn at the image's size
  GLuint volume;  // --look volume's ray march

  Programs() {
    using namespace shaders;
    sphere_forward = link({sphere_vert}, {lighting_glsl, forward_glsl, sphere_frag});
    point_forward = link({points_vert}, {lighting_glsl, forward_glsl, points_frag});
    mesh_forward = link({mesh_vert}, {lighting_glsl, forward_glsl, mesh_frag});
    line = link({lines_vert}, {lines_frag});
    sphere_gbuffer = link({sphere_vert}, {gbuffer_glsl, sphere_frag});
    point_gbuffer = link({points_vert}, {gbuffer_glsl, points_frag});
    mesh_gbuffer = link({mesh_vert}, {gbuffer_glsl, mesh_frag});
    snow_gbuffer = link({mesh_vert}, {gbuffer_glsl, snow_frag});
    point_depth = link({points_vert}, {point_depth_frag});
    mesh_depth = link({mesh_vert}, {depth_only_frag});
    occlusion = link({fullscreen_vert}, {surface_glsl, occlusion_frag});
    compose = link({fullscreen_vert}, {surface_glsl, compose_frag});
    fxaa = link({fullscreen_vert}, {fxaa_frag});
    volume = link({fullscreen_vert}, {volume_frag});
  }
};

// The 3D deferred targets, sized to the G-buffer (the image, or twice it each way when the frame
// is supersampled): albedo, normal, depth; the lit image (linearly filtered for the FXAA pass);
// the occlusion at half resolution.
struct DeferredTargets {
  int width = 0, height = 0;
  GLuint albedo = 0, normal = 0, depth = 0, gbuffer_fbo = 0;
  GLuint lit = 0, lit_fbo = 0;
  GLuint occlusion = 0, occlusion_fbo = 0;

  void resize(int w, int h) {
    if (w == width && h == height) return;
    release();
    width = w, height = h;
    albedo = makeTexture(GL_RGBA8, w, h, GL_RGBA, GL_UNSIGNED_BYTE, GL_NEAREST);
    normal = makeTexture(GL_RGBA8, w, h, GL_RGBA, GL_UNSIGNED_BYTE, GL_NEAREST);
    depth =
        makeTexture(GL_DEPTH_COMPONENT24, w, h, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, GL_NEAREST);
    gbuffer_fbo = makeFramebuffer({albedo, normal}, depth);
    lit = makeTexture(GL_RGBA8, w, h, GL_RGBA, GL_UNSIGNED_BYTE, GL_LINEAR);
    lit_fbo = makeFramebuffer({lit}, 0);
    occlusion = makeTexture(GL_R8, w / 2, h / 2, GL_RED, GL_UNSIGNED_BYTE, GL_LINEAR);
    occlusion_fbo = makeFramebuffer({occlusion}, 0);
  }
  void release() {
    const GLuint textures[] = {albedo, normal, depth, lit, occlusion};
    const GLuint fbos[] = {gbuffer_fbo, lit_fbo, occlusion_fbo};
    glDeleteTextures(5, textures);
    glDeleteFramebuffers(3, fbos);
  }
};

// The key light's depth map, compared in hardware with linear filtering (PCF).
struct ShadowMap {
  int size = 0;
  GLuint depth = 0, fbo = 0;

  void resize(int s) {
    if (s == size) return;
    glDeleteTextures(1, &depth);
    glDeleteFramebuffers(1, &fbo);
    size = s;
    depth = makeTexture(GL_DEPTH_COMPONENT24, s, s, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    fbo = makeFramebuffer({}, depth);
  }
};

}  // namespace

struct Renderer::Gl {
  OffscreenContext context;
  GLuint msaa_fbo = 0, msaa_color = 0, msaa_depth = 0;
  GLuint resolve_fbo = 0, resolve_color = 0, resolve_depth = 0;  // also the single-sample target
  Programs programs;
  DeferredTargets deferred;
  ShadowMap shadow;
  GLuint sphere_vao = 0, corner_vbo = 0, instance_vbo = 0, line_vao = 0, line_vbo = 0;
  GLuint mesh_vao = 0, mesh_vbo = 0, screen_vao = 0;
  GLuint snow_vao = 0, snow_vbo = 0, snow_ebo = 0;  // the surface look's mesh, indexed
  std::vector<float> instances, lines, floor_lines, cells, meshes;  // per frame, reused
  std::vector<float> snow_vertices, particle_colours;               // the surface look's, reused
  GLsizei snow_indices = 0;
  std::vector<std::uint32_t> seen_by_camera, seen_by_light;  // 3D: particles not buried
  GLsizei ground_vertices = 0;                               // the ground leads `meshes` in 3D
  SnowVolume volume;  // --look volume: the snow as a medium, and its 3D texture
  GLuint volume_texture = 0;

  // A run of particles in the instance buffer.
  struct Particles {
    GLint first = 0;
    GLsizei count = 0;
  };

  // Vertices of position and colour (render/grid_lines.h) as lines or triangles.
  void drawLines(const View& camera, float marker, const std::vector<float>& vertices, GLenum mode);
  void drawMeshes(GLuint program, const View& camera, GLint first, GLsizei count);
  void drawSnow(GLuint program, const View& camera);
  // The surface's vertices (position, normal, the colour of the particles near it) and
  // triangles into the snow buffers.
  void fillSnow(const Snapshot& s, const SnowSurface& surface, const RenderSettings& settings,
                double spacing);
  // Particles of the instance buffer: impostors, or one point sprite each (round_up: sprite
  // sizes round up, shaders/points.vert).
  void drawSpheres(GLuint program, const View& camera, float radius, int viewport_height,
                   bool sprites, Particles particles, bool round_up = false);
  // The particles' centres and colours into the instance buffer: the given ones, in turn.
  void fillInstances(const Snapshot& s, const RenderSettings& settings,
                     const std::vector<const std::vector<std::uint32_t>*>& runs);
  // --look volume: `volume` into its texture, and marched over the lit image (lit_fbo).
  void uploadVolume();
  void drawVolume(const View& camera, const Palette& palette);
  // 3D: shadow map, G-buffer, occlusion and lighting passes (and the volume's march), into
  // resolve_fbo.
  void renderDeferred(const RenderSettings& settings, const View& camera, const Palette& palette,
                      glm::vec3 extent, float radius, bool sprites, GLsizei mesh_vertices,
                      Particles seen_by_camera, Particles seen_by_light);
};

void Renderer::Gl::drawLines(const View& camera, float marker, const std::vector<float>& vertices,
                             GLenum mode) {
  if (vertices.empty()) return;
  setCamera(programs.line, camera);
  setUniform(programs.line, "marker", marker);
  glBindVertexArray(line_vao);
  glBindBuffer(GL_ARRAY_BUFFER, line_vbo);
  glBufferData(GL_ARRAY_BUFFER, vertices.size() * sizeof(float), vertices.data(), GL_STREAM_DRAW);
  glDrawArrays(mode, 0, static_cast<GLsizei>(vertices.size() / 6));
}

void Renderer::Gl::drawMeshes(GLuint program, const View& camera, GLint first, GLsizei count) {
  if (count <= 0) return;
  setCamera(program, camera);
  setUniform(program, "light_direction", glm::vec3(-0.4f, 0.7f, 0.6f));
  glBindVertexArray(mesh_vao);
  glDrawArrays(GL_TRIANGLES, first, count);
}

void Renderer::Gl::drawSnow(GLuint program, const View& camera) {
  if (snow_indices == 0) return;
  setCamera(program, camera);
  glBindVertexArray(snow_vao);
  glDrawElements(GL_TRIANGLES, snow_indices, GL_UNSIGNED_INT, nullptr);
}

void Renderer::Gl::fillSnow(const Snapshot& s, const SnowSurface& surface,
                            const RenderSettings& settings, double spacing) {
  const ColourRange range = colourRange(settings, s);
  const ColorBy by = settings.color_by == ColorBy::Density && s.density.empty() ? ColorBy::White
                                                                                : settings.color_by;
  std::vector<float> at_vertices;
  if (by != ColorBy::White) {
    particle_colours.resize(static_cast<size_t>(s.size()) * 3);
    for (int i = 0; i < s.size(); ++i) {
      const glm::vec3 c = particleColour(s, i, by, range);
      for (int k = 0; k < 3; ++k) particle_colours[3 * i + k] = c[k];
    }
    at_vertices = averageAtVertices(surface, s.position, particle_colours, 3, 2 * spacing);
  }
  const glm::vec3 white = particleColour(s, 0, ColorBy::White, range);
  snow_vertices.resize(surface.vertices.size() * 9);
  for (size_t v = 0; v < surface.vertices.size(); ++v) {
    float* o = &snow_vertices[9 * v];
    for (int k = 0; k < 3; ++k) {
      o[k] = surface.vertices[v][k];
      o[3 + k] = surface.normals[v][k];
      o[6 + k] = at_vertices.empty() ? white[k] : at_vertices[3 * v + k];
    }
  }
  glBindVertexArray(snow_vao);
  glBindBuffer(GL_ARRAY_BUFFER, snow_vbo);
  glBufferData(GL_ARRAY_BUFFER, snow_vertices.size() * sizeof(float), snow_vertices.data(),
               GL_STREAM_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, snow_ebo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, surface.triangles.size() * sizeof(surface.triangles[0]),
               surface.triangles.data(), GL_STREAM_DRAW);
  snow_indices = static_cast<GLsizei>(surface.triangles.size() * 3);
}

void Renderer::Gl::drawSpheres(GLuint program, const View& camera, float radius,
                               int viewport_height, bool sprites, Particles particles,
                               bool round_up) {
  if (particles.count == 0) return;
  setCamera(program, camera);
  setUniform(program, "round_up", round_up ? 1.f : 0.f);
  setUniform(program, "radius", radius);
  setUniform(program, "viewport_height", float(viewport_height));
  setUniform(program, "light_direction", glm::vec3(-0.4f, 0.7f, 0.6f));
  glBindVertexArray(sphere_vao);
  if (sprites) {
    // One vertex per particle: the per-instance attributes read as per-vertex ones.
    glEnable(GL_PROGRAM_POINT_SIZE);
    for (int a = 1; a <= 2; ++a) glVertexAttribDivisor(a, 0);
    glDrawArrays(GL_POINTS, particles.first, particles.count);
    for (int a = 1; a <= 2; ++a) glVertexAttribDivisor(a, 1);
  } else {
    glDrawArraysInstancedBaseInstance(GL_TRIANGLE_STRIP, 0, 4, particles.count,
                                      static_cast<GLuint>(particles.first));
  }
}

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

  g.line_vao = makeVertexArray(g.line_vbo, 2);  // position, colour
  g.mesh_vao = makeVertexArray(g.mesh_vbo, 3);  // position, normal, colour
  g.snow_vao = makeVertexArray(g.snow_vbo, 3);  // the same, and its triangles' indices
  glGenBuffers(1, &g.snow_ebo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.snow_ebo);
  glGenVertexArrays(1, &g.screen_vao);  // the full-screen triangle needs no attributes
}

Renderer::~Renderer() = default;

Image Renderer::render(const Snapshot& s) {
  Gl& g = *gl_;
  g.context.makeCurrent();
  const int w = settings_.width, h = settings_.height;
  const float cell = static_cast<float>(s.grid.cell_size);
  const glm::vec3 extent(s.grid.cells[0] * cell, s.grid.cells[1] * cell,
                         s.grid.dimension == 3 ? s.grid.cells[2] * cell : 0.f);
  const View camera = cameraFor(s, settings_, extent);
  const Palette palette = paletteFor(settings_);

  // Level of detail, for the whole frame from the projected radius at the domain's centre: small
  // spheres become point sprites (docs/rendering.md).
  const double spacing =
      s.grid.particle_spacing > 0 ? s.grid.particle_spacing : s.grid.cell_size / 3;
  const float radius =
      static_cast<float>(settings_.sphere_radius > 0 ? settings_.sphere_radius : 0.5 * spacing);
  const glm::vec4 centre_clip = camera.projection * camera.view * glm::vec4(0.5f * extent, 1.f);
  const float radius_pixels = radius * camera.projection[1][1] * 0.5f * h / centre_clip.w;
  // The volume look draws the spheres only into the shadow map, and is not supersampled.
  const bool volume = settings_.look == Look::Volume && s.grid.dimension == 3;
  const bool sprites = volume || (s.size() > 0 && radius_pixels < settings_.lod_pixels);

  g.cells.clear();
  if (settings_.density_cells) densityCells(s, extent, palette.background, g.cells);
  g.lines.clear();
  g.floor_lines.clear();
  // 3D frames not supersampled (sprites, FXAA): their lines a pixel wide get half the contrast.
  const GridCanvas canvas{palette.background, palette.ground,
                          s.grid.dimension == 3 && !supersampled(settings_, sprites) ? 0.5f : 1.f};
  if (settings_.show_grid)
    gridLines(s, extent, camera, w, h, canvas, g.lines, g.floor_lines);
  else if (s.grid.dimension == 2)
    groundLine(extent, g.lines);  // 3D frames have their ground plane
  g.meshes.clear();
  if (s.grid.dimension == 3)
    appendGround(extent, 0.3f * std::max(extent.x, extent.z), palette.ground, g.meshes);
  g.ground_vertices = static_cast<GLsizei>(g.meshes.size() / 9);
  for (const SnapshotCollider& c : s.colliders)
    appendCollider(c, s.grid.dimension, extent, palette.collider, g.meshes);
  const GLsizei mesh_vertices = static_cast<GLsizei>(g.meshes.size() / 9);
  glBindBuffer(GL_ARRAY_BUFFER, g.mesh_vbo);
  glBufferData(GL_ARRAY_BUFFER, g.meshes.size() * sizeof(float), g.meshes.data(), GL_STREAM_DRAW);

  if (s.grid.dimension == 2) {
    g.fillInstances(s, settings_, {});
    // The report's look: forward shading, 4x MSAA unless the spheres are sprites (llvmpipe's
    // MSAA doubles the cost of a frame of small sprites).
    glBindFramebuffer(GL_FRAMEBUFFER, sprites ? g.resolve_fbo : g.msaa_fbo);
    glViewport(0, 0, w, h);
    glClearColor(palette.background.r, palette.background.g, palette.background.b, 1.f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    g.drawLines(camera, 1.f, g.cells, GL_TRIANGLES);
    g.drawLines(camera, 1.f, g.lines, GL_LINES);
    // Colliders over the grid, under the particles.
    glDisable(GL_DEPTH_TEST);
    g.drawMeshes(g.programs.mesh_forward, camera, 0, mesh_vertices);
    glEnable(GL_DEPTH_TEST);
    g.drawSpheres(sprites ? g.programs.point_forward : g.programs.sphere_forward, camera, radius, h,
                  sprites, {0, s.size()});
    if (!sprites) {
      glBindFramebuffer(GL_READ_FRAMEBUFFER, g.msaa_fbo);
      glBindFramebuffer(GL_DRAW_FRAMEBUFFER, g.resolve_fbo);
      glBlitFramebuffer(0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    }
  } else if (settings_.look == Look::Surface) {
    // The surface in place of the spheres; its loose grains as spheres, seen and casting shadows.
    std::optional<SnowSurface> built;
    if (!s.surface) built = buildSnowSurface(s, settings_.surface);
    const SnowSurface& surface = s.surface ? *s.surface : *built;
    g.fillInstances(s, settings_, {&surface.loose, &surface.loose});  // checks the colouring
    g.fillSnow(s, surface, settings_, spacing);
    glUseProgram(g.programs.snow_gbuffer);  // the grain is the particles', whatever the spheres'
    setUniform(g.programs.snow_gbuffer, "grain", static_cast<float>(spacing));
    const auto loose = static_cast<GLsizei>(surface.loose.size());
    g.renderDeferred(settings_, camera, palette, extent, radius, sprites, mesh_vertices, {0, loose},
                     {loose, settings_.shadows ? loose : 0});
  } else {
    g.snow_indices = 0;
    // Particles buried in the snow are left out of the passes that cannot see them.
    const BuriedParticles buried(s.position, static_cast<float>(spacing), radius);
    g.seen_by_camera.clear();
    if (volume) {
      buildSnowVolume(s, radius, key_light, g.volume);
      g.uploadVolume();
    } else {
      buried.visibleFromPoint(glm::vec3(glm::inverse(camera.view)[3]), g.seen_by_camera);
    }
    g.seen_by_light.clear();
    if (settings_.shadows) buried.visibleFromDirection(key_light, g.seen_by_light);
    g.fillInstances(s, settings_, {&g.seen_by_camera, &g.seen_by_light});
    const auto camera_count = static_cast<GLsizei>(g.seen_by_camera.size());
    g.renderDeferred(settings_, camera, palette, extent, radius, sprites, mesh_vertices,
                     {0, camera_count},
                     {camera_count, static_cast<GLsizei>(g.seen_by_light.size())});
  }

  // Read back, flipping OpenGL's bottom-up rows.
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

void Renderer::Gl::fillInstances(const Snapshot& s, const RenderSettings& settings,
                                 const std::vector<const std::vector<std::uint32_t>*>& runs) {
  Gl& g = *this;
  if (s.size() == 0) return;
  if (settings.color_by == ColorBy::Plastic && static_cast<int>(s.plastic_j.size()) != s.size())
    throw InputError("--color-by plastic: frame " + std::to_string(s.frame) +
                     " has no plastic compression (J_P); only MPM runs carry it");
  const ColourRange range = colourRange(settings, s);
  const ColorBy by = settings.color_by == ColorBy::Density && s.density.empty() ? ColorBy::White
                                                                                : settings.color_by;
  g.instances.clear();
  auto add = [&](int i) {
    const glm::vec3 colour = particleColour(s, i, by, range);
    g.instances.insert(g.instances.end(), s.position[i].begin(), s.position[i].end());
    g.instances.insert(g.instances.end(), {colour.r, colour.g, colour.b});
  };
  if (runs.empty())
    for (int i = 0; i < s.size(); ++i) add(i);
  for (const std::vector<std::uint32_t>* run : runs)
    for (std::uint32_t i : *run) add(static_cast<int>(i));
  glBindBuffer(GL_ARRAY_BUFFER, g.instance_vbo);
  glBufferData(GL_ARRAY_BUFFER, g.instances.size() * sizeof(float), g.instances.data(),
               GL_STREAM_DRAW);
}

void Renderer::Gl::uploadVolume() {
  if (volume.empty()) return;
  if (!volume_texture) {
    glGenTextures(1, &volume_texture);
    glBindTexture(GL_TEXTURE_3D, volume_texture);
    glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_3D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    for (GLenum wrap : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R})
      glTexParameteri(GL_TEXTURE_3D, wrap, GL_CLAMP_TO_EDGE);
  }
  glBindTexture(GL_TEXTURE_3D, volume_texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage3D(GL_TEXTURE_3D, 0, GL_RGB16F, volume.size.x, volume.size.y, volume.size.z, 0, GL_RGB,
               GL_FLOAT, volume.texels.data());
}

void Renderer::Gl::drawVolume(const View& camera, const Palette& palette) {
  const GLuint program = programs.volume;
  glUseProgram(program);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_3D, volume_texture);
  glUniform1i(glGetUniformLocation(program, "volume_texture"), 0);
  setTexture(program, "depth_texture", 1, deferred.depth);
  setUniform(program, "clip_to_world", glm::inverse(camera.projection * camera.view));
  setUniform(program, "eye", glm::vec3(glm::inverse(camera.view)[3]));
  setUniform(program, "volume_origin", volume.origin);
  setUniform(program, "volume_size", glm::vec3(volume.size));
  setUniform(program, "spacing", volume.spacing);
  setUniform(program, "box_low", volume.low);
  setUniform(program, "box_high", volume.high);
  setUniform(program, "snow_albedo", snowWhite());
  // The medium scatters the same in every direction, with no surface's cosine to dim the key
  // light or tilt to choose between sky and bounce: weights that make lit snow about as bright
  // as the studio look's lit spheres.
  setUniform(program, "key_color", 1.1f * palette.key);
  setUniform(program, "sky_color", 0.8f * palette.sky);
  setUniform(program, "bounce_color", 0.5f * palette.bounce);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_SRC_ALPHA);  // the scattered light, over the image behind times T
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glDisable(GL_BLEND);
}

void Renderer::Gl::renderDeferred(const RenderSettings& settings, const View& camera,
                                  const Palette& palette, glm::vec3 extent, float radius,
                                  bool sprites, GLsizei mesh_vertices, Particles seen_by_camera,
                                  Particles seen_by_light) {
  Gl& g = *this;
  const Programs& p = g.programs;
  const bool fxaa = !supersampled(settings, sprites) && !sprites;
  const int scale = supersampled(settings, sprites) ? 2 : 1, gw = scale * settings.width,
            gh = scale * settings.height;
  g.deferred.resize(gw, gh);

  // The key light's shadow map: the particles and the colliders (the ground only receives).
  const KeyLight light = keyLightFor(extent, radius);
  if (settings.shadows) {
    g.shadow.resize(light.size);
    glBindFramebuffer(GL_FRAMEBUFFER, g.shadow.fbo);
    glViewport(0, 0, light.size, light.size);
    glEnable(GL_DEPTH_TEST);
    glClear(GL_DEPTH_BUFFER_BIT);
    g.drawSpheres(p.point_depth, light.camera, radius, light.size, true, seen_by_light, true);
    g.drawMeshes(p.mesh_depth, light.camera, g.ground_vertices, mesh_vertices - g.ground_vertices);
    g.drawSnow(p.mesh_depth, light.camera);
  }

  // The G-buffer: the ground (pushed back, so grid lines and colliders on it win), the
  // colliders, the back wall's lines unlit and the floor's lit as the ground is, the spheres.
  glBindFramebuffer(GL_FRAMEBUFFER, g.deferred.gbuffer_fbo);
  glViewport(0, 0, gw, gh);
  const float no_albedo[] = {0, 0, 0, 0}, facing_normal[] = {0.5f, 0.5f, 1, 1}, far = 1;
  glClearBufferfv(GL_COLOR, 0, no_albedo);
  glClearBufferfv(GL_COLOR, 1, facing_normal);
  glClearBufferfv(GL_DEPTH, 0, &far);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(2, 2);
  g.drawMeshes(p.mesh_gbuffer, camera, 0, g.ground_vertices);
  glPolygonOffset(1, 1);
  g.drawMeshes(p.mesh_gbuffer, camera, g.ground_vertices, mesh_vertices - g.ground_vertices);
  glDisable(GL_POLYGON_OFFSET_FILL);
  // The line shader writes no normal: unmasked, the normal target would get whatever llvmpipe
  // leaves in an unwritten output (it differed between identical runs). Masked, it keeps the
  // normal of the surface the line lies on, which the occlusion pass reads there, and the
  // lighting pass for the floor's lines.
  glColorMaski(1, GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  g.drawLines(camera, 0.5f, g.lines, GL_LINES);
  g.drawLines(camera, 1.f, g.floor_lines, GL_LINES);
  glColorMaski(1, GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  g.drawSnow(p.snow_gbuffer, camera);
  g.drawSpheres(sprites ? p.point_gbuffer : p.sphere_gbuffer, camera, radius, gh, sprites,
                seen_by_camera, true);
  glDisable(GL_DEPTH_TEST);

  // What both screen passes need to see the surface (shaders/surface.glsl).
  const glm::vec4 centre_clip = camera.projection * camera.view * glm::vec4(0.5f * extent, 1.f);
  const float pixel = 2 * centre_clip.w / (camera.projection[1][1] * gh);  // world metres
  auto useSurface = [&](GLuint program) {
    glUseProgram(program);
    setTexture(program, "depth_texture", 0, g.deferred.depth);
    setTexture(program, "normal_texture", 1, g.deferred.normal);
    setUniform(program, "inverse_projection", glm::inverse(camera.projection));
    setUniform(program, "surface_gap", std::max(4 * radius, 4 * pixel));
  };
  glBindVertexArray(g.screen_vao);

  if (settings.occlusion) {
    glBindFramebuffer(GL_FRAMEBUFFER, g.deferred.occlusion_fbo);
    glViewport(0, 0, gw / 2, gh / 2);
    useSurface(p.occlusion);
    setUniform(p.occlusion, "radius", 5 * radius);
    setUniform(p.occlusion, "pixels_per_metre", camera.projection[1][1] * 0.5f * gh);
    setUniform(p.occlusion, "strength", 1.6f);
    setUniform(p.occlusion, "image_step", float(scale));
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }

  glBindFramebuffer(GL_FRAMEBUFFER, g.deferred.lit_fbo);
  glViewport(0, 0, gw, gh);
  useSurface(p.compose);
  setTexture(p.compose, "albedo_texture", 2, g.deferred.albedo);
  setTexture(p.compose, "occlusion_texture", 3, g.deferred.occlusion);
  setTexture(p.compose, "shadow_texture", 4, g.shadow.depth);
  glUniform1i(glGetUniformLocation(p.compose, "use_shadows"), settings.shadows);
  glUniform1i(glGetUniformLocation(p.compose, "use_occlusion"), settings.occlusion);
  const glm::mat4 to_texture =
      glm::translate(glm::mat4(1), glm::vec3(0.5f)) * glm::scale(glm::mat4(1), glm::vec3(0.5f));
  setUniform(p.compose, "view_to_shadow",
             to_texture * light.camera.projection * light.camera.view * glm::inverse(camera.view));
  // Deeper than a sphere's own shadow-map depth (its front, seen from the light) reaches.
  setUniform(p.compose, "shadow_bias", (2.5f * radius + 2 * light.texel) / light.depth_range);
  setUniform(p.compose, "normal_offset", 1.5f * light.texel);
  const glm::mat3 to_view(camera.view);
  setUniform(p.compose, "key_direction", glm::normalize(to_view * key_light));
  setUniform(p.compose, "up_direction", glm::normalize(to_view * glm::vec3(0, 1, 0)));
  setUniform(p.compose, "key_color", palette.key);
  setUniform(p.compose, "sky_color", palette.sky);
  setUniform(p.compose, "bounce_color", palette.bounce);
  setUniform(p.compose, "background", palette.background);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  if (settings.look == Look::Volume && !g.volume.empty()) g.drawVolume(camera, palette);

  // Down to the image: FXAA, or a 2x2 box filter for supersampled frames (linear filtering at
  // half scale).
  if (fxaa) {
    glBindFramebuffer(GL_FRAMEBUFFER, g.resolve_fbo);
    glViewport(0, 0, settings.width, settings.height);
    glUseProgram(p.fxaa);
    setTexture(p.fxaa, "lit_texture", 0, g.deferred.lit);
    glBindVertexArray(g.screen_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    return;
  }
  glBindFramebuffer(GL_READ_FRAMEBUFFER, g.deferred.lit_fbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, g.resolve_fbo);
  glBlitFramebuffer(0, 0, gw, gh, 0, 0, settings.width, settings.height, GL_COLOR_BUFFER_BIT,
                    scale == 1 ? GL_NEAREST : GL_LINEAR);
}

}  // namespace snowsim
