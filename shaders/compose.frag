// The deferred lighting pass: the key light with its shadow map (4 filtered taps), the sky fill
// (brighter facing up) darkened by the ambient occlusion, a little specular; the background and
// unlit lines as they are. Alpha of the albedo: 1 lit, kSnowAlpha (gbuffer.glsl) the surface
// look's snow, below 0.75 unlit. (Compiled after "#version" and surface.glsl.)
uniform sampler2D albedo_texture;
uniform sampler2D occlusion_texture;
uniform sampler2DShadow shadow_texture;
uniform bool use_shadows;
uniform bool use_occlusion;
uniform mat4 view_to_shadow;  // view space to the shadow map's [0, 1] coordinates and depth
uniform float shadow_bias;    // in shadow depth
uniform float normal_offset;  // view-space metres along the normal before the shadow lookup
uniform vec3 key_direction;   // view space, towards the light
uniform vec3 up_direction;    // view space
uniform vec3 key_color;
uniform vec3 sky_color;
uniform vec3 bounce_color;  // the fill from below
uniform vec3 background;

out vec4 fragment;

float keyVisibility(vec3 position) {
  vec3 s = (view_to_shadow * vec4(position, 1.0)).xyz;
  if (any(lessThan(s, vec3(0.0))) || any(greaterThan(s, vec3(1.0)))) return 1.0;
  vec2 texel = 1.0 / vec2(textureSize(shadow_texture, 0));
  float lit = 0.0;
  for (int i = 0; i < 4; ++i) {
    vec2 offset = (vec2(i & 1, i >> 1) - 0.5) * 1.5 * texel;
    lit += texture(shadow_texture, vec3(s.xy + offset, s.z - shadow_bias));
  }
  return 0.25 * lit;
}

float ambientOcclusion() {
  vec2 size = vec2(textureSize(occlusion_texture, 0));
  vec2 uv = gl_FragCoord.xy / (2.0 * size);
  float sum = 0.0;
  for (int i = 0; i < 4; ++i)  // 4 bilinear taps: a 4x4 box of half-resolution texels
    sum += texture(occlusion_texture, uv + (vec2(i & 1, i >> 1) - 0.5) * 2.0 / size).r;
  return 0.25 * sum;
}

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 albedo = texelFetch(albedo_texture, p, 0);
  if (albedo.a == 0.0) {
    fragment = vec4(background, 1.0);
    return;
  }
  if (albedo.a < 0.75) {
    fragment = vec4(albedo.rgb, 1.0);
    return;
  }
  vec3 position = viewPosition(p);
  vec3 normal = surfaceNormal(p, position);
  float cosine = dot(normal, key_direction);
  float facing = max(cosine, 0.0);
  // The surface look's snow scatters light under its surface: the key light wraps a little past
  // the terminator (wrapped Lambert), which keeps its bent grains from turning black there.
  // kSnowAlpha (0.875, gbuffer.glsl, not compiled in here) lies between 0.75 and 0.95.
  const float kWrap = 0.35;
  bool snow = albedo.a < 0.95;
  float diffuse = snow ? max((cosine + kWrap) / (1.0 + kWrap), 0.0) : facing;
  float lit =
      use_shadows && diffuse > 0.0 ? keyVisibility(position + normal_offset * normal) : 1.0;
  float ao = use_occlusion ? ambientOcclusion() : 1.0;
  vec3 fill = mix(bounce_color, sky_color, 0.5 + 0.5 * dot(normal, up_direction)) * ao;
  vec3 halfway = normalize(key_direction + normalize(-position));
  float specular = 0.15 * pow(max(dot(normal, halfway), 0.0), 32.0) * facing * lit;
  fragment = vec4(albedo.rgb * (key_color * diffuse * lit + fill) + vec3(specular), 1.0);
}
