#include "app/frame_writer.h"

namespace snowsim {

BackgroundFrameWriter::BackgroundFrameWriter(int depth, VideoEncoder* video)
    : depth_(depth), video_(video), thread_([this] { run(); }) {}

BackgroundFrameWriter::~BackgroundFrameWriter() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void BackgroundFrameWriter::rethrowError() {
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void BackgroundFrameWriter::write(std::string png_path, Image image) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return static_cast<int>(queue_.size()) < depth_ || error_; });
  rethrowError();
  queue_.emplace_back(std::move(png_path), std::move(image));
  lock.unlock();
  changed_.notify_all();
}

void BackgroundFrameWriter::finish() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return (queue_.empty() && !writing_) || error_; });
  rethrowError();
}

void BackgroundFrameWriter::run() {
  std::unique_lock lock(mutex_);
  while (true) {
    changed_.wait(lock, [&] { return !queue_.empty() || stopping_; });
    if (queue_.empty()) return;  // stopping, nothing left
    auto [path, image] = std::move(queue_.front());
    queue_.pop_front();
    writing_ = true;
    lock.unlock();
    std::exception_ptr failure;
    try {
      if (video_ != nullptr) video_->addFrame(image);
      if (!path.empty()) writePng(path, image);
    } catch (...) {
      failure = std::current_exception();
    }
    lock.lock();
    writing_ = false;
    if (failure && !error_) error_ = failure;
    changed_.notify_all();
  }
}

}  // namespace snowsim
