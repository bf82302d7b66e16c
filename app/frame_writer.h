// Frames written on a thread of their own, so that encoding a frame (PNG and MP4 alike) overlaps
// rendering and simulating the next one. Each frame is added to the video, if there is one, then
// written as a PNG, if it has a path, in the order the frames came. At most `depth` frames wait;
// write() blocks beyond that, which bounds the memory a fast simulation can queue.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "render/image.h"
#include "render/video_encoder.h"

namespace snowsim {

class BackgroundFrameWriter {
 public:
  // video: fed by the writer's thread only, from the first write() until finish() returns; the
  // caller keeps it alive as long as the writer. nullptr: no video.
  explicit BackgroundFrameWriter(int depth = 2, VideoEncoder* video = nullptr);
  ~BackgroundFrameWriter();  // writes what is queued; an error is reported by finish() only
  BackgroundFrameWriter(const BackgroundFrameWriter&) = delete;
  BackgroundFrameWriter& operator=(const BackgroundFrameWriter&) = delete;

  // Queues the frame for the video and for writePng(png_path, image) (none if png_path is
  // empty); rethrows an earlier frame's error.
  void write(std::string png_path, Image image);
  // Waits until every queued frame is written; rethrows the first frame's error.
  void finish();

 private:
  void run();
  void rethrowError();

  const int depth_;
  VideoEncoder* const video_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::pair<std::string, Image>> queue_;
  bool writing_ = false;   // the thread holds a frame it has taken off the queue
  bool stopping_ = false;  // set by the destructor: the thread ends once the queue is empty
  std::exception_ptr error_;
  std::thread thread_;  // last: starts once everything it uses exists
};

}  // namespace snowsim
