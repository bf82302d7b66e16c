// What `snowsim diff` found for each frame, and how it tells it: a line per frame, a summary
// line, a JSON report for machines and an HTML page for people.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "render/image.h"
#include "render/image_diff.h"

namespace snowsim {

// The limits a comparison is judged by.
struct DiffLimits {
  double threshold = 0.1;    // YIQ distance (0..1) above which a pixel differs
  double max_share = 0;      // share of a frame's compared pixels (0..1) that may differ
  std::string mask;          // mask image, empty for none
  bool missing_fail = true;  // frames in A but not in B fail the comparison
  bool extra_fail = true;    // frames in B but not in A fail it
  bool directories = false;  // two directories of frames, not two images
};

struct ImageSize {
  int width = 0, height = 0;
};

std::string sizeText(const ImageSize& size);  // "640x480"

struct FrameResult {
  // Resized: A's and B's images differ in size (another resolution), so no pixel is compared; a
  // difference like any other, which fails.
  enum class Status { Passed, Failed, Missing, Extra, Resized };
  std::string name;  // the file name, by which frames are paired
  Status status = Status::Passed;
  DiffFigures figures;       // zero for missing, extra and resized frames
  ImageSize size_a, size_b;  // the images' sizes, for resized frames
};

struct RunComparison {
  std::string a, b;
  DiffLimits limits;
  std::vector<FrameResult> frames;  // by name

  // Whether a frame fails: beyond the limits, or missing or extra when those fail.
  bool fails(const FrameResult& frame) const;
  // No frame beyond the limits, no missing or extra frame that fails, and at least one compared.
  bool passed() const;
  long comparedFrames() const;  // frames in both A and B, resized ones too
};

// The line printed for a frame of a directory: only frames that differ, are missing or extra get
// one (empty otherwise).
std::string frameLine(const RunComparison& comparison, const FrameResult& frame);

// "PASS: ..." or "FAIL: ...", the counts and the limits used.
std::string summaryLine(const RunComparison& comparison);

// Writes every frame's figures as JSON, atomically. Throws InputError naming the path.
void writeJsonReport(const std::string& path, const RunComparison& comparison);

// Fails early, with an InputError naming --json, when path cannot be written.
void checkJsonReportPath(const std::string& path);

// The HTML page of the failing frames: each frame's A, B and diff images side by side, in
// folders next to index.html with relative links, so the directory can be uploaded as it is.
// Built in a temporary directory beside `dir` and renamed to it by finish(); a report not
// finished (an error on the way) leaves nothing behind.
class HtmlReport {
 public:
  // Throws InputError naming --html when dir cannot be created, or exists and holds something
  // other than an earlier report (which finish() replaces).
  explicit HtmlReport(const std::string& dir);
  ~HtmlReport();
  HtmlReport(const HtmlReport&) = delete;
  HtmlReport& operator=(const HtmlReport&) = delete;

  // Copies the frame's two images and writes its diff image; each frame finish() shows as
  // failing must have been added.
  void addFailingFrame(const std::string& name, const std::filesystem::path& a,
                       const std::filesystem::path& b, const Image& diff);
  // Copies a resized frame's two images, shown side by side without a diff image; each resized
  // frame finish() shows must have been added.
  void addResizedFrame(const std::string& name, const std::filesystem::path& a,
                       const std::filesystem::path& b);
  void finish(const RunComparison& comparison);

 private:
  std::string name_;                // as the user gave it, for messages
  std::filesystem::path dir_;       // absolute
  std::filesystem::path building_;  // the temporary directory, empty once finished
};

}  // namespace snowsim
