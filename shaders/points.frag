// A point sprite shaded as a sphere (normals from the sprite coordinate), flat depth.
// (Compiled after "#version" and lighting.glsl.)
in vec3 base_color;

uniform vec3 light_direction;  // view space, towards the light

out vec4 fragment;

void main() {
  vec2 quad = vec2(2.0 * gl_PointCoord.x - 1.0, 1.0 - 2.0 * gl_PointCoord.y);
  float r2 = dot(quad, quad);
  if (r2 > 1.0) discard;
  vec3 normal = vec3(quad, sqrt(1.0 - r2));
  fragment = vec4(shadeSnow(base_color, normal, light_direction), 1.0);
}
