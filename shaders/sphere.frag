// Sphere impostor: the quad point becomes a point on the sphere with its normal and exact depth.
// (Compiled after "#version" and forward.glsl or gbuffer.glsl, which define emit.)
in vec2 quad;
in vec3 view_center;
in vec3 base_color;

uniform mat4 projection;
uniform float radius;

void main() {
  float r2 = dot(quad, quad);
  if (r2 > 1.0) discard;
  vec3 normal = vec3(quad, sqrt(1.0 - r2));
  vec3 surface = view_center + radius * normal;
  vec4 clip = projection * vec4(surface, 1.0);
  gl_FragDepth = 0.5 * (clip.z / clip.w) + 0.5;
  emit(base_color, normal, 1.0);
}
