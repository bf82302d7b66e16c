// A PNG sequence written on a thread of its own, so that encoding a frame overlaps rendering and
// simulating the next one. At most `depth` frames wait; write() blocks beyond that, which bounds
// the memory a fast simulation can queue.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "render/image.h"

namespace snowsim {

class BackgroundPngWriter {
 public:
  explicit BackgroundPngWriter(int depth = 2);
  ~BackgroundPngWriter();  // writes what is queued; an error is reported by finish() only
  BackgroundPngWriter(const BackgroundPngWriter&) = delete;
  BackgroundPngWriter& operator=(const BackgroundPngWriter&) = delete;

  // Queues the image for writePng(path, image); rethrows an earlier write's error.
  void write(std::string path, Image image);
  // Waits until every queued image is written; rethrows the first write's error.
  void finish();

 private:
  void run();
  void rethrowError();

  const int depth_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::pair<std::string, Image>> queue_;
  bool writing_ = false;   // the thread holds an image it has taken off the queue
  bool stopping_ = false;  // set by the destructor: the thread ends once the queue is empty
  std::exception_ptr error_;
  std::thread thread_;  // last: starts once everything it uses exists
};

}  // namespace snowsim
