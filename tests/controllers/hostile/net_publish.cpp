// Opens a UDP socket and publishes on another rig's LCM port (args: the port), to the LCM
// multicast group with ttl 0 (this machine only). The sandbox refuses the socket (seccomp) and
// has no network to send on (its own network namespace).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include "hostile.hpp"

namespace {

class NetPublish : public hostile::Hostile {
 public:
  explicit NetPublish(const std::string& args) : port_(std::stoi(args)) {}

 protected:
  void Act() override {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    if (fd < 0) throw std::runtime_error("socket(AF_INET, SOCK_DGRAM): " + hostile::Errno());
    const unsigned char ttl = 0;
    ::setsockopt(fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(port_));
    ::inet_pton(AF_INET, "239.255.76.67", &to.sin_addr);
    const char payload[] = "hostile net_publish";
    const ssize_t sent =
        ::sendto(fd, payload, sizeof payload, 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
    const std::string error = hostile::Errno();
    ::close(fd);
    if (sent < 0) {
      throw std::runtime_error("sendto 239.255.76.67:" + std::to_string(port_) + ": " + error);
    }
    throw std::runtime_error("sent " + std::to_string(sent) + " bytes to 239.255.76.67:" +
                             std::to_string(port_));
  }

 private:
  int port_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(NetPublish)
