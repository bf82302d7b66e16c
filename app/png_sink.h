// Rendering frames to PNG images, shared by `snowsim run` and `snowsim render`.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "app/frame_sink.h"
#include "render/renderer.h"

namespace snowsim {

// The image options of the command line.
struct RenderOptions {
  int width = 1280;
  int height = 720;
  std::string color_by = "white";
  bool grid = true;

  void addTo(CLI::App& command);
  RenderSettings settings() const;  // throws InputError for a bad value
};

class PngSink final : public FrameSink {
 public:
  PngSink(std::string dir, const RenderSettings& settings);
  void write(const Snapshot& snapshot) override;

 private:
  std::string dir_;
  Renderer renderer_;
};

}  // namespace snowsim
