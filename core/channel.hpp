#pragma once
// A channel name tied to its message type. `Channel<sirupp::arm_state_t>` holds a name (settable,
// so a lab layout or a rig prefix can change it) but its type is fixed in code: Bus::Publish,
// Bus::Subscribe and Latest refuse at compile time to pair it with another message type, and the
// channel table (core/channels.hpp) reads its type column from here.
//
// A Channel converts to `const std::string&`, so code that only needs the name (error texts,
// lcm-logger filters, listings) uses it as before.

#include <ostream>
#include <string>
#include <type_traits>
#include <utility>

namespace sirupp::core {

// What every Channel<Msg> has, without the type parameter: its name and its LCM type's name.
class ChannelName {
 public:
  const std::string& name() const { return name_; }
  // Fully qualified LCM type, e.g. "sirupp.arm_state_t".
  const std::string& lcm_type() const { return lcm_type_; }

  operator const std::string&() const { return name_; }  // NOLINT: implicit on purpose
  const char* c_str() const { return name_.c_str(); }
  // Renames the channel; its type stays.
  void SetName(std::string name) { name_ = std::move(name); }

  friend bool operator==(const ChannelName& a, const std::string& b) { return a.name_ == b; }
  friend bool operator==(const std::string& a, const ChannelName& b) { return a == b.name_; }
  friend bool operator!=(const ChannelName& a, const std::string& b) { return a.name_ != b; }
  friend std::string operator+(const std::string& a, const ChannelName& b) { return a + b.name_; }
  friend std::string operator+(const ChannelName& a, const std::string& b) { return a.name_ + b; }
  friend std::string operator+(const char* a, const ChannelName& b) { return a + b.name_; }
  friend std::string operator+(const ChannelName& a, const char* b) { return a.name_ + b; }
  friend std::ostream& operator<<(std::ostream& out, const ChannelName& c) {
    return out << c.name_;
  }

 protected:
  ChannelName(std::string name, std::string lcm_type)
      : name_(std::move(name)), lcm_type_(std::move(lcm_type)) {}

 private:
  std::string name_;
  std::string lcm_type_;
};

template <class Msg>
class Channel : public ChannelName {
 public:
  using Message = Msg;

  explicit Channel(std::string name)
      : ChannelName(std::move(name), std::string("sirupp.") + Msg::getTypeName()) {}
  // Renames the channel; its type stays.
  Channel& operator=(std::string name) {
    SetName(std::move(name));
    return *this;
  }
};

// For Bus and Latest: the compile-time check that a channel carries the message type used with it.
template <class Msg, class ChannelMsg>
constexpr void CheckChannelType() {
  static_assert(std::is_same_v<Msg, ChannelMsg>,
                "channel type mismatch: this Channel<> carries another message type");
}

}  // namespace sirupp::core
