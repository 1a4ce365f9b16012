#pragma once
// `--json` output of the sirupp commands: built with nlohmann::json (nlohmann-json3-dev), keys in
// the order written, printed on one line. Shapes: docs/json.md.

#include <nlohmann/json.hpp>
#include <ostream>
#include <string>

namespace sirupp::tools {

using Json = nlohmann::ordered_json;

// One JSON document on one line. Non-finite numbers become null (JSON has no NaN or infinity);
// bytes that are not UTF-8 become U+FFFD instead of making the output invalid.
inline void WriteJsonLine(std::ostream& out, const Json& document) {
  out << document.dump(-1, ' ', false, Json::error_handler_t::replace) << "\n";
}

}  // namespace sirupp::tools
