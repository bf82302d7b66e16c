// Sphere impostor: the quad point becomes a point on the sphere with its normal and exact depth.
// (Compiled after "#version" and lighting.glsl.)
in vec2 quad;
in vec3 view_center;
in vec3 base_color;

uniform mat4 projection;
uniform float radius;
uniform vec3 light_direction;  // view space, towards the light

out vec4 fragment;

void main() {
  float r2 = dot(quad, quad);
  if (r2 > 1.0) discard;
  vec3 normal = vec3(quad, sqrt(1.0 - r2));
  vec3 surface = view_center + radius * normal;
  vec4 clip = projection * vec4(surface, 1.0);
  gl_FragDepth = 0.5 * (clip.z / clip.w) + 0.5;
  fragment = vec4(shadeSnow(base_color, normal, light_direction), 1.0);
}
