#include "runtime/args.hpp"

#include <cmath>
#include <cstdlib>
#include <utility>

#include "core/errors.hpp"
#include "runtime/app_format.hpp"

#ifndef SIRUPP_VERSION
#error "SIRUPP_VERSION must be defined by the build (CMake's project version)"
#endif

namespace sirupp::runtime {

namespace {

constexpr double kNoMaximum = static_cast<double>(Flag::kMany);

// "-1.5" and "-3" are values; "-x" and "--x" are flags.
bool LooksLikeFlag(const std::string& text) {
  if (text.size() < 2 || text[0] != '-') return false;
  char* end = nullptr;
  std::strtod(text.c_str(), &end);
  return end != text.c_str() + text.size();
}

// "sirupp-sim" stays; a command of the CLI ("move joints") is shown as "sirupp move joints".
std::string UsageName(const std::string& command) {
  return command.rfind("sirupp", 0) == 0 ? command : "sirupp " + command;
}

std::string ValueText(const Flag& flag) {
  if (flag.count() < 0) return flag.value_name() + " ...";
  if (flag.count() > 1) return flag.value_name() + " x" + std::to_string(flag.count());
  return flag.value_name();
}

}  // namespace

const char* Version() { return SIRUPP_VERSION; }

double ParseNumberArg(const std::string& text, const std::string& what) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value)) {
    throw core::UsageError(what + ": '" + text + "' is not a finite number");
  }
  return value;
}

Flag::Flag(std::string name, std::string help) : name_(std::move(name)), help_(std::move(help)) {}

Flag& Flag::Takes(std::string value_name, int count) {
  value_name_ = std::move(value_name);
  count_ = count;
  counted_ = true;
  return *this;
}

Flag& Flag::Switch() {
  switch_ = true;
  counted_ = true;
  count_ = 0;
  return *this;
}

Flag& Flag::Short(char letter) {
  short_ = letter;
  return *this;
}

Flag& Flag::Positional(std::string value_name, int count) {
  positional_ = true;
  value_name_ = std::move(value_name);
  count_ = count;
  counted_ = count != 0;
  return *this;
}

Flag& Flag::Range(double min, double max) {
  check_ = Check::kRange;
  min_ = min;
  max_ = max;
  return *this;
}

Flag& Flag::Above(double min, double max) {
  check_ = Check::kAbove;
  min_ = min;
  max_ = max;
  return *this;
}

Flag& Flag::AtLeast(double min) {
  check_ = Check::kAtLeast;
  min_ = min;
  max_ = 1e300;
  return *this;
}

Flag& Flag::Integer(long min, long max) {
  check_ = Check::kInteger;
  min_ = static_cast<double>(min);
  max_ = static_cast<double>(max);
  return *this;
}

Flag& Flag::OneOf(std::vector<std::string> choices) {
  check_ = Check::kChoice;
  choices_ = std::move(choices);
  return *this;
}

std::string Flag::Allowed() const {
  switch (check_) {
    case Check::kNone:
      return "";
    case Check::kRange:
      return "a number from " + core::FormatNumber(min_) + " to " + core::FormatNumber(max_);
    case Check::kAbove:
      return "a number > " + core::FormatNumber(min_) +
             (max_ < 1e300 ? " and <= " + core::FormatNumber(max_) : "");
    case Check::kAtLeast:
      return "a number >= " + core::FormatNumber(min_);
    case Check::kInteger:
      if (max_ >= kNoMaximum) return "a whole number >= " + std::to_string(static_cast<long>(min_));
      return "a whole number from " + std::to_string(static_cast<long>(min_)) + " to " +
             std::to_string(static_cast<long>(max_));
    case Check::kChoice: {
      std::string list;
      for (const std::string& choice : choices_) list += (list.empty() ? "" : ", ") + choice;
      return list;
    }
  }
  return "";
}

std::string Flag::Validate(const std::string& text) const {
  bool ok = true;
  if (check_ == Check::kChoice) {
    ok = false;
    for (const std::string& choice : choices_) ok = ok || choice == text;
  } else if (check_ != Check::kNone) {
    char* end = nullptr;
    const double value = std::strtod(text.c_str(), &end);
    ok = !text.empty() && end == text.c_str() + text.size() && std::isfinite(value);
    if (ok && check_ == Check::kAbove) ok = value > min_ && value <= max_;
    if (ok && check_ != Check::kAbove) ok = value >= min_ && value <= max_;
    if (ok && check_ == Check::kInteger) ok = value == std::floor(value);
  }
  return ok ? "" : "'" + text + "' is not allowed; allowed: " + Allowed();
}

