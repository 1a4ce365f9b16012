#pragma once
// Helpers shared by the unit tests.

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace sirupp::testing {

// A message through the LCM wire format and back, as if it had crossed the network.

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

// The what() of the Error that body() throws, or "" if it throws none.
template <class Error, class Body>
std::string ErrorText(Body body) {
  try {
    body();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

}  // namespace sirupp::testing
