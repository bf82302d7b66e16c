#include "render/image_diff.h"

#include <algorithm>
#include <cmath>

namespace snowsim {

namespace {

struct Yiq {
  double y, i, q;
};

// RGB (0..255) to YIQ, NTSC coefficients as in Kotsarenko & Ramos 2010.
Yiq toYiq(const std::uint8_t* p) {
  const double r = p[0], g = p[1], b = p[2];
  return {0.29889531 * r + 0.58662247 * g + 0.11448223 * b,
          0.59597799 * r - 0.27417610 * g - 0.32180189 * b,
          0.21147017 * r - 0.52261711 * g + 0.31114694 * b};
}

// Weighted squared YIQ distance (Kotsarenko & Ramos 2010, eq. for delta E with weights
// 0.5053, 0.299, 0.1957); its maximum over 8-bit RGB is 35215.
double yiqDistance(const std::uint8_t* p, const std::uint8_t* q) {
  const Yiq a = toYiq(p), b = toYiq(q);
  const double dy = a.y - b.y, di = a.i - b.i, dq = a.q - b.q;
  return 0.5053 * dy * dy + 0.299 * di * di + 0.1957 * dq * dq;
}
constexpr double kMaxDistance = 35215;

double brightness(const std::uint8_t* p) {
  return toYiq(p).y;
}

// Whether at least three of the 8 neighbours of (x, y) have exactly its colour: a flat region.
bool inFlatRegion(const Image& image, int x, int y) {
  int equal = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int nx = x + dx, ny = y + dy;
      if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= image.width || ny >= image.height)
        continue;
      equal += std::equal(image.pixel(x, y), image.pixel(x, y) + 3, image.pixel(nx, ny));
    }
  return equal >= 3;
}

// A pixel of `image` looks anti-aliased when it lies between a darker and a brighter neighbour
// (an edge's gradient), at most two neighbours equal it, and its darkest or brightest neighbour
// sits in a flat region in both images: an edge between two flat areas (Vysniauskas 2009).
bool looksAntiAliased(const Image& image, const Image& other, int x, int y) {
  const double centre = brightness(image.pixel(x, y));
  int equal = 0;
  double darkest = 0, brightest = 0;
  int dark_x = -1, dark_y = -1, bright_x = -1, bright_y = -1;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int nx = x + dx, ny = y + dy;
      if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= image.width || ny >= image.height)
        continue;
      const double delta = brightness(image.pixel(nx, ny)) - centre;
      if (delta == 0) ++equal;
      if (delta < darkest) darkest = delta, dark_x = nx, dark_y = ny;
      if (delta > brightest) brightest = delta, bright_x = nx, bright_y = ny;
    }
  if (dark_x < 0 || bright_x < 0 || equal > 2) return false;
  return (inFlatRegion(image, dark_x, dark_y) && inFlatRegion(other, dark_x, dark_y)) ||
         (inFlatRegion(image, bright_x, bright_y) && inFlatRegion(other, bright_x, bright_y));
}

}  // namespace

bool maskExcludes(const std::uint8_t* mask_pixel) {
  return brightness(mask_pixel) < 127.5;
}

ImageDiff diffImages(const Image& a, const Image& b, double threshold, const Image* mask) {
  ImageDiff result;
  result.visual = Image{a.width, a.height, std::vector<std::uint8_t>(a.rgba.size())};
  const double limit = threshold * threshold;  // distances compared as normalised squares
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      std::uint8_t* out = &result.visual.rgba[4 * (size_t(y) * a.width + x)];
      if (mask && maskExcludes(mask->pixel(x, y))) {
        out[0] = 170, out[1] = 200, out[2] = 240, out[3] = 255;
        continue;
      }
      ++result.compared;
      const double distance = yiqDistance(a.pixel(x, y), b.pixel(x, y)) / kMaxDistance;
      result.largest = std::max(result.largest, std::sqrt(distance));
      if (distance > limit) {
        const bool edge = looksAntiAliased(a, b, x, y) || looksAntiAliased(b, a, x, y);
        (edge ? result.anti_aliased : result.differing) += 1;
        out[0] = 255, out[1] = edge ? 220 : 0, out[2] = 0, out[3] = 255;
      } else {
        const auto v = std::uint8_t(200 + brightness(a.pixel(x, y)) * 55 / 255);
        out[0] = out[1] = out[2] = v, out[3] = 255;
      }
    }
  result.share = result.compared > 0 ? double(result.differing) / double(result.compared) : 0;
  return result;
}

}  // namespace snowsim
