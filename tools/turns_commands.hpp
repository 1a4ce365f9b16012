#pragma once
// `sirupp turns serve`: the one real arm shared by turns on a lab PC with several rigs, without the
// class server (turns/turn_manager.hpp). The teacher types the queue's commands on its standard
// input; every event is printed.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

// Exit 0 after Ctrl-C or the end of its input (with the arm not in a turn or handover), 1 when
// the queue was stopped by a failed handover, 2 for bad arguments.
int RunTurns(const std::vector<std::string>& args, std::istream& in, std::ostream& out,
             std::ostream& err);

}  // namespace sirupp::tools
