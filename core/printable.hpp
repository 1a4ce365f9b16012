#pragma once
// User text (a plan line, a value from a file or a message) made safe to echo in a one-line error
// message: valid UTF-8 is kept as it is, while control characters (ASCII 0-31 and 127, C1
// controls, the Unicode line and paragraph separators, zero-width and byte-order marks and the
// bidirectional overrides, all of which can make a line read differently from what it holds) and
// bytes that are not valid UTF-8 are written
// as \xNN, one per byte. Every place that echoes user text in an error goes through Printable().

#include <cstddef>
#include <string>
#include <string_view>

namespace sirupp::core {

// `text` with the bytes above escaped. With max_chars > 0, at most that many characters of the
// text are kept (an escape counts as one), followed by "..." when it was cut.
std::string Printable(std::string_view text, size_t max_chars = 0);

// Whether `text` would print unchanged (no escape needed).
bool IsPrintable(std::string_view text);

}  // namespace sirupp::core
