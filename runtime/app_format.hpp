#pragma once
// The look of every generated --help text: "usage:" first, then the prose, the arguments, the
// flags and the subcommands, every line wrapped to 80 columns. Used by runtime::Args and by the
// `sirupp` command tree (tools/cli.cpp), which builds its CLI::App directly.

#include <CLI/CLI.hpp>
#include <string>

namespace sirupp::runtime {

// Sets the formatter, --help/-h and --version (printing "NAME VERSION") on `app`.
void ConfigureApp(CLI::App& app, const std::string& version_text);

// `text` wrapped at spaces to lines of at most `width` characters; existing line ends are kept.
std::string Wrap(const std::string& text, size_t width);

}  // namespace sirupp::runtime
