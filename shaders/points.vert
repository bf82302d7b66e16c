// Level of detail for spheres a few pixels wide: one point sprite per particle, sized to the
// sphere's projected diameter, at the depth of its front point (no per-pixel ray cast).
// (Compiled after "#version".)
layout(location = 1) in vec3 center;  // world space
layout(location = 2) in vec3 color;

uniform mat4 view;
uniform mat4 projection;
uniform float radius;
uniform float viewport_height;
// 0: the sprite's size rounds as OpenGL rounds it; 1: up, so that touching spheres leave no gaps
// between their sprites (the deferred pass reads the surface from their depths).
uniform float round_up;

out vec3 base_color;
// A sprite's own normal says little below a few pixels: the lighting pass leans on the depth
// buffer's surface instead (shaders/surface.glsl).
out float sprite_normal_trust;

void main() {
  vec4 view_center = view * vec4(center, 1.0);
  // The front of the sphere, as the impostor's nearest depth: in front of the grid behind it.
  gl_Position = projection * (view_center + vec4(0.0, 0.0, radius, 0.0));
  base_color = color;
  // Projected radius in pixels: projection[1][1] maps view-space height to clip space; a
  // perspective divides by the distance (w), an orthographic projection has w = 1.
  float diameter = radius * projection[1][1] * viewport_height / gl_Position.w;
  gl_PointSize = max(1.0, mix(diameter, ceil(diameter), round_up));
  sprite_normal_trust = clamp((gl_PointSize - 2.0) / 6.0, 0.0, 1.0);
}
