// Anti-aliasing of a 3D frame drawn at its own size (FXAA, Lottes 2009): where the luma of the
// four diagonal neighbours says an edge crosses the pixel, the colour is averaged over a short
// span along the edge, and the wider average is kept only while its luma stays within the
// neighbourhood's (else the narrower one): jagged silhouettes of spheres and meshes smooth out,
// flat areas and texture-free interiors stay as they are. (Compiled after "#version".)
uniform sampler2D lit_texture;  // linearly filtered

out vec4 fragment;

const float kReduceMin = 1.0 / 128.0;
const float kReduceMul = 1.0 / 8.0;
const float kSpanMax = 8.0;  // pixels

float luma(vec3 c) { return dot(c, vec3(0.299, 0.587, 0.114)); }

void main() {
  ivec2 size = textureSize(lit_texture, 0);
  vec2 texel = 1.0 / vec2(size);
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 centre = texelFetch(lit_texture, p, 0).rgb;
  // The image's border pixels repeat beyond it, as the linear taps' clamp to its edge does.
  float nw = luma(texelFetch(lit_texture, clamp(p + ivec2(-1, 1), ivec2(0), size - 1), 0).rgb);
  float ne = luma(texelFetch(lit_texture, clamp(p + ivec2(1, 1), ivec2(0), size - 1), 0).rgb);
  float sw = luma(texelFetch(lit_texture, clamp(p + ivec2(-1, -1), ivec2(0), size - 1), 0).rgb);
  float se = luma(texelFetch(lit_texture, clamp(p + ivec2(1, -1), ivec2(0), size - 1), 0).rgb);
  float m = luma(centre);
  float lowest = min(m, min(min(nw, ne), min(sw, se)));
  float highest = max(m, max(max(nw, ne), max(sw, se)));
  // Along the edge: perpendicular to the luma's gradient over the diagonals (y up).
  vec2 along = vec2(-((nw + ne) - (sw + se)), (ne + se) - (nw + sw));
  float reduce = max((nw + ne + sw + se) * 0.25 * kReduceMul, kReduceMin);
  float scale = 1.0 / (min(abs(along.x), abs(along.y)) + reduce);
  along = clamp(along * scale, vec2(-kSpanMax), vec2(kSpanMax)) * texel;
  vec2 uv = gl_FragCoord.xy * texel;
  vec3 narrow = 0.5 * (texture(lit_texture, uv + along * (1.0 / 3.0 - 0.5)).rgb +
                       texture(lit_texture, uv + along * (2.0 / 3.0 - 0.5)).rgb);
  vec3 wide = 0.5 * narrow + 0.25 * (texture(lit_texture, uv - 0.5 * along).rgb +
                                     texture(lit_texture, uv + 0.5 * along).rgb);
  float wide_luma = luma(wide);
  fragment = vec4(wide_luma < lowest || wide_luma > highest ? narrow : wide, 1.0);
}
