#pragma once
// The command line of every SIRUPP process and `sirupp` command, parsed by CLI11 (libcli11-dev).
// Each flag is declared once, as a Flag: its name, help, value names and count, and its checks
// (range, whole number, choices). The same declaration feeds the parser, the generated --help text
// and the error messages. Values run until the next `--name`; "-1.5" is a value, not a flag;
// `--name=value` works too. Unknown flags, missing or extra values, bad numbers and values outside
// the declared checks throw core::UsageError naming the command, the flag, the bad text and what
// is allowed. --help (-h) and --version throw HelpRequested with the text to print (exit 0).

#include <map>
#include <string>
#include <vector>

namespace sirupp::runtime {

// One flag (`--name`) or positional argument, declared once.
class Flag {
 public:
  // --name with any number of values, counted where they are read (Args::Values); `help` is shown
  // in --help and in count errors (e.g. "Q.. (one per joint)").
  Flag(std::string name, std::string help);

  // Takes `count` values (-1: one or more) shown in --help as `value_name`.
  Flag& Takes(std::string value_name, int count = 1);
  // A switch: no value.
  Flag& Switch();
  // Also -C (e.g. -j for --jobs).
  Flag& Short(char letter);
  // A positional argument (no "--"), read with Args::Values(name, ...): `count` values, -1 for one
  // or more, 0 for any number (none allowed).
  Flag& Positional(std::string value_name, int count = 1);
  // Every value a finite number in [min, max].
  Flag& Range(double min, double max);
  // Every value a finite number > min (and <= max).
  Flag& Above(double min, double max = 1e300);
  // Every value a finite number >= min.
  Flag& AtLeast(double min);
  // Every value a whole number in [min, max] (max kMany: no upper bound).
  static constexpr long kMany = 1000000000000000L;
  Flag& Integer(long min, long max);
  // Every value one of `choices`.
  Flag& OneOf(std::vector<std::string> choices);

  enum class Check { kNone, kRange, kAbove, kAtLeast, kInteger, kChoice };
  const std::string& name() const { return name_; }
  const std::string& help() const { return help_; }
  const std::string& value_name() const { return value_name_; }
  int count() const { return count_; }  // -1 one or more, 0 a switch or any number
  bool is_switch() const { return switch_; }
  bool positional() const { return positional_; }
  // The check as one phrase, e.g. "a whole number from 0 to 99" (empty: none).
  std::string Allowed() const;
  // Empty when `text` passes the check, else "'TEXT' is not allowed; allowed: ...".
  std::string Validate(const std::string& text) const;

 private:
  std::string name_;
  std::string help_;
  std::string value_name_;
  int count_ = 0;
  bool counted_ = false;  // the count was declared (Takes or Positional)
  bool switch_ = false;
  char short_ = 0;
  bool positional_ = false;
  Check check_ = Check::kNone;
  double min_ = 0;
  double max_ = 0;
  std::vector<std::string> choices_;
  friend class Args;
};

// --help and --version: the text for stdout; the program exits 0. Not a std::exception, so no
// handler for errors takes it for one.
struct HelpRequested {
  std::string text;
};

// The project version (CMake's project version), e.g. "0.1.0".
const char* Version();

class Args {
 public:
  // Parses `args` (after the program name, or after the command words). `command` names the
  // program or command in messages and in the usage line ("sirupp-sim", "move joints"); `about`
  // is the prose under the usage line in --help.
  Args(const std::vector<std::string>& args, const std::string& command,
       const std::vector<Flag>& flags, const std::string& about = "");

  bool Has(const std::string& flag) const { return values_.count(flag) != 0; }
  // The flag's values; throws if the flag is missing or has a count other than `count`
  // (count < 0: any number >= 1).
  const std::vector<std::string>& Values(const std::string& flag, int count) const;
  std::string String(const std::string& flag) const;
  std::vector<double> Numbers(const std::string& flag, int count) const;
  // A declared whole number (Flag::Integer), or `fallback` when absent.
  long Integer(const std::string& flag, long fallback) const;
  // A number flag, or `fallback` when absent.
  double Number(const std::string& flag, double fallback) const;
  // A flag without values (a switch): throws if values were given.
  bool Switch(const std::string& flag) const;

 private:
  std::string command_;
  std::map<std::string, Flag> flags_;
  std::map<std::string, std::vector<std::string>> values_;
};

// Parses a decimal number strictly (whole text, finite); throws UsageError naming `what`.
double ParseNumberArg(const std::string& text, const std::string& what);

}  // namespace sirupp::runtime
