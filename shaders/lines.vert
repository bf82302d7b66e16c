// Grid lines, ground and walls, in world space.
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 color;
uniform mat4 view;
uniform mat4 projection;
out vec3 line_color;
void main() {
  line_color = color;
  gl_Position = projection * view * vec4(position, 1.0);
}
