// Perceptual image comparison for visual regression tests.
#pragma once

#include "render/image.h"

namespace snowsim {

struct ImageDiff {
  long differing = 0;     // pixels beyond the threshold, anti-aliased edges excluded
  long anti_aliased = 0;  // pixels that differ but look like anti-aliasing
  double share = 0;       // differing / all pixels
  double largest = 0;     // largest normalised YIQ difference, 0..1
  Image visual;           // red: differing, yellow: anti-aliased, faded grey: the rest
};

// Compares a and b (same size) with the YIQ colour distance of Kotsarenko & Ramos 2010, normalised
// to 0..1; a pixel differs when its distance exceeds threshold (0.1 ~ a careful eye).
ImageDiff diffImages(const Image& a, const Image& b, double threshold = 0.1);

}  // namespace snowsim
