// --look volume: the snow's extinction volume (render/snow_volume.h) ray-marched in front of the
// lit ground and colliders, Beer-Lambert extinction and single scattering of the key light
// attenuated by the optical depth towards it (a few octaves of lower extinction stand in for
// multiple scattering, Wrenninge et al. 2013), and the sky's fill attenuated by the depth above.
// Writes the light scattered towards the eye and, as alpha, the transmittance, which the blend
// (ONE, SRC_ALPHA) multiplies the lit image behind by. (Compiled after "#version".)
uniform sampler3D volume_texture;  // sigma (1/m), optical depth to the light, and upwards
uniform sampler2D depth_texture;   // the G-buffer's: the march stops at the ground, colliders
uniform mat4 clip_to_world;
uniform vec3 eye;
uniform vec3 volume_origin;  // world position of texel (0, 0, 0)
uniform vec3 volume_size;    // texels
uniform float spacing;       // between texels (m)
uniform vec3 box_low;        // world box holding snow
uniform vec3 box_high;
uniform vec3 snow_albedo;
uniform vec3 key_color;
uniform vec3 sky_color;
uniform vec3 bounce_color;

out vec4 fragment;

vec3 worldAt(vec2 ndc, float depth) {
  vec4 w = clip_to_world * vec4(ndc, 2.0 * depth - 1.0, 1.0);
  return w.xyz / w.w;
}

// The key light reaching a point through optical depth tau: octave i has extinction 0.5^i and
// weight 0.5^i, normalised so an unshadowed point gets the key light in full.
float keyReach(float tau) {
  return (exp(-tau) + 0.5 * exp(-0.5 * tau) + 0.25 * exp(-0.25 * tau) +
          0.125 * exp(-0.125 * tau)) / 1.875;
}

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec2 ndc = (vec2(p) + 0.5) / vec2(textureSize(depth_texture, 0)) * 2.0 - 1.0;
  float depth = texelFetch(depth_texture, p, 0).r;
  vec3 direction = normalize(worldAt(ndc, 1.0) - eye);
  float end = depth < 1.0 ? length(worldAt(ndc, depth) - eye) : 1e30;
  vec3 to_low = (box_low - eye) / direction, to_high = (box_high - eye) / direction;
  vec3 near = min(to_low, to_high), far = max(to_low, to_high);
  float start = max(max(max(near.x, near.y), near.z), 0.0);
  end = min(end, min(min(far.x, far.y), far.z));
  fragment = vec4(0.0, 0.0, 0.0, 1.0);
  if (start >= end) return;
  // Half a texel a step, started at a per-pixel offset (interleaved gradient noise,
  // Jimenez 2014: fixed, so frames repeat) so the steps leave no rings.
  float step_length = 0.5 * spacing;
  float t = start + step_length * fract(52.9829189 * fract(dot(vec2(p), vec2(0.06711056, 0.00583715))));
  float transmittance = 1.0;
  vec3 light = vec3(0.0);
  for (; t < end && transmittance > 0.004; t += step_length) {
    vec3 q = ((eye + t * direction - volume_origin) / spacing + 0.5) / volume_size;
    vec3 v = texture(volume_texture, q).rgb;
    if (v.r <= 0.0) continue;
    float absorbed = 1.0 - exp(-v.r * step_length);
    vec3 in_scatter = key_color * keyReach(v.g) + sky_color * exp(-0.3 * v.b) + bounce_color;
    light += transmittance * absorbed * snow_albedo * in_scatter;
    transmittance *= 1.0 - absorbed;
  }
  fragment = vec4(light, transmittance);
}
