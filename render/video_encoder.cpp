#include "render/video_encoder.h"

#include <cstdio>
#include <filesystem>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

#include "sim/core/errors.h"
#include "sim/io/files.h"

namespace snowsim {

namespace {

std::string avError(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, text, sizeof text);
  return text;
}

bool isX26x(const AVCodec* codec) {
  const std::string name = codec->name;
  return name == "libx264" || name == "libx265";
}

// libx264 (H.264, what every player reads) when this libavcodec has it, else MPEG-4 part 2.
const AVCodec* chooseEncoder(const std::string& wanted) {
  if (wanted != "auto") {
    const AVCodec* codec = avcodec_find_encoder_by_name(wanted.c_str());
    if (!codec || codec->type != AVMEDIA_TYPE_VIDEO)
      throw InputError("--mp4-codec: this libavcodec has no video encoder named '" + wanted +
                       "'; allowed: auto or a name from `ffmpeg -encoders` (e.g. libx264, mpeg4)");
    return codec;
  }
  for (const char* name : {"libx264", "mpeg4"})
    if (const AVCodec* codec = avcodec_find_encoder_by_name(name)) return codec;
  throw InputError(
      "MP4: this libavcodec has neither libx264 nor mpeg4; install Debian's libavcodec59 "
      "(scripts/setup.sh) or pass --no-mp4");
}

}  // namespace

void validate(const VideoSettings& s, int width, int height) {
  if (!(s.fps > 0 && s.fps <= 1000))
    throw InputError("--mp4-fps: " + numberText(s.fps) + " is outside the allowed (0, 1000]");
  if (s.crf < 0 || s.crf > 51)
    throw InputError("--mp4-crf: " + std::to_string(s.crf) + " is outside the allowed 0..51");
  if (width % 2 || height % 2)
    throw InputError("--width/--height: MP4 (yuv420p) needs an even width and height, got " +
                     std::to_string(width) + "x" + std::to_string(height) +
                     "; allowed: even sizes, or --no-mp4");
  chooseEncoder(s.codec);
}

struct VideoEncoder::State {
  std::string path, temp_path;
  int width = 0, height = 0;
  const AVCodec* codec = nullptr;
  AVFormatContext* format = nullptr;
  AVCodecContext* context = nullptr;
  AVStream* stream = nullptr;
  SwsContext* scaler = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  int frames = 0;
  bool finished = false;

  ~State() {
    if (format && format->pb) avio_closep(&format->pb);
    avformat_free_context(format);
    avcodec_free_context(&context);
    sws_freeContext(scaler);
    av_frame_free(&frame);
    av_packet_free(&packet);
    if (!finished && !temp_path.empty()) {
      std::error_code ignored;
      std::filesystem::remove(temp_path, ignored);
    }
  }

  void check(int code, const std::string& what) const {
    if (code < 0) throw InputError(path + ": " + what + ": " + avError(code));
  }

  // Sends a frame (nullptr: end of stream) and writes every packet the encoder hands back.
  void encode(AVFrame* input) {
    check(avcodec_send_frame(context, input), "encoding a frame");
    for (;;) {
      const int r = avcodec_receive_packet(context, packet);
      if (r == AVERROR(EAGAIN) || r == AVERROR_EOF) return;
      check(r, "encoding a frame");
      // One frame long; without a duration the MP4 muxer gives the last frame none and players
      // drop it.
      if (packet->duration == 0) packet->duration = 1;
      av_packet_rescale_ts(packet, context->time_base, stream->time_base);
      packet->stream_index = stream->index;
      check(av_interleaved_write_frame(format, packet), "writing a frame");
    }
  }
};

