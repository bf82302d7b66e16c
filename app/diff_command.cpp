// snowsim diff A.png B.png: perceptual image difference for visual regression in CI.
#include <cstdio>
#include <cstdlib>

#include "app/commands.h"
#include "render/image.h"
#include "render/image_diff.h"
#include "sim/core/errors.h"

namespace snowsim {

namespace {

struct DiffOptions {
  std::string a, b, out;
  double threshold = 0.1;
  double max_share = 0;
};

void diff(const DiffOptions& options) {
  if (options.threshold < 0 || options.threshold > 1)
    throw InputError("--threshold: must be within 0..1");
  const Image a = readPng(options.a), b = readPng(options.b);
  if (a.width != b.width || a.height != b.height)
    throw InputError(options.a + " is " + std::to_string(a.width) + "x" + std::to_string(a.height) +
                     " but " + options.b + " is " + std::to_string(b.width) + "x" +
                     std::to_string(b.height));
  const ImageDiff result = diffImages(a, b, options.threshold);
  if (!options.out.empty()) writePng(options.out, result.visual);
  std::printf("%ld differing pixels (%.4f%%), %ld anti-aliased ignored, largest difference %.3f\n",
              result.differing, 100 * result.share, result.anti_aliased, result.largest);
  if (result.share > options.max_share) std::exit(1);
}

}  // namespace

void addDiffCommand(CLI::App& app) {
  auto options = std::make_shared<DiffOptions>();
  CLI::App* cmd = app.add_subcommand("diff", "Compare two PNG images perceptually");
  cmd->add_option("a", options->a, "First image (PNG)")->required();
  cmd->add_option("b", options->b, "Second image (PNG)")->required();
  cmd->add_option("--threshold", options->threshold,
                  "YIQ colour distance (0..1) above which a pixel differs")
      ->capture_default_str();
  cmd->add_option("--max-share", options->max_share,
                  "Share of differing pixels (0..1) still accepted")
      ->capture_default_str();
  cmd->add_option("--out", options->out,
                  "Write a diff image here (red: differs, yellow: "
                  "anti-aliased edge)");
  cmd->footer("Exit codes: 0 within tolerance, 1 beyond it, 2 bad input.");
  cmd->callback([options] { diff(*options); });
}

}  // namespace snowsim
