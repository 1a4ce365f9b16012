#pragma once
// Who talks on a udpm bus: listens on a multicast group and port the way an LCM participant does
// (SO_REUSEADDR, the group joined on the default interface, so ttl=0 traffic of this machine is
// heard) and says what it heard. A private rig checks its port with it before it starts there:
// LCM binds its port shared, so a bind says nothing about another program already on it.

#include <string>

namespace sirupp::proc {

// The address every private rig uses (LCM's default group).
inline constexpr const char* kRigGroup = "239.255.76.67";

// What was heard on GROUP:PORT within `seconds`: "" when nothing, else a line naming the first
// datagram's sender and, for an LCM datagram, its channel ("a datagram on 239.255.76.67:7901 from
// 127.0.0.1:41234 (LCM channel HEARTBEAT)"); returns at the first datagram. Every SIRUPP process
// sends a heartbeat each second, so 1.2 s hears any of them. Throws std::runtime_error naming
// GROUP:PORT when the socket cannot be made.
std::string HeardOnUdpm(const std::string& group, int port, double seconds);

}  // namespace sirupp::proc
