#pragma once
// The small file steps of the class's stores (controller submissions, notebook submissions).

#include <string>

namespace sirupp::classroom {

// The file's bytes; "" when it cannot be read.
std::string ReadAll(const std::string& file);
// Written whole or not at all (a reader never sees half a file); mode 644. Throws on failure.
void WriteAtomically(const std::string& file, const std::string& text);
// The local time as "YYYY-mm-dd HH:MM:SS" (the pages' submitted_at).
std::string WallClock();

}  // namespace sirupp::classroom
