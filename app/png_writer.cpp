#include "app/png_writer.h"

namespace snowsim {

BackgroundPngWriter::BackgroundPngWriter(int depth) : depth_(depth), thread_([this] { run(); }) {}

BackgroundPngWriter::~BackgroundPngWriter() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void BackgroundPngWriter::rethrowError() {
  if (error_) std::rethrow_exception(std::exchange(error_, nullptr));
}

void BackgroundPngWriter::write(std::string path, Image image) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return static_cast<int>(queue_.size()) < depth_ || error_; });
  rethrowError();
  queue_.emplace_back(std::move(path), std::move(image));
  lock.unlock();
  changed_.notify_all();
}

void BackgroundPngWriter::finish() {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return (queue_.empty() && !writing_) || error_; });
  rethrowError();
}

void BackgroundPngWriter::run() {
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
      writePng(path, image);
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
