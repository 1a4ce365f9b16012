#pragma once
// A small strict parser for `sirupp` subcommand arguments of the form `--name [values...]`.
// Values run until the next `--name`; "-1.5" is a value, not a flag. Unknown flags, missing or
// extra values and bad numbers throw core::UsageError naming the flag, the bad text and what is
// allowed.

#include <map>
#include <string>
#include <vector>

namespace sirupp::runtime {

class Args {
 public:
  // `allowed` maps each flag (without "--") to a short description used in error messages.
  Args(const std::vector<std::string>& args, const std::string& command,
       const std::map<std::string, std::string>& allowed);

  bool Has(const std::string& flag) const { return values_.count(flag) != 0; }
  // The flag's values; throws if the flag is missing or has a count other than `count`
  // (count < 0: any number >= 1).
  const std::vector<std::string>& Values(const std::string& flag, int count) const;
  std::string String(const std::string& flag) const;
  std::vector<double> Numbers(const std::string& flag, int count) const;
  // A flag without values (a switch): throws if values were given.
  bool Switch(const std::string& flag) const;

 private:
  std::string command_;
  std::map<std::string, std::string> allowed_;
  std::map<std::string, std::vector<std::string>> values_;
};

// Parses a decimal number strictly (whole text, finite); throws UsageError naming `what`.
double ParseNumberArg(const std::string& text, const std::string& what);

}  // namespace sirupp::runtime
