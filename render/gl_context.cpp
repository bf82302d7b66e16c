#include "render/gl_context.h"

#define GL_GLEXT_PROTOTYPES
#include <GL/osmesa.h>

#include <stdexcept>
#include <vector>

namespace snowsim {

struct OffscreenContext::State {
  OSMesaContext context = nullptr;
  std::vector<unsigned char> unused_buffer = std::vector<unsigned char>(4);  // 1x1, never read
};

OffscreenContext::OffscreenContext() : state_(std::make_unique<State>()) {
  const int attributes[] = {OSMESA_FORMAT,
                            OSMESA_RGBA,
                            OSMESA_DEPTH_BITS,
                            24,
                            OSMESA_PROFILE,
                            OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION,
                            3,
                            OSMESA_CONTEXT_MINOR_VERSION,
                            3,
                            0};
  state_->context = OSMesaCreateContextAttribs(attributes, nullptr);
  if (!state_->context) throw std::runtime_error("cannot create an OSMesa OpenGL 3.3 core context");
  try {
    makeCurrent();
  } catch (...) {
    OSMesaDestroyContext(state_->context);
    throw;
  }
}

void OffscreenContext::makeCurrent() {
  if (!OSMesaMakeCurrent(state_->context, state_->unused_buffer.data(), GL_UNSIGNED_BYTE, 1, 1))
    throw std::runtime_error("cannot make the OSMesa context current");
}

OffscreenContext::~OffscreenContext() {
  OSMesaDestroyContext(state_->context);
}

}  // namespace snowsim
