#include "render/figure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <stb/stb_easy_font.h>

#include "render/colour.h"

namespace snowsim {

namespace {
constexpr int kGap = 8;
constexpr int kLabelHeight = 34;
constexpr int kTitleHeight = 44;
constexpr int kBarHeight = 64;  // the bar, its end values and its label
constexpr int kBarThickness = 18;
constexpr std::uint8_t kPaper[4] = {255, 255, 255, 255};
}  // namespace

void drawText(Image& image, int x, int y, const std::string& text, int scale) {
  // stb_easy_font emits axis-aligned quads, 4 vertices of 16 bytes each (x, y, z, colour).
  static char buffer[64 * 1024];
  std::string copy = text;
  const int quads = stb_easy_font_print(0, 0, copy.data(), nullptr, buffer, sizeof buffer);
  for (int q = 0; q < quads; ++q) {
    const float* v0 = reinterpret_cast<const float*>(buffer + q * 64);
    const float* v2 = reinterpret_cast<const float*>(buffer + q * 64 + 32);
    const int x0 = x + static_cast<int>(v0[0]) * scale, y0 = y + static_cast<int>(v0[1]) * scale;
    const int x1 = x + static_cast<int>(v2[0]) * scale, y1 = y + static_cast<int>(v2[1]) * scale;
    for (int py = std::max(0, y0); py < std::min(image.height, y1); ++py)
      for (int px = std::max(0, x0); px < std::min(image.width, x1); ++px) {
        std::uint8_t* p = &image.rgba[4 * (static_cast<size_t>(py) * image.width + px)];
        p[0] = p[1] = p[2] = 20;
        p[3] = 255;
      }
  }
}

int textWidth(const std::string& text, int scale) {
  return stb_easy_font_width(const_cast<char*>(text.c_str())) * scale;
}

namespace {

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

// The bar centred in the band whose top is at y.
void drawColourBar(Image& figure, int y, const ColourBar& bar) {
  const int width = std::min(480, figure.width - 2 * 40), x0 = (figure.width - width) / 2;
  for (int px = 0; px < width; ++px) {
    const glm::vec3 c = colourMap(bar.plastic ? ColorBy::Plastic : ColorBy::Density,
                                  width > 1 ? float(px) / float(width - 1) : 0.f);
    const std::uint8_t rgba[4] = {static_cast<std::uint8_t>(std::lround(255 * c.r)),
                                  static_cast<std::uint8_t>(std::lround(255 * c.g)),
                                  static_cast<std::uint8_t>(std::lround(255 * c.b)), 255};
    for (int py = y; py < y + kBarThickness; ++py)
      std::copy_n(rgba, 4, &figure.rgba[4 * (static_cast<size_t>(py) * figure.width + x0 + px)]);
  }
  const int text_y = y + kBarThickness + 6;
  drawText(figure, x0, text_y, number(bar.low), 2);
  const std::string high = number(bar.high);
  drawText(figure, x0 + width - textWidth(high, 2), text_y, high, 2);
  if (bar.plastic) drawText(figure, x0 + (width - textWidth("1", 2)) / 2, text_y, "1", 2);
  drawText(figure, (figure.width - textWidth(bar.label, 2)) / 2, text_y + 18, bar.label, 2);
}

}  // namespace

Image composeFigure(const std::vector<std::vector<Panel>>& rows, const std::string& title,
                    const std::optional<ColourBar>& bar) {
  int columns = 0;
  for (const auto& row : rows) columns = std::max<int>(columns, row.size());
  const int panel_w = rows.at(0).at(0).image.width, panel_h = rows[0][0].image.height;
  const int cell_h = panel_h + kLabelHeight;
  const int top = title.empty() ? 0 : kTitleHeight;
  Image figure;
  figure.width = kGap + columns * (panel_w + kGap);
  figure.height =
      top + kGap + static_cast<int>(rows.size()) * (cell_h + kGap) + (bar ? kBarHeight : 0);
  figure.rgba.resize(static_cast<size_t>(figure.width) * figure.height * 4);
  for (size_t i = 0; i < figure.rgba.size(); i += 4) std::copy_n(kPaper, 4, &figure.rgba[i]);
  for (size_t r = 0; r < rows.size(); ++r)
    for (size_t c = 0; c < rows[r].size(); ++c) {
      const Panel& panel = rows[r][c];
      const int x = kGap + static_cast<int>(c) * (panel_w + kGap);
      const int y = top + kGap + static_cast<int>(r) * (cell_h + kGap);
      for (int py = 0; py < panel_h; ++py)
        std::copy_n(&panel.image.rgba[static_cast<size_t>(py) * panel_w * 4], panel_w * 4,
                    &figure.rgba[(static_cast<size_t>(y + py) * figure.width + x) * 4]);
      drawText(figure, x + (panel_w - textWidth(panel.label, 2)) / 2, y + panel_h + 8, panel.label,
               2);
    }
  if (!title.empty()) {
    // Large enough to read, small enough to fit the strip.
    const int scale = std::clamp(figure.width / std::max(1, textWidth(title, 1)), 1, 3);
    drawText(figure, std::max(kGap, (figure.width - textWidth(title, scale)) / 2), 12, title,
             scale);
  }
  if (bar) drawColourBar(figure, figure.height - kBarHeight, *bar);
  return figure;
}

}  // namespace snowsim
