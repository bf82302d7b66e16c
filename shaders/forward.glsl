// Output of a forward pass (2D scenes): the fragment shaded here. (After lighting.glsl.)
uniform vec3 light_direction;  // view space, towards the light

out vec4 fragment;

void emit(vec3 base_color, vec3 normal, float normal_trust) {
  fragment = vec4(shadeSnow(base_color, normal, light_direction), 1.0);
}
