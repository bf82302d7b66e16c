// A point sprite shaded as a sphere (normals from the sprite coordinate), flat depth.
// (Compiled after "#version" and forward.glsl or gbuffer.glsl, which define emit.)
in vec3 base_color;
in float sprite_normal_trust;

void main() {
  vec2 quad = vec2(2.0 * gl_PointCoord.x - 1.0, 1.0 - 2.0 * gl_PointCoord.y);
  float r2 = dot(quad, quad);
  if (r2 > 1.0) discard;
  emit(base_color, vec3(quad, sqrt(1.0 - r2)), sprite_normal_trust);
}
