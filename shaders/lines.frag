// Grid lines and density cells, unlit. marker: 1 in a forward pass; in the deferred geometry pass
// 0.5 tells the lighting pass to leave the pixel unlit, and 1 to light it as the surface the line
// lies on (the floor's lines: the ground's normal stays under them; shaders/gbuffer.glsl).
in vec3 line_color;
uniform float marker;
out vec4 fragment;
void main() { fragment = vec4(line_color, marker); }
