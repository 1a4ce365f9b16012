// Every file in tests/data/bad_models/ is a robot model with one defect. Its second line says,
// after
// "# expect: ", the exact message (after "FILE:") the loader must give. The corpus doubles as
// documentation of what `sirupp model check` tells a user.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "core/model_loader.hpp"

namespace sirupp::core {
namespace {

constexpr const char* kCorpus = "tests/data/bad_models";

std::vector<std::string> CorpusFiles() {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(kCorpus)) {
    if (entry.path().extension() == ".yaml") files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string ExpectedMessage(const std::string& file) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    const std::string marker = "# expect: ";
    if (line.rfind(marker, 0) == 0) return line.substr(marker.size());
  }
  return "";
}

TEST(BadModels, CorpusHasAtLeastTwentyFiles) { EXPECT_GE(CorpusFiles().size(), 20U); }

TEST(BadModels, EachFileFailsWithItsMessage) {
  for (const std::string& file : CorpusFiles()) {
    SCOPED_TRACE(file);
    const std::string expected = ExpectedMessage(file);
    ASSERT_FALSE(expected.empty()) << "no '# expect: ' line";
    try {
      LoadRobotModel(file);
      ADD_FAILURE() << "loaded without error";
    } catch (const ConfigError& error) {
      EXPECT_EQ(std::string(error.what()), file + ":" + expected);
      EXPECT_EQ(error.where().file, file);
      EXPECT_GT(error.where().line, 0);
    }
  }
}

TEST(BadModels, TheCleanTwinLoads) {
  // The corpus is built from this file; it must itself be valid, or the defects prove nothing.
  const RobotModel model = LoadRobotModel("tests/data/good_two_link.yaml");
  EXPECT_EQ(model.num_joints(), 2);
}

TEST(BadModels, MissingFileNamesTheFile) {
  try {
    LoadRobotModel("tests/data/no_such_model.yaml");
    FAIL() << "loaded a missing file";
  } catch (const ConfigError& error) {
    EXPECT_EQ(std::string(error.what()),
              "tests/data/no_such_model.yaml: cannot read the file: No such file or directory");
  }
}

}  // namespace
}  // namespace sirupp::core
