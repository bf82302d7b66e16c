// snowsim diff A B: perceptual image difference for visual regression in CI, of two PNG images or
// of two directories of frames (a whole run against a reference run).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <set>

#include "app/commands.h"
#include "app/diff_report.h"
#include "render/image.h"
#include "render/image_diff.h"
#include "sim/core/errors.h"

namespace snowsim {

namespace {

namespace fs = std::filesystem;

struct DiffOptions {
  std::string a, b, out, json, html;
  DiffLimits limits;
  bool allow_missing = false, allow_extra = false;
};

void checkFraction(const char* option, double value, const char* meaning) {
  if (value >= 0 && value <= 1) return;  // NaN is refused too
  char text[64];
  std::snprintf(text, sizeof text, "%s: %g is out of range; allowed: 0 to 1", option, value);
  throw InputError(text + std::string(" (") + meaning + ")");
}

std::string sizeText(const Image& image) {
  return sizeText(ImageSize{image.width, image.height});
}

// The frames of a directory: the names of its PNG files.
std::set<std::string> pngNames(const std::string& dir) {
  std::set<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::string extension = it->path().extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
    if (extension == ".png" && it->is_regular_file()) names.insert(it->path().filename().string());
  }
  if (ec) throw InputError(dir + ": cannot list the directory (" + ec.message() + ")");
  return names;
}

// A report (--out, --json) written over an image it compares, or over the mask, would replace it.
void refuseWritingOverAnInput(const char* option, const std::string& path, const std::string& a,
                              const std::string& b, const std::string& mask, bool directories) {
  std::error_code ec;
  if (path.empty() || !fs::exists(path, ec)) return;
  if (!mask.empty() && fs::exists(mask, ec) && fs::equivalent(path, mask, ec))
    throw InputError(std::string(option) + " " + path +
                     ": is the --mask; write the report elsewhere");
  std::string extension = fs::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), ::tolower);
  if (directories && extension != ".png") return;  // a directory's frames are its PNG files
  for (const std::string& input : {a, b}) {
    const fs::path compared =
        directories ? fs::path(input) / fs::path(path).filename() : fs::path(input);
    if (fs::exists(compared, ec) && fs::equivalent(path, compared, ec))
      throw InputError(std::string(option) + " " + path + ": is " + compared.string() +
                       ", one of the images compared; write the report elsewhere");
  }
}

// Both files or both directories; says which is which when neither or a mixture.
bool bothDirectories(const std::string& a, const std::string& b) {
  for (const std::string& path : {a, b})
    if (!fs::exists(path)) throw InputError(path + ": no such file or directory");
  const bool a_dir = fs::is_directory(a), b_dir = fs::is_directory(b);
  if (a_dir != b_dir)
    throw InputError((a_dir ? a : b) + " is a directory but " + (a_dir ? b : a) +
                     " is not; give two PNG images or two directories of frames");
  return a_dir;
}

class Comparer {
 public:
  explicit Comparer(const DiffOptions& options) : options_(options) {
    if (options.limits.mask.empty()) return;
    try {
      mask_ = readPng(options.limits.mask);
    } catch (const InputError& e) {
      throw InputError(std::string("--mask ") + e.what());
    }
    bool keeps_any = false;
    for (int y = 0; y < mask_->height && !keeps_any; ++y)
      for (int x = 0; x < mask_->width && !keeps_any; ++x)
        keeps_any = !maskExcludes(mask_->pixel(x, y));
    if (!keeps_any)
      throw InputError("--mask " + options.limits.mask +
                       ": every pixel is dark, so no pixel would be compared; its light pixels "
                       "(brightness half or more) are the ones compared");
  }

  // Compares the images at a and b, named `name` in the reports.
  FrameResult compare(const std::string& name, const std::string& a, const std::string& b,
                      HtmlReport* html) const {
    const Image image_a = readPng(a), image_b = readPng(b);
    // Another resolution is a difference of the output, not bad input: the frame fails.
    if (image_a.width != image_b.width || image_a.height != image_b.height) {
      if (html) html->addResizedFrame(name, a, b);
      return {name,
              FrameResult::Status::Resized,
              {},
              {image_a.width, image_a.height},
              {image_b.width, image_b.height}};
    }
    if (mask_ && (mask_->width != image_a.width || mask_->height != image_a.height))
      throw InputError("--mask " + options_.limits.mask + " is " + sizeText(*mask_) + " but " + a +
                       " is " + sizeText(image_a) + "; the mask must have the frames' size");
    const ImageDiff diff =
        diffImages(image_a, image_b, options_.limits.threshold, mask_ ? &*mask_ : nullptr);
    const bool fails = diff.share > options_.limits.max_share;
    if (!options_.out.empty()) writePng(options_.out, diff.visual);
    if (fails && html) html->addFailingFrame(name, a, b, diff.visual);
    return {name, fails ? FrameResult::Status::Failed : FrameResult::Status::Passed, diff, {}, {}};
  }

 private:
  const DiffOptions& options_;
  std::optional<Image> mask_;
};

// Every frame of either directory, paired by name, each line printed as it is compared.
void compareDirectories(const Comparer& comparer, RunComparison& comparison, HtmlReport* html) {
  const std::set<std::string> in_a = pngNames(comparison.a), in_b = pngNames(comparison.b);
  if (in_a.empty() && in_b.empty())
    throw InputError(comparison.a + " and " + comparison.b + ": neither holds a PNG frame");
  std::set<std::string> names = in_a;
  names.insert(in_b.begin(), in_b.end());
  for (const std::string& name : names) {
    FrameResult frame{name, FrameResult::Status::Missing, {}, {}, {}};
    if (!in_b.count(name)) {
      frame.status = FrameResult::Status::Missing;
    } else if (!in_a.count(name)) {
      frame.status = FrameResult::Status::Extra;
    } else {
      frame = comparer.compare(name, (fs::path(comparison.a) / name).string(),
                               (fs::path(comparison.b) / name).string(), html);
    }
    const std::string line = frameLine(comparison, frame);
    if (!line.empty()) std::printf("%s\n", line.c_str());
    comparison.frames.push_back(frame);
  }
}

