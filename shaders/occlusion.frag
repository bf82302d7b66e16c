// Screen-space ambient occlusion at half the G-buffer's resolution: a few samples on a disc of a
// fixed world radius around the pixel, each counting as far as it rises above the surface's
// tangent plane (Alchemy AO, McGuire et al. 2011), so crevices and packed snow darken while a flat
// surface and a lone particle stay bright. The disc turns from pixel to pixel (4x4 pattern); the
// lighting pass blurs it. (Compiled after "#version" and surface.glsl.)
uniform float radius;            // world (view-space) metres
uniform float pixels_per_metre;  // at unit distance: projection[1][1] * height / 2
uniform float strength;
uniform float image_step;        // G-buffer pixels a side per image pixel (2 supersampled)

out vec4 occlusion;

const int kSamples = 8;

void main() {
  ivec2 p = 2 * ivec2(gl_FragCoord.xy);
  if (!isGeometry(p)) {
    occlusion = vec4(1.0);
    return;
  }
  vec3 centre = viewPosition(p);
  vec3 normal = surfaceNormal(p, centre);
  // At most 32 pixels of the image, however many G-buffer pixels that is.
  float disc = clamp(radius * pixels_per_metre / -centre.z, 2.0, 32.0 * image_step);
  ivec2 pattern = ivec2(gl_FragCoord.xy) & 3;
  float turn = float(pattern.x * 4 + pattern.y) * 0.3927;  // 2 pi / 16
  ivec2 last = textureSize(depth_texture, 0) - 1;
  float sum = 0.0;
  for (int i = 0; i < kSamples; ++i) {
    float angle = turn + 2.39996 * float(i);  // golden angle spiral
    float r = disc * sqrt((float(i) + 0.5) / float(kSamples));
    ivec2 q = clamp(p + ivec2(r * vec2(cos(angle), sin(angle))), ivec2(0), last);
    vec3 v = viewPosition(q) - centre;
    float d2 = dot(v, v);
    if (d2 >= radius * radius) continue;
    sum += max(dot(v, normal) * inversesqrt(d2 + 1e-12) - 0.1, 0.0) * (1.0 - d2 / (radius * radius));
  }
  occlusion = vec4(clamp(1.0 - strength * sum / float(kSamples), 0.0, 1.0));
}
