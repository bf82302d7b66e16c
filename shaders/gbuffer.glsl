// Output of the deferred geometry pass (3D scenes): albedo (alpha 1: lit surface; kSnowAlpha: the
// surface look's snow, lit as translucent; below 0.75: unlit, compose.frag) and the view-space
// normal with how far to trust it (1; a sprite a pixel or two wide: 0, its normal comes from the
// depth buffer in the lighting pass, shaders/surface.glsl).
layout(location = 0) out vec4 albedo;
layout(location = 1) out vec4 normal_and_trust;

const float kSnowAlpha = 0.875;

void emit(vec3 base_color, vec3 normal, float normal_trust) {
  albedo = vec4(base_color, 1.0);
  normal_and_trust = vec4(0.5 * normal + 0.5, normal_trust);
}
