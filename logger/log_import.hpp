#pragma once
// An LCM log file (lcm-logger's output) turned into the same aligned tables as our data files: the
// report reads both alike. Events are taken in file order, the event timestamp standing in for the
// receive time, through the same Aligner the live logger uses, so a log of a run and the data file
// the logger wrote during it give the same rows.

#include <string>
#include <vector>

#include "core/channels.hpp"
#include "logger/aligner.hpp"
#include "logger/data_file.hpp"

namespace sirupp::logger {

struct ImportOptions {
  core::Channels channels;  // full names as in the log (prefix included)
  AlignerOptions aligner;
  bool split_per_plan = true;  // one table per movement set, as the logger's files
};

// Throws core::ConfigError naming the file, byte offset and event for a damaged log, a message on
// one of our channels that does not decode as its type, or inconsistent joint counts. A log with
// no joint-state stream at all is an error too (there would be nothing to report).
std::vector<RunTable> ImportLcmLog(const std::string& path, const ImportOptions& options);

}  // namespace sirupp::logger
