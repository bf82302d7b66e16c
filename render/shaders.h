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
}  // namespace snowsim::shaders