VideoEncoder::VideoEncoder(std::string path, int width, int height, const VideoSettings& settings)
    : state_(std::make_unique<State>()) {
  validate(settings, width, height);
  State& s = *state_;
  s.path = std::move(path);
  s.width = width;
  s.height = height;
  av_log_set_level(AV_LOG_ERROR);  // x264 prints its statistics at info level
  s.codec = chooseEncoder(settings.codec);
  if (settings.codec == "auto" && std::string(s.codec->name) != "libx264")
    std::fprintf(stderr, "snowsim: no libx264 in this libavcodec; encoding MP4 with %s\n",
                 s.codec->name);
  s.temp_path = s.path + ".part";

  s.check(avformat_alloc_output_context2(&s.format, nullptr, "mp4", s.temp_path.c_str()),
          "creating the MP4 container");
  s.stream = avformat_new_stream(s.format, nullptr);
  s.context = avcodec_alloc_context3(s.codec);
  if (!s.stream || !s.context) throw InputError(s.path + ": out of memory opening the encoder");
  AVCodecContext& c = *s.context;
  c.width = width;
  c.height = height;
  c.pix_fmt = AV_PIX_FMT_YUV420P;
  c.framerate = av_d2q(settings.fps, 100000);
  c.time_base = av_inv_q(c.framerate);
  c.gop_size = 2 * static_cast<int>(settings.fps + 0.5);  // a key frame every two seconds
  c.color_primaries = AVCOL_PRI_BT709;
  c.color_trc = AVCOL_TRC_BT709;
  c.colorspace = AVCOL_SPC_BT709;
  c.color_range = AVCOL_RANGE_MPEG;
  if (s.format->oformat->flags & AVFMT_GLOBALHEADER) c.flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
  AVDictionary* codec_options = nullptr;
  if (isX26x(s.codec)) {
    av_dict_set(&codec_options, "preset", settings.preset.c_str(), 0);
    av_dict_set_int(&codec_options, "crf", settings.crf, 0);
  } else {
    // Fixed quantiser 2 (best) .. 31 (worst), scaled from the crf range.
    c.flags |= AV_CODEC_FLAG_QSCALE;
    c.global_quality = FF_QP2LAMBDA * (2 + settings.crf * 29 / 51);
  }
  const int opened = avcodec_open2(&c, s.codec, &codec_options);
  av_dict_free(&codec_options);
  s.check(opened, std::string("opening the ") + s.codec->name + " encoder");
  s.check(avcodec_parameters_from_context(s.stream->codecpar, &c), "configuring the stream");
  s.stream->time_base = c.time_base;

  s.frame = av_frame_alloc();
  s.packet = av_packet_alloc();
  if (!s.frame || !s.packet) throw InputError(s.path + ": out of memory opening the encoder");
  s.frame->format = c.pix_fmt;
  s.frame->width = width;
  s.frame->height = height;
  s.check(av_frame_get_buffer(s.frame, 0), "allocating a frame");
  s.scaler = sws_getContext(width, height, AV_PIX_FMT_RGBA, width, height, AV_PIX_FMT_YUV420P,
                            SWS_BICUBIC, nullptr, nullptr, nullptr);
  if (!s.scaler) throw InputError(s.path + ": cannot convert RGBA to yuv420p");
  // Full-range RGB in, BT.709 limited-range YUV out, as the stream is tagged.
  const int* bt709 = sws_getCoefficients(SWS_CS_ITU709);
  sws_setColorspaceDetails(s.scaler, bt709, 1, bt709, 0, 0, 1 << 16, 1 << 16);

  if (avio_open(&s.format->pb, s.temp_path.c_str(), AVIO_FLAG_WRITE) < 0)
    throw InputError(s.path + ": cannot create the video file (is the directory writable?)");
  AVDictionary* muxer_options = nullptr;
  av_dict_set(&muxer_options, "movflags", "+faststart", 0);  // playable while downloading
  const int header = avformat_write_header(s.format, &muxer_options);
  av_dict_free(&muxer_options);
  s.check(header, "writing the MP4 header");
}

VideoEncoder::~VideoEncoder() = default;

void VideoEncoder::addFrame(const Image& image) {
  State& s = *state_;
  if (image.width != s.width || image.height != s.height)
    throw InputError(s.path + ": frame of " + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + " in a " + std::to_string(s.width) + "x" +
                     std::to_string(s.height) + " video");
  s.check(av_frame_make_writable(s.frame), "preparing a frame");
  const uint8_t* source[1] = {image.rgba.data()};
  const int source_stride[1] = {4 * image.width};
  sws_scale(s.scaler, source, source_stride, 0, s.height, s.frame->data, s.frame->linesize);
  s.frame->pts = s.frames++;
  s.encode(s.frame);
}

void VideoEncoder::finish() {
  State& s = *state_;
  if (s.finished) return;
  s.encode(nullptr);
  s.check(av_write_trailer(s.format), "writing the MP4 trailer");
  avio_closep(&s.format->pb);
  syncFile(s.temp_path, s.path);
  std::error_code error;
  std::filesystem::rename(s.temp_path, s.path, error);
  if (error) throw InputError(s.path + ": cannot rename the finished video: " + error.message());
  s.finished = true;
}

std::string VideoEncoder::codecName() const {
  return state_->codec->name;
}

int VideoEncoder::framesWritten() const {
  return state_->frames;
}

}  // namespace snowsim
