// An off-screen OpenGL 3.3+ core context with no display and no GPU (Mesa's OSMesa, llvmpipe).
// Everything renders into the renderer's own framebuffer objects; this class only makes a
// context current. Mesa dropped OSMesa in 25.1: EGL surfaceless would replace it here alone.
#pragma once

#include <memory>

namespace snowsim {

class OffscreenContext {
 public:
  OffscreenContext();  // throws std::runtime_error when no context can be created
  ~OffscreenContext();
  OffscreenContext(const OffscreenContext&) = delete;
  OffscreenContext& operator=(const OffscreenContext&) = delete;

  // Several renderers may live in one thread; each makes its own context current to draw.
  void makeCurrent();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace snowsim
