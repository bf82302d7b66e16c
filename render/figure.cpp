#include "render/figure.h"

#include <algorithm>

#include <stb/stb_easy_font.h>

namespace snowsim {

namespace {
constexpr int kGap = 8;
constexpr int kLabelHeight = 34;
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

Image composeFigure(const std::vector<std::vector<Panel>>& rows) {
  int columns = 0;
  for (const auto& row : rows) columns = std::max<int>(columns, row.size());
  const int panel_w = rows.at(0).at(0).image.width, panel_h = rows[0][0].image.height;
  const int cell_h = panel_h + kLabelHeight;
  Image figure;
  figure.width = kGap + columns * (panel_w + kGap);
  figure.height = kGap + static_cast<int>(rows.size()) * (cell_h + kGap);
  figure.rgba.resize(static_cast<size_t>(figure.width) * figure.height * 4);
  for (size_t i = 0; i < figure.rgba.size(); i += 4) std::copy_n(kPaper, 4, &figure.rgba[i]);
  for (size_t r = 0; r < rows.size(); ++r)
    for (size_t c = 0; c < rows[r].size(); ++c) {
      const Panel& panel = rows[r][c];
      const int x = kGap + static_cast<int>(c) * (panel_w + kGap);
      const int y = kGap + static_cast<int>(r) * (cell_h + kGap);
      for (int py = 0; py < panel_h; ++py)
        std::copy_n(&panel.image.rgba[static_cast<size_t>(py) * panel_w * 4], panel_w * 4,
                    &figure.rgba[(static_cast<size_t>(y + py) * figure.width + x) * 4]);
      const int text_width = stb_easy_font_width(const_cast<char*>(panel.label.c_str())) * 2;
      drawText(figure, x + (panel_w - text_width) / 2, y + panel_h + 8, panel.label, 2);
    }
  return figure;
}

}  // namespace snowsim
