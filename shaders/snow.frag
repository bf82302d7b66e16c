// The surface look's snow mesh: the surface's normal bent at the scale of its grains, as a bump map
// of value noise fixed in the snow (Mikkelsen 2010's surface gradient from screen derivatives, so
// no tangents are needed), faded where a grain is smaller than a pixel so that it does not
// shimmer; marked as snow (albedo alpha kSnowAlpha) for the lighting pass's wrapped diffuse.
// (Compiled after "#version" and gbuffer.glsl.)
in vec3 view_normal;
in vec3 view_position;
in vec3 world_position;
in vec3 base_color;

uniform float grain;  // world metres between grains (about a particle's spacing)

float hash(vec3 cell) {
  cell = fract(cell * vec3(0.1031, 0.1030, 0.0973));
  cell += dot(cell, cell.yxz + 33.33);
  return fract((cell.x + cell.y) * cell.z);
}

// Trilinear value noise in [0, 1], smoothly interpolated.
float valueNoise(vec3 x) {
  vec3 cell = floor(x), f = fract(x);
  vec3 u = f * f * (3.0 - 2.0 * f);
  float n000 = hash(cell), n100 = hash(cell + vec3(1, 0, 0));
  float n010 = hash(cell + vec3(0, 1, 0)), n110 = hash(cell + vec3(1, 1, 0));
  float n001 = hash(cell + vec3(0, 0, 1)), n101 = hash(cell + vec3(1, 0, 1));
  float n011 = hash(cell + vec3(0, 1, 1)), n111 = hash(cell + vec3(1, 1, 1));
  return mix(mix(mix(n000, n100, u.x), mix(n010, n110, u.x), u.y),
             mix(mix(n001, n101, u.x), mix(n011, n111, u.x), u.y), u.z);
}

void main() {
  vec3 n = normalize(view_normal);
  // Two octaves: the grains and the clumps of a few of them.
  float footprint = length(fwidth(world_position));
  float fine = clamp(1.5 - footprint / (0.5 * grain), 0.0, 1.0);
  float coarse = clamp(1.5 - footprint / (1.5 * grain), 0.0, 1.0);
  // The coarse octave turned off the axes, so the lattice of the noise does not line up.
  const mat3 turn = mat3(0.00, 0.80, 0.60, -0.80, 0.36, -0.48, -0.60, -0.48, 0.64);
  float height = grain * (0.16 * fine * valueNoise(world_position / (0.5 * grain)) +
                          0.28 * coarse * valueNoise(turn * world_position / (1.5 * grain)));
  vec3 dpdx = dFdx(view_position), dpdy = dFdy(view_position);
  vec3 r1 = cross(dpdy, n), r2 = cross(n, dpdx);
  float det = dot(dpdx, r1);
  vec3 surface_gradient = sign(det) * (dFdx(height) * r1 + dFdy(height) * r2);
  vec3 bent = abs(det) > 0.0 ? normalize(abs(det) * n - surface_gradient) : n;
  // A little grain-to-grain variation of the whiteness, as packed crystals scatter unevenly.
  float shade = 0.96 + 0.04 * valueNoise(world_position / (0.5 * grain) + 17.0) * fine;
  emit(base_color * shade, bent, 1.0);
  albedo.a = kSnowAlpha;
}
