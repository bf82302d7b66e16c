#version 330 core
// Sphere impostor: the quad point becomes a point on the sphere with its normal and depth.
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

  vec3 l = normalize(light_direction);
  float diffuse = max(dot(normal, l), 0.0);
  vec3 halfway = normalize(l + vec3(0.0, 0.0, 1.0));
  float specular = pow(max(dot(normal, halfway), 0.0), 32.0);
  float ambient = 0.35 + 0.15 * normal.y;  // a soft sky term, brighter on top
  fragment = vec4(base_color * (ambient + 0.6 * diffuse) + vec3(0.25 * specular), 1.0);
}
