// The GLSL sources of shaders/, embedded at build time.
#pragma once

namespace snowsim::shaders {
extern const char* const sphere_vert;
extern const char* const sphere_frag;
extern const char* const lines_vert;
extern const char* const lines_frag;
extern const char* const points_vert;
extern const char* const points_frag;
extern const char* const lighting_glsl;
extern const char* const forward_glsl;
extern const char* const gbuffer_glsl;
extern const char* const mesh_vert;
extern const char* const mesh_frag;
extern const char* const snow_frag;
extern const char* const depth_only_frag;
extern const char* const point_depth_frag;
extern const char* const fullscreen_vert;
extern const char* const surface_glsl;
extern const char* const occlusion_frag;
extern const char* const compose_frag;
extern const char* const fxaa_frag;
extern const char* const volume_frag;
}  // namespace snowsim::shaders
