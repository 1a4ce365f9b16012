#include "core/errors.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

namespace sirupp::core {

std::string SourceLocation::ToString() const {
  std::string text = file.empty() ? std::string("<input>") : file;
  if (line > 0) {
    text += ":" + std::to_string(line);
    if (column > 0) text += ":" + std::to_string(column);
  }
  return text;
}

namespace {
std::string JoinConfig(const SourceLocation& where, const std::string& key_path,
                       const std::string& problem) {
  std::string text = where.ToString() + ": ";
  if (!key_path.empty()) text += key_path + ": ";
  return text + problem;
}
}  // namespace

ConfigError::ConfigError(SourceLocation where, std::string key_path, std::string problem)
    : std::runtime_error(JoinConfig(where, key_path, problem)),
      where_(std::move(where)),
      key_path_(std::move(key_path)),
      problem_(std::move(problem)) {}

MessageError::MessageError(std::string channel, std::string field_path, std::string problem)
    : std::runtime_error("channel " + channel + ": " +
                         (field_path.empty() ? "" : field_path + ": ") + problem),
      channel_(std::move(channel)),
      field_path_(std::move(field_path)) {}

std::string FormatNumber(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[40];
  for (int precision = 6; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof buffer, "%.*g", precision, value);
    if (std::strtod(buffer, nullptr) == value) break;
  }
  return buffer;
}

std::string FormatApprox(double value) {
  if (!std::isfinite(value)) return FormatNumber(value);
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.6g", value);
  return buffer;
}

}  // namespace sirupp::core
