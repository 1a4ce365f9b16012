#pragma once
// `sirupp model export`: a robot model as URDF or MJCF (core/model_export.hpp, docs/export.md).

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kModelExportAbout;

// args: what follows `sirupp model export`.
int RunModelExport(const std::vector<std::string>& args, std::ostream& out);

}  // namespace sirupp::tools
