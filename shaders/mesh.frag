// (Compiled after "#version" and forward.glsl or gbuffer.glsl, which define emit.)
in vec3 view_normal;
in vec3 base_color;

void main() { emit(base_color, normalize(view_normal), 1.0); }
