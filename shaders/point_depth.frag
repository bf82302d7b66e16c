// The key light's shadow map of the particles: only depth, of a disc.
void main() {
  vec2 quad = 2.0 * gl_PointCoord - 1.0;
  if (dot(quad, quad) > 1.0) discard;
}
