// Encoding rendered frames into an MP4 video with FFmpeg's libavcodec/libavformat/libswscale.
// The file is written under a temporary name and renamed when finish() writes the trailer, so
// a run that fails leaves no half-written video; a run that is interrupted calls finish() and
// keeps a shorter video that still plays.
#pragma once

#include <memory>
#include <string>

#include "render/image.h"

namespace snowsim {

struct VideoSettings {
  double fps = 30;
  // "auto": libx264 when Debian's libavcodec has it, else the best other MP4 encoder; or the name
  // of a libavcodec encoder (ffmpeg -encoders lists them).
  std::string codec = "auto";
  int crf = 20;  // constant rate factor for x264/x265 (0 lossless .. 51 worst); others: quality
  std::string preset = "veryfast";  // x264/x265 speed preset
};

// Throws InputError naming the option for a value outside its range, an encoder this libavcodec
// lacks, or a frame size yuv420p cannot hold (odd width or height).
void validate(const VideoSettings& settings, int width, int height);

class VideoEncoder {
 public:
  // Opens the encoder for width x height frames (both even: yuv420p halves the chroma planes).
  // Throws InputError for a missing encoder, odd sizes or an unwritable path; writes nothing then.
  VideoEncoder(std::string path, int width, int height, const VideoSettings& settings);
  ~VideoEncoder();  // without finish(): the temporary file is removed
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  void addFrame(const Image& image);  // RGBA, the size given at construction
  void finish();                      // flushes the encoder, writes the trailer, renames
  std::string codecName() const;
  int framesWritten() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace snowsim
