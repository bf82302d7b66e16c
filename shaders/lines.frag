in vec3 line_color;
out vec4 fragment;
void main() { fragment = vec4(line_color, 1.0); }
