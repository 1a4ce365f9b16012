#include "runtime/args.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>

#include "core/errors.hpp"

namespace sirupp::runtime {

namespace {
bool IsFlag(const std::string& text) {
  return text.size() > 2 && text[0] == '-' && text[1] == '-' &&
         std::isalpha(static_cast<unsigned char>(text[2]));
}
}  // namespace

double ParseNumberArg(const std::string& text, const std::string& what) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value)) {
    throw core::UsageError(what + ": '" + text + "' is not a finite number");
  }
  return value;
}

Args::Args(const std::vector<std::string>& args, const std::string& command,
           const std::map<std::string, std::string>& allowed)
    : command_(command), allowed_(allowed) {
  std::string current;
  for (const std::string& arg : args) {
    if (IsFlag(arg)) {
      current = arg.substr(2);
      if (allowed_.count(current) == 0) {
        std::string list;
        for (const auto& [flag, what] : allowed_) list += (list.empty() ? "--" : ", --") + flag;
        throw core::UsageError(command_ + ": unknown option '" + arg + "'; allowed: " + list);
      }
      if (!values_.emplace(current, std::vector<std::string>{}).second) {
        throw core::UsageError(command_ + ": option '" + arg + "' given twice");
      }
    } else if (current.empty()) {
      throw core::UsageError(command_ + ": unexpected argument '" + arg + "' before any option");
    } else {
      values_[current].push_back(arg);
    }
  }
}

const std::vector<std::string>& Args::Values(const std::string& flag, int count) const {
  const auto found = values_.find(flag);
  const std::string describe = "--" + flag + " " + allowed_.at(flag);
  if (found == values_.end()) throw core::UsageError(command_ + ": missing " + describe);
  const int got = static_cast<int>(found->second.size());
  if ((count >= 0 && got != count) || (count < 0 && got == 0)) {
    throw core::UsageError(command_ + ": " + describe + " takes " +
                           (count >= 0 ? std::to_string(count) : std::string("one or more")) +
                           " value(s), got " + std::to_string(got));
  }
  return found->second;
}

std::string Args::String(const std::string& flag) const { return Values(flag, 1)[0]; }

std::vector<double> Args::Numbers(const std::string& flag, int count) const {
  std::vector<double> numbers;
  const std::vector<std::string>& texts = Values(flag, count);
  for (size_t i = 0; i < texts.size(); ++i) {
    numbers.push_back(
        ParseNumberArg(texts[i], command_ + " --" + flag + " value " + std::to_string(i + 1)));
  }
  return numbers;
}

bool Args::Switch(const std::string& flag) const {
  const auto found = values_.find(flag);
  if (found == values_.end()) return false;
  if (!found->second.empty()) {
    throw core::UsageError(command_ + ": --" + flag + " takes no value, got '" + found->second[0] +
                           "'");
  }
  return true;
}

}  // namespace sirupp::runtime
