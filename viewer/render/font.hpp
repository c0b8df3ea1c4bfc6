// A tiny built-in 5x7 bitmap font (upper case, digits, a little punctuation;
// lower case is drawn as upper case) for the stats overlay: no font files.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>
#include <vector>

namespace sculpt::view::font {

constexpr int kGlyphW = 5;
constexpr int kGlyphH = 7;
constexpr int kAdvance = 6;   // pixels per character, at scale 1
constexpr int kLine = 9;      // pixels per line, at scale 1

// Rows top to bottom, bit 4 = leftmost column. Unknown characters draw as '?'.
const std::array<std::uint8_t, kGlyphH>& glyph(char c);

// Lit pixels of `text` as rectangles (x, y, w, h in pixels, y down), the
// text's top-left at (x, y), each font pixel `scale` screen pixels wide.
struct Rect {
  float x, y, w, h;
};
void layout(std::string_view text, float x, float y, int scale, std::vector<Rect>& out);

}  // namespace sculpt::view::font
