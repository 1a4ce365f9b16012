#pragma once
// Test helper: a message through the LCM wire format and back, as if it had crossed the network.

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace sirupp::testing {

template <class Msg>
Msg ThroughTheWire(const Msg& message) {
  std::vector<uint8_t> buffer(static_cast<size_t>(message.getEncodedSize()));
  EXPECT_EQ(message.encode(buffer.data(), 0, static_cast<int>(buffer.size())),
            static_cast<int>(buffer.size()));
  Msg decoded;
  EXPECT_EQ(decoded.decode(buffer.data(), 0, static_cast<int>(buffer.size())),
            static_cast<int>(buffer.size()));
  return decoded;
}

}  // namespace sirupp::testing
