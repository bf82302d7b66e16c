// (Compiled after "#version".)
// One camera-facing quad per particle; the fragment shader ray-casts the sphere inside it.
layout(location = 0) in vec2 corner;  // (-1,-1) .. (1,1)
layout(location = 1) in vec3 center;  // world space
layout(location = 2) in vec3 color;

uniform mat4 view;
uniform mat4 projection;
uniform float radius;

out vec2 quad;
out vec3 view_center;
out vec3 base_color;

void main() {
  view_center = (view * vec4(center, 1.0)).xyz;
  quad = corner;
  base_color = color;
  // The quad sits in front of the sphere so its ray-cast surface is never clipped by the quad.
  vec3 corner_position = view_center + vec3(corner * radius, radius);
  gl_Position = projection * vec4(corner_position, 1.0);
}