Args::Args(const std::vector<std::string>& args, const std::string& command,
           const std::vector<Flag>& flags, const std::string& about)
    : command_(command) {
  CLI::App app(about, UsageName(command));
  ConfigureApp(app, UsageName(command) + " " + Version());
  app.allow_extras();
  std::vector<std::pair<const Flag*, CLI::Option*>> options;
  for (const Flag& declared : flags) {
    const Flag& flag = flags_.emplace(declared.name(), declared).first->second;
    // (The help is set with description(): add_option(name, std::string&) would bind the string
    // as the option's result.)
    std::string help = flag.help();
    if (!flag.Allowed().empty()) help += " (" + flag.Allowed() + ")";
    CLI::Option* option = nullptr;
    const std::string names =
        (flag.short_ != 0 ? std::string("-") + flag.short_ + "," : std::string()) + "--" +
        flag.name();
    if (flag.is_switch()) {
      option = app.add_flag(names)->description(help);
    } else {
      // Every count is checked below, so the messages name the flag and the count the same way
      // for every flag.
      option = app.add_option(flag.positional() ? flag.name() : names)->description(help);
      // A declared count of one or more is CLI11's (the next words are positionals); other
      // counts are checked below, so the messages name the flag and the count the same way.
      if (flag.count() > 0 && !flag.positional()) {
        option->expected(flag.count());
      } else {
        option->expected(0, CLI::detail::expected_max_vector_size)->allow_extra_args();
      }
      option->type_name(flag.value_name());
      option->option_text(flag.positional()           ? ""
                          : flag.value_name().empty() ? "VALUE ..."
                                                      : ValueText(flag));
      if (flag.positional()) option->type_name(flag.value_name());
      if (!flag.Allowed().empty()) {
        option->check(CLI::Validator([&flag](std::string& text) { return flag.Validate(text); }, "",
                                     flag.name()));
      }
    }
    options.emplace_back(&flag, option);
  }
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes them reversed
  try {
    app.parse(reversed);
  } catch (const CLI::CallForHelp&) {
    throw HelpRequested{app.help()};
  } catch (const CLI::CallForVersion&) {
    throw HelpRequested{UsageName(command) + " " + Version() + "\n"};
  } catch (const CLI::ParseError& error) {
    throw core::UsageError(command_ + ": " + error.what());
  }
  const std::vector<std::string> extra = app.remaining();
  for (const std::string& arg : extra) {
    if (!LooksLikeFlag(arg)) continue;
    std::string list;
    for (const auto& [name, flag] : flags_) {
      if (!flag.positional()) list += (list.empty() ? "--" : ", --") + name;
    }
    throw core::UsageError(command_ + ": unknown option '" + arg + "'; allowed: " + list);
  }
  if (!extra.empty()) {
    throw core::UsageError(command_ + ": unexpected argument '" + extra.front() + "'");
  }
  for (const auto& [flag, option] : options) {
    if (option->count() == 0) continue;
    std::vector<std::string> values = option->results();
    if (flag->is_switch()) {
      // CLI11 records a plain switch as "true"; `--switch=VALUE` keeps VALUE.
      if (values.size() == 1 && values[0] == "true") values.clear();
    } else if (values.size() == 1 && values[0].empty() && !flag->positional() &&
               flag->count() <= 0) {
      values.clear();  // --flag without a value
    }
    values_[flag->name()] = values;
  }
  for (const Flag& flag : flags) {
    if (flag.is_switch()) {
      Switch(flag.name());
    } else if (flag.counted_ && (Has(flag.name()) || flag.positional())) {
      Values(flag.name(), flag.count());
    }
  }
}

const std::vector<std::string>& Args::Values(const std::string& flag, int count) const {
  const auto found = values_.find(flag);
  const Flag& declared = flags_.at(flag);
  const std::string describe =
      declared.positional()
          ? declared.value_name()
          : "--" + flag + " " +
                (declared.value_name().empty() ? declared.help() : ValueText(declared));
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

long Args::Integer(const std::string& flag, long fallback) const {
  if (!Has(flag)) return fallback;
  return static_cast<long>(Numbers(flag, 1)[0]);  // whole: checked by the declaration
}

double Args::Number(const std::string& flag, double fallback) const {
  return Has(flag) ? Numbers(flag, 1)[0] : fallback;
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
