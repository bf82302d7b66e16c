// Triangles in world space with a normal and a colour per vertex: the ground, the colliders and the
// surface look's snow. Also the depth-only pass from the key light. (Compiled after "#version".)
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 color;

uniform mat4 view;
uniform mat4 projection;

out vec3 view_normal;
out vec3 view_position;
out vec3 world_position;
out vec3 base_color;

void main() {
  view_normal = mat3(view) * normal;
  base_color = color;
  world_position = position;
  vec4 in_view = view * vec4(position, 1.0);
  view_position = in_view.xyz;
  gl_Position = projection * in_view;
}
