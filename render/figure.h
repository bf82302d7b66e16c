// Figure strips like the report's: rendered frames side by side, rows stacked, each panel
// labelled with its time underneath.
#pragma once

#include <string>
#include <vector>

#include "render/image.h"

namespace snowsim {

struct Panel {
  Image image;
  std::string label;  // written under the panel, e.g. "t = 0.20 s"
};

// Lays rows of equally sized panels out on one image with a gap between them.
Image composeFigure(const std::vector<std::vector<Panel>>& rows);

// Writes text into the image (stb_easy_font glyphs, scaled), top-left corner at (x, y).
void drawText(Image& image, int x, int y, const std::string& text, int scale);

}  // namespace snowsim
