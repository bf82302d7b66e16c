// The surface seen at a pixel of the G-buffer (shaders/gbuffer.glsl): its view-space position from
// the depth buffer and its normal. Impostors and meshes store their normal. Sprites a pixel or two
// wide cannot: their normal comes from the depth of their neighbours, so dense snow reads as a
// surface, with the sprite's own normal added as far as it is trusted.
// (Compiled after "#version".)
uniform sampler2D depth_texture;
uniform sampler2D normal_texture;
uniform mat4 inverse_projection;
uniform float surface_gap;  // view-space depth step between neighbours of one surface (m)

bool isGeometry(ivec2 p) { return texelFetch(depth_texture, p, 0).r < 1.0; }

vec3 viewPosition(ivec2 p) {
  vec2 size = vec2(textureSize(depth_texture, 0));
  float depth = texelFetch(depth_texture, p, 0).r;
  vec4 ndc = vec4((vec2(p) + 0.5) / size * 2.0 - 1.0, 2.0 * depth - 1.0, 1.0);
  vec4 v = inverse_projection * ndc;
  return v.xyz / v.w;
}

// The surface's tangent along one screen axis, from the neighbours two pixels away on either side
// (a central difference smooths the steps between layers of sprites), else from the one neighbour
// on the same surface (at a silhouette), else along the screen axis (as if facing the eye).
vec3 tangent(ivec2 p, vec3 centre, ivec2 step) {
  vec3 forward = viewPosition(p + 2 * step) - centre;
  vec3 backward = centre - viewPosition(p - 2 * step);
  bool f = abs(forward.z) < 2.0 * surface_gap, b = abs(backward.z) < 2.0 * surface_gap;
  if (f && b) return forward + backward;
  forward = viewPosition(p + step) - centre;
  backward = centre - viewPosition(p - step);
  f = abs(forward.z) < surface_gap;
  b = abs(backward.z) < surface_gap;
  if (f && b) return abs(forward.z) < abs(backward.z) ? forward : backward;
  if (f) return forward;
  if (b) return backward;
  return vec3(step, 0.0);
}

vec3 surfaceNormal(ivec2 p, vec3 centre) {
  vec4 stored = texelFetch(normal_texture, p, 0);
  vec3 own = stored.xyz * 2.0 - 1.0;
  if (stored.a >= 1.0) return normalize(own);
  vec3 n = normalize(cross(tangent(p, centre, ivec2(1, 0)), tangent(p, centre, ivec2(0, 1))));
  if (dot(n, centre) > 0.0) n = -n;  // towards the eye
  return normalize(n + stored.a * (own - vec3(0.0, 0.0, 1.0)));
}
