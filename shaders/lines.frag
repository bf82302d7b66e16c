// Grid lines and density cells, unlit. marker: 1 in a forward pass; 0.5 in the deferred geometry
// pass, where it tells the lighting pass to leave the pixel unlit (shaders/gbuffer.glsl).
in vec3 line_color;
uniform float marker;
out vec4 fragment;
void main() { fragment = vec4(line_color, marker); }
