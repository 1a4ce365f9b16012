#include "runtime/app_format.hpp"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <sstream>

namespace sirupp::runtime {
namespace {

constexpr size_t kColumn = 26;  // flag names; descriptions start here (on 60 columns or more)

// Where the text of a table row starts: after its first gap of two or more spaces past the
// indentation ("  --rate HZ     text"), else after the indentation.
size_t TextColumn(const std::string& line) {
  const size_t indent = std::min(line.find_first_not_of(' '), line.size());
  const size_t gap = line.find("  ", indent);
  const size_t text =
      gap == std::string::npos ? std::string::npos : line.find_first_not_of(' ', gap);
  return text == std::string::npos ? indent : text;
}

class Formatter : public CLI::Formatter {
 public:
  Formatter() : width_(HelpWidth()), column_(width_ >= 60 ? kColumn : width_ / 3) {
    column_width(column_);
    label("Usage", "usage");
    label("OPTIONS", "options");
    label("SUBCOMMAND", "COMMAND");
    label("SUBCOMMANDS", "COMMAND");
    label("Subcommands", "Commands");
  }

  std::string make_help(const CLI::App* app, std::string name,
                        CLI::AppFormatMode mode) const override {
    if (mode == CLI::AppFormatMode::Sub) return make_expanded(app);
    std::ostringstream out;
    out << make_usage(app, name) << make_description(app) << make_positionals(app)
        << make_groups(app, mode) << make_subcommands(app, mode);
    const std::string footer = make_footer(app);
    if (!footer.empty()) out << "\n" << footer;
    return out.str();
  }

  std::string make_description(const CLI::App* app) const override {
    const std::string description = app->get_description();
    return description.empty() ? "" : Wrap(description, width_) + "\n";
  }

  std::string make_footer(const CLI::App* app) const override {
    const std::string footer = app->get_footer();
    return footer.empty() ? "" : Wrap(footer, width_) + "\n";
  }

  std::string make_option_desc(const CLI::Option* option) const override {
    return Wrap(option->get_description(), width_ - column_);
  }

  std::string make_subcommand(const CLI::App* sub) const override {
    std::ostringstream out;
    CLI::detail::format_help(out, sub->get_name(), Wrap(sub->get_description(), width_ - column_),
                             column_);
    return out.str();
  }

 private:
  size_t width_;
  size_t column_;
};

}  // namespace

size_t HelpWidth() {
  long columns = 0;
  winsize size{};
  if (isatty(STDOUT_FILENO) == 1 && ioctl(STDOUT_FILENO, TIOCGWINSZ, &size) == 0) {
    columns = size.ws_col;
  } else if (const char* variable = std::getenv("COLUMNS")) {
    columns = std::strtol(variable, nullptr, 10);
  }
  if (columns <= 0) return 80;
  return static_cast<size_t>(std::clamp(columns, 40L, 80L));
}

std::string Wrap(const std::string& text, size_t width) { return Fill(Reflow(text), width); }

std::string Reflow(const std::string& text) {
  // A line break stays where the indentation changes, before a flag ("--x") or an item
  // ("pose: ..."), after a sentence or a colon, and around the rows of a hand-made table (indented
  // lines); elsewhere the hand-made break is a space. A row's continuation (a line indented to
  // the row's text column) joins its row.
  std::string flowed;
  std::istringstream lines(text);
  std::string line;
  std::string previous;
  size_t previous_indent = 0;
  bool first = true;
  while (std::getline(lines, line)) {
    const size_t indent = std::min(line.find_first_not_of(' '), line.size());
    const std::string body = line.substr(indent);
    const size_t colon = body.find(": ");
    const bool item = colon != std::string::npos && colon < 14 && body.find(' ') > colon;
    const bool continuation = !first && previous_indent > 0 && indent > previous_indent &&
                              indent == TextColumn(previous) && !body.empty();
    // A row of a hand-made table ("  name   text") stays a line of its own, and so does the line
    // after it; an indented line of prose joins the line before it at the same indentation.
    const bool row = TextColumn(line) > indent;
    const bool after_row = !first && TextColumn(previous) > previous_indent;
    const bool keep =
        !continuation && (first || previous.empty() || body.empty() || row || after_row ||
                          indent != previous_indent || body.rfind("--", 0) == 0 || item ||
                          previous.back() == '.' || previous.back() == ':');
    if (!first) flowed += keep ? "\n" : " ";
    flowed += keep ? line : body;
    previous = keep ? line : previous + " " + body;
    if (keep) previous_indent = indent;
    first = false;
  }
  return flowed;
}

std::string Fill(const std::string& text, size_t width) {
  std::string wrapped;
  std::istringstream lines(text);
  std::string line;
  bool first_line = true;
  while (std::getline(lines, line)) {
    if (!first_line) wrapped += "\n";
    first_line = false;
    const size_t indent_end = line.find_first_not_of(' ');
    const std::string indent = line.substr(0, indent_end == std::string::npos ? 0 : indent_end);
    if (!indent.empty()) {
      // A row of a hand-made table keeps its spacing; a long one is broken at spaces, the rest
      // under the row's text column.
      const size_t column = TextColumn(line) + 16 < width ? TextColumn(line) : indent.size();
      std::string rest = line;
      while (rest.size() > width) {
        const size_t cut = rest.rfind(' ', width);
        if (cut == std::string::npos || cut <= column) break;
        wrapped += rest.substr(0, rest.find_last_not_of(' ', cut) + 1) + "\n";
        rest = std::string(column, ' ') + rest.substr(rest.find_first_not_of(' ', cut));
      }
      wrapped += rest;
      continue;
    }
    // Prose is filled word by word.
    std::istringstream words(line);
    std::string word;
    std::string current;
    while (words >> word) {
      if (!current.empty() && current.size() + 1 + word.size() > width) {
        wrapped += current + "\n";
        current.clear();
      }
      current += (current.empty() ? "" : " ") + word;
    }
    wrapped += current;
  }
  return wrapped;
}

void ConfigureApp(CLI::App& app, const std::string& version_text) {
  app.formatter(std::make_shared<Formatter>());
  app.set_help_flag("-h,--help", "print this help and exit");
  app.set_version_flag("--version", version_text, "print the version and exit");
}

}  // namespace sirupp::runtime
