// Perceptual image comparison for visual regression tests.
#pragma once

#include "render/image.h"

namespace snowsim {

// What a comparison found, in numbers.
struct DiffFigures {
  long compared = 0;      // pixels the mask leaves in (all without a mask)
  long differing = 0;     // compared pixels beyond the threshold, anti-aliased edges excluded
  long anti_aliased = 0;  // compared pixels that differ but look like anti-aliasing
  double share = 0;       // differing / compared, 0..1
  double largest = 0;     // largest normalised YIQ difference of a compared pixel, 0..1
};

struct ImageDiff : DiffFigures {
  Image visual;  // red: differing, yellow: anti-aliased, light blue: masked out, faded grey: rest
};

// Whether a mask pixel excludes its pixel from the comparison: it is dark (brightness below half,
// so black and dark greys; alpha is ignored). Light pixels are compared.
bool maskExcludes(const std::uint8_t* mask_pixel);

// Compares a and b (same size) with the YIQ colour distance of Kotsarenko & Ramos 2010, normalised
// to 0..1 (0: equal, 1: black against white); a pixel differs when its distance exceeds threshold
// (0.1 ~ a careful eye). mask, when given, has their size; maskExcludes says which pixels it
// leaves out.
ImageDiff diffImages(const Image& a, const Image& b, double threshold = 0.1,
                     const Image* mask = nullptr);

}  // namespace snowsim
