// Tests of core/channels: names, prefix rule, and that the channel table agrees with the message
// files in lcmtypes/ and with docs/channels.md. Run from the source root (as CTest does).

#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/channels.hpp"

namespace sirupp::core {
namespace {

std::string ReadFile(const std::string& path) {
  std::ifstream file(path);
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

// The markdown row docs/channels.md must contain for one table entry.
std::string DocRow(const ChannelInfo& info) {
  return "| `" + info.name + "` | `" + info.lcm_type + "` | " + info.publisher + " | " +
         info.subscribers + " | " + info.rate + " | " + info.carries + " |";
}

TEST(ChannelsTest, DefaultsAreTheTableNamesInOrder) {
  const std::vector<std::string> names = Channels{}.All();
  const std::vector<ChannelInfo>& table = ChannelTable();
  ASSERT_EQ(names.size(), 33u);
  ASSERT_EQ(table.size(), names.size());
  for (std::size_t i = 0; i < names.size(); ++i) EXPECT_EQ(names[i], table[i].name) << i;
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()).size(), names.size())
      << "channel names must be unique";
  EXPECT_EQ(Channels{}.sim_arm_state, "SIM_ARM_STATE");
  EXPECT_EQ(Channels{}.viewer_image, "VIEWER_IMAGE");
}

TEST(ChannelsTest, WithPrefixPrependsToEveryName) {
  const Channels rig = Channels::WithPrefix("RIG3_");
  const std::vector<std::string> plain = Channels{}.All();
  const std::vector<std::string> prefixed = rig.All();
  ASSERT_EQ(prefixed.size(), plain.size());
  for (std::size_t i = 0; i < plain.size(); ++i) EXPECT_EQ(prefixed[i], "RIG3_" + plain[i]);
  EXPECT_EQ(rig.heartbeat, "RIG3_HEARTBEAT");
  EXPECT_EQ(Channels::WithPrefix("").All(), plain);
}

TEST(ChannelsTest, BadPrefixIsRefusedWithTheValueAndTheRule) {
  for (const std::string bad : {"RIG-3", "rig 3", "RIG.*", "RIG/3", "R\xc3\xa4"}) {
    try {
      Channels::WithPrefix(bad);
      ADD_FAILURE() << "accepted prefix \"" << bad << "\"";
    } catch (const std::invalid_argument& error) {
      const std::string text = error.what();
      EXPECT_NE(text.find("\"" + bad + "\""), std::string::npos) << text;
      EXPECT_NE(text.find("letters, digits and '_'"), std::string::npos) << text;
    }
  }
  EXPECT_NO_THROW(ValidateChannelPrefix("Rig_3_"));
}

TEST(ChannelsTest, PrefixMayNotPushANameBeyondLcmLimit) {
  // CONTROLLER_STATUS (17 characters) is the longest name; LCM allows 63.
  EXPECT_NO_THROW(ValidateChannelPrefix(std::string(46, 'R')));
  try {
    ValidateChannelPrefix(std::string(47, 'R'));
    ADD_FAILURE() << "47-character prefix accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("at most 46"), std::string::npos) << error.what();
  }
}

TEST(ChannelsTest, EveryTableTypeHasAnLcmFile) {
  const std::string package = "sirupp.";
  for (const ChannelInfo& info : ChannelTable()) {
    ASSERT_EQ(info.lcm_type.compare(0, package.size(), package), 0) << info.lcm_type;
    const std::string type = info.lcm_type.substr(package.size());
    const std::string path = "lcmtypes/" + type + ".lcm";
    const std::string text = ReadFile(path);
    ASSERT_FALSE(text.empty()) << path << " missing (tests run from the source root)";
    EXPECT_NE(text.find("package sirupp;"), std::string::npos) << path;
    EXPECT_NE(text.find("struct " + type), std::string::npos) << path;
  }
}

TEST(ChannelsTest, EveryRowIsFilledIn) {
  for (const ChannelInfo& info : ChannelTable()) {
    EXPECT_FALSE(info.publisher.empty()) << info.name;
    EXPECT_FALSE(info.subscribers.empty()) << info.name;
    EXPECT_FALSE(info.rate.empty()) << info.name;
    EXPECT_FALSE(info.carries.empty()) << info.name;
    // A '|' would break the markdown table the docs show.
    for (const std::string* cell :
         {&info.publisher, &info.subscribers, &info.rate, &info.carries}) {
      EXPECT_EQ(cell->find('|'), std::string::npos) << info.name;
    }
  }
}

TEST(ChannelsTest, DocsPageShowsExactlyTheTable) {
  const std::string doc = ReadFile("docs/channels.md");
  ASSERT_FALSE(doc.empty()) << "docs/channels.md missing (tests run from the source root)";
  std::set<std::string> expected_rows;
  for (const ChannelInfo& info : ChannelTable()) {
    const std::string row = DocRow(info);
    expected_rows.insert(row);
    EXPECT_NE(doc.find(row + "\n"), std::string::npos)
        << "docs/channels.md lacks the row (or it differs):\n"
        << row;
  }
  // And no channel row in the page that the table does not have.
  std::istringstream lines(doc);
  std::string line;
  int channel_rows = 0;
  while (std::getline(lines, line)) {
    if (line.find("| `sirupp.") == std::string::npos) continue;
    ++channel_rows;
    EXPECT_EQ(expected_rows.count(line), 1u) << "row not in ChannelTable():\n" << line;
  }
  EXPECT_EQ(channel_rows, static_cast<int>(ChannelTable().size()));
}

}  // namespace
}  // namespace sirupp::core
