// Figure strips like the report's: a title, rendered frames side by side, rows stacked, each
// panel labelled with its time underneath, and a colour bar with units when colour means a value.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "render/image.h"

namespace snowsim {

struct Panel {
  Image image;
  std::string label;  // written under the panel, e.g. "t = 0.20 s"
};

// The colour map's key: viridis from `low` (left) to `high` (right), labelled with the quantity;
// for J_P the cool-warm map over log J_P, with 1 marked in the middle (render/colour.h).
struct ColourBar {
  std::string label;  // the quantity and its unit, e.g. "speed (m/s)"
  double low = 0, high = 1;
  bool plastic = false;
};

// Lays rows of equally sized panels out on one image with a gap between them, the title (if any)
// above and the colour bar (if any) below.
Image composeFigure(const std::vector<std::vector<Panel>>& rows, const std::string& title = "",
                    const std::optional<ColourBar>& bar = std::nullopt);

// Writes text into the image (stb_easy_font glyphs, scaled), top-left corner at (x, y).
void drawText(Image& image, int x, int y, const std::string& text, int scale);

// The width in pixels of text drawn at the scale.
int textWidth(const std::string& text, int scale);

}  // namespace snowsim
