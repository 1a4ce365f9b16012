#pragma once
// The look of every generated --help text: "usage:" first, then the prose, the arguments, the
// flags and the subcommands, every line wrapped once to HelpWidth() columns. Used by runtime::Args
// and by the `sirupp` command tree (tools/cli.cpp), which builds its CLI::App directly.

#include <CLI/CLI.hpp>
#include <string>

namespace sirupp::runtime {

// Sets the formatter, --help/-h and --version (printing "NAME VERSION") on `app`.
void ConfigureApp(CLI::App& app, const std::string& version_text);

// The width help texts are wrapped to: the terminal's width when standard output is one (else
// $COLUMNS when set), at least 40 and at most 80 columns; 80 when neither is known.
size_t HelpWidth();

// `text` reflowed (Reflow) and filled to lines of at most `width` characters (a longer word
// stays whole).
std::string Wrap(const std::string& text, size_t width);
// Hand-wrapped prose joined into paragraphs: a line break stays after a sentence or a colon, where
// the indentation changes, before a flag and around a row of a hand-made table ("  name   text");
// indented prose joins like any other.
std::string Reflow(const std::string& text);
// Each line filled at spaces to at most `width` characters; leading indentation kept, and an
// indented line that fits is kept as written (a row of a hand-made table).
std::string Fill(const std::string& text, size_t width);

}  // namespace sirupp::runtime
