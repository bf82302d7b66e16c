// Where the frames of a run go: PLY files, images, a video. The run command feeds every sink the
// same snapshots in order and finishes them at the end.
#pragma once

#include <memory>
#include <vector>

#include "sim/core/snapshot.h"

namespace snowsim {

class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual void write(const Snapshot& snapshot) = 0;
  // Returns once every frame written so far is complete on disk.
  virtual void flush() {}
  virtual void finish() {}
};

using FrameSinks = std::vector<std::unique_ptr<FrameSink>>;

}  // namespace snowsim