void diff(const DiffOptions& options) {
  checkFraction("--threshold", options.limits.threshold,
                "a YIQ colour distance: 0 equal, 1 black against white");
  checkFraction("--max-share", options.limits.max_share, "a share of the pixels: 0.005 is 0.5%");
  RunComparison comparison{options.a, options.b, options.limits, {}};
  comparison.limits.directories = bothDirectories(options.a, options.b);
  comparison.limits.missing_fail = !options.allow_missing;
  comparison.limits.extra_fail = !options.allow_extra;
  if (comparison.limits.directories && !options.out.empty())
    throw InputError("--out: writes the diff image of two images; for directories use --html");
  // Everything the user asked for is checked before the comparison, which may take a while.
  refuseWritingOverAnInput("--out", options.out, options.a, options.b, options.limits.mask, false);
  if (!options.out.empty() && fs::is_directory(options.out))
    throw InputError("--out " + options.out + ": is a directory; give the diff image's file name");
  refuseWritingOverAnInput("--json", options.json, options.a, options.b, options.limits.mask,
                           comparison.limits.directories);
  const Comparer comparer(options);
  if (!options.json.empty()) checkJsonReportPath(options.json);
  std::optional<HtmlReport> html;
  if (!options.html.empty()) html.emplace(options.html);

  if (comparison.limits.directories) {
    compareDirectories(comparer, comparison, html ? &*html : nullptr);
  } else {
    const FrameResult& frame = comparison.frames.emplace_back(comparer.compare(
        fs::path(options.a).filename().string(), options.a, options.b, html ? &*html : nullptr));
    const DiffFigures& f = frame.figures;
    if (frame.status == FrameResult::Status::Resized)
      std::printf("%s is %s but %s is %s: no pixel compared%s\n", options.a.c_str(),
                  sizeText(frame.size_a).c_str(), options.b.c_str(), sizeText(frame.size_b).c_str(),
                  options.out.empty() ? "" : ", no diff image written");
    else
      std::printf(
          "%ld differing pixels (%.4f%%), %ld anti-aliased ignored, largest difference %.3f\n",
          f.differing, 100 * f.share, f.anti_aliased, f.largest);
  }
  if (!options.json.empty()) writeJsonReport(options.json, comparison);
  if (html) html->finish(comparison);
  std::printf("%s\n", summaryLine(comparison).c_str());
  if (!comparison.passed()) std::exit(1);
}

}  // namespace

void addDiffCommand(CLI::App& app) {
  auto options = std::make_shared<DiffOptions>();
  CLI::App* cmd = app.add_subcommand(
      "diff", "Compare two PNG images, or two directories of frames, perceptually");
  cmd->add_option("a", options->a, "Expected: a PNG image, or a directory of PNG frames")
      ->required();
  cmd->add_option("b", options->b, "Actual: a PNG image, or a directory of PNG frames")->required();
  cmd->add_option("--threshold", options->limits.threshold,
                  "YIQ colour distance (0..1) above which a pixel differs")
      ->capture_default_str();
  cmd->add_option("--max-share", options->limits.max_share,
                  "Share of a frame's compared pixels (0..1) that may differ")
      ->capture_default_str();
  cmd->add_option("--mask", options->limits.mask,
                  "PNG of the frames' size: its dark pixels (brightness below half) are left out "
                  "of the comparison, its light ones compared");
  cmd->add_option("--out", options->out,
                  "Two images: write their diff image here (red: differs, yellow: anti-aliased "
                  "edge, light blue: masked out; none when their sizes differ)");
  cmd->add_option("--json", options->json, "Write every frame's figures here as JSON");
  cmd->add_option("--html", options->html,
                  "Write a page of the failing frames (A, B and diff image side by side) into "
                  "this directory, with the images, for a CI artefact");
  cmd->add_flag("--allow-missing", options->allow_missing,
                "Directories: frames in A but not in B do not fail the comparison");
  cmd->add_flag("--allow-extra", options->allow_extra,
                "Directories: frames in B but not in A do not fail the comparison");
  cmd->footer(
      "Units: a pixel's difference is the YIQ colour distance of Kotsarenko and Ramos (2010), "
      "normalised to 0..1 (0: equal, 1: black against white; 0.1 is about what a careful eye "
      "notices); --threshold and 'largest difference' are in it. A frame's share is the fraction "
      "of its compared pixels (all, or those the mask keeps) that differ beyond --threshold, "
      "anti-aliased edge pixels not counted; 0..1 like --max-share (0.005 is 0.5%); the lines "
      "also give it in percent.\n"
      "Directories: frames are the *.png files, paired by name; a frame fails when its share "
      "exceeds --max-share, or when A's and B's images differ in size (a resolution change: no "
      "pixel "
      "is compared, and the JSON gives both sizes). Frames missing from B or extra in B fail too "
      "unless allowed. One line "
      "is printed for each frame that differs, is missing or extra, then a PASS or FAIL line "
      "with the limits used.\n"
      "Exit codes: 0 within tolerance, 1 beyond it, 2 bad input.");
  cmd->callback([options] { diff(*options); });
}

}  // namespace snowsim
