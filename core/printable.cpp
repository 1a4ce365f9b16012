#include "core/printable.hpp"

#include <cstdint>

namespace sirupp::core {

namespace {

// The length of the valid UTF-8 sequence at text[i] (1 to 4), or 0 if the bytes there are not one
// (a stray continuation byte, an overlong form, a surrogate, a value above U+10FFFF, a cut
// sequence). Sets `code` to the code point.
size_t Utf8Length(std::string_view text, size_t i, uint32_t& code) {
  const auto byte = [&](size_t k) { return static_cast<uint8_t>(text[k]); };
  const uint8_t lead = byte(i);
  size_t length = 0;
  uint32_t min = 0;
  if (lead < 0x80) {
    code = lead;
    return 1;
  }
  if ((lead & 0xE0) == 0xC0) {
    length = 2;
    min = 0x80;
    code = lead & 0x1F;
  } else if ((lead & 0xF0) == 0xE0) {
    length = 3;
    min = 0x800;
    code = lead & 0x0F;
  } else if ((lead & 0xF8) == 0xF0) {
    length = 4;
    min = 0x10000;
    code = lead & 0x07;
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  for (size_t k = 1; k < length; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
    code = (code << 6) | (byte(i + k) & 0x3F);
  }
  if (code < min || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return 0;
  return length;
}

// Control characters, and invisible ones that make a line read differently from what it holds.
bool IsControl(uint32_t code) {
  return code < 0x20 || code == 0x7F || (code >= 0x80 && code <= 0x9F) ||  // C0, DEL, C1
         (code >= 0x200B && code <= 0x200F) ||  // zero-width spaces and joiners, direction marks
         (code >= 0x2028 && code <= 0x202E) ||  // line and paragraph separators, bidi embeddings
         (code >= 0x2060 && code <= 0x2069) ||  // word joiner, invisible operators, bidi isolates
         code == 0xFEFF;                        // byte-order mark (zero-width no-break space)
}

void AppendEscaped(std::string& out, std::string_view bytes) {
  static const char kHex[] = "0123456789ABCDEF";
  for (const char c : bytes) {
    const auto b = static_cast<uint8_t>(c);
    out += "\\x";
    out += kHex[b >> 4];
    out += kHex[b & 0x0F];
  }
}

}  // namespace

std::string Printable(std::string_view text, size_t max_chars) {
  std::string out;
  out.reserve(text.size());
  size_t chars = 0;
  size_t i = 0;
  while (i < text.size()) {
    if (max_chars > 0 && chars == max_chars) {
      out += "...";
      break;
    }
    uint32_t code = 0;
    const size_t length = Utf8Length(text, i, code);
    if (length == 0) {
      AppendEscaped(out, text.substr(i, 1));
      ++i;
    } else {
      if (IsControl(code)) {
        AppendEscaped(out, text.substr(i, length));
      } else {
        out.append(text.substr(i, length));
      }
      i += length;
    }
    ++chars;
  }
  return out;
}

bool IsPrintable(std::string_view text) {
  size_t i = 0;
  while (i < text.size()) {
    uint32_t code = 0;
    const size_t length = Utf8Length(text, i, code);
    if (length == 0 || IsControl(code)) return false;
    i += length;
  }
  return true;
}

}  // namespace sirupp::core
