// Building a submitted C++ controller (grade/build_controller.hpp): a good source becomes a
// library; errors come back at their file:line:column, named as the student wrote them; in the
// sandbox the compiler sees nothing outside the source's folder, /usr and the include folder; a
// build that does not end is stopped at the time limit.

#include "grade/build_controller.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "sandbox/sandbox.hpp"

namespace sirupp::grade {
namespace {
namespace fs = std::filesystem;

class BuildControllerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() / ("sirupp-build-" + std::to_string(::getpid()) + "-" +
                                           ::testing::UnitTest::GetInstance()
                                               ->current_test_info()
                                               ->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_ / "src");
    ::chmod(folder_.c_str(), 0755);
    ::chmod((folder_ / "src").c_str(), 0755);
    options_.include_dir = SIRUPP_INCLUDE_DIR;
    options_.sandbox = sandbox::ProbeMachine().usable;
  }
  void TearDown() override { fs::remove_all(folder_); }
  std::string Source(const std::string& name, const std::string& text) {
    const fs::path path = folder_ / "src" / name;
    std::ofstream(path) << text;
    ::chmod(path.c_str(), 0644);
    return path.string();
  }
  std::string Out() const { return (folder_ / "out").string(); }

  fs::path folder_;
  BuildOptions options_;
};

TEST_F(BuildControllerTest, AGoodSourceBecomesALibrary) {
  std::ifstream example("examples/02_pd_gravity/pd_gravity.cpp");
  std::stringstream text;
  text << example.rdbuf();
  const BuildResult built =
      BuildController({Source("pd.cpp", text.str())}, Out(), "pd", options_);
  EXPECT_TRUE(built.built) << built.problem;
  EXPECT_EQ(built.library, Out() + "/pd.so");
  EXPECT_TRUE(fs::is_regular_file(built.library));
  EXPECT_TRUE(built.errors.empty());
}

TEST_F(BuildControllerTest, ErrorsComeBackAtTheirLines) {
  const std::string source = Source("mine.cpp",
                                    "#include <sirupp/controller.h>\n"
                                    "int f() {\n"
                                    "  return 1\n"
                                    "}\n"
                                    "int g() { return undeclared_name; }\n");
  const BuildResult built = BuildController({source}, Out(), "mine", options_);
  EXPECT_FALSE(built.built);
  ASSERT_EQ(built.errors.size(), 2u) << built.problem;
  EXPECT_EQ(built.errors[0].file, "mine.cpp");
  EXPECT_EQ(built.errors[0].line, 3);
  EXPECT_NE(built.errors[0].message.find("expected ';'"), std::string::npos)
      << built.errors[0].message;
  EXPECT_EQ(built.errors[1].line, 5);
  EXPECT_NE(built.errors[1].message.find("undeclared_name"), std::string::npos);
  EXPECT_NE(built.problem.find("mine.cpp:3:"), std::string::npos) << built.problem;
  EXPECT_FALSE(fs::exists(Out() + "/mine.so"));
}

TEST_F(BuildControllerTest, AMissingDefinitionFailsTheBuildNotTheLoad) {
  const std::string source = Source("link.cpp",
                                    "int missing();\n"
                                    "int use() { return missing(); }\n");
  const BuildResult built = BuildController({source}, Out(), "link", options_);
  EXPECT_FALSE(built.built);
  EXPECT_NE(built.problem.find("missing"), std::string::npos) << built.problem;
}

TEST_F(BuildControllerTest, TheSandboxedCompilerSeesNothingOutsideItsFolder) {
  if (!options_.sandbox) GTEST_SKIP() << sandbox::ProbeMachine().problem;
  // Another student's file, readable by everyone on the machine.
  const fs::path other = folder_ / "other";
  fs::create_directories(other);
  ::chmod(other.c_str(), 0755);
  std::ofstream(other / "secret.h") << "int secret = 42;\n";
  ::chmod((other / "secret.h").c_str(), 0644);
  const std::string source =
      Source("peek.cpp", "#include \"" + (other / "secret.h").string() + "\"\nint x = secret;\n");
  const BuildResult built = BuildController({source}, Out(), "peek", options_);
  EXPECT_FALSE(built.built);
  ASSERT_FALSE(built.errors.empty()) << built.problem;
  EXPECT_NE(built.errors[0].message.find("No such file or directory"), std::string::npos)
      << built.errors[0].ToString();
  // Unsandboxed the same source builds: the check above can fail.
  BuildOptions plain = options_;
  plain.sandbox = false;
  EXPECT_TRUE(BuildController({source}, Out(), "peek", plain).built);
}

TEST_F(BuildControllerTest, ABuildThatDoesNotEndIsStoppedAtTheTimeLimit) {
  // A header that is a FIFO nobody writes: the compiler waits on it for ever.
  ASSERT_EQ(::mkfifo((folder_ / "src" / "wait.h").c_str(), 0644), 0);
  const std::string source = Source("slow.cpp", "#include \"wait.h\"\n");
  options_.time_limit_s = 1;
  const BuildResult built = BuildController({source}, Out(), "slow", options_);
  EXPECT_FALSE(built.built);
  EXPECT_EQ(built.problem, "the build took longer than 1 s and was stopped");
  EXPECT_LT(built.seconds, 5);
}

TEST(CompilerErrors, ParsedFromGccOutput) {
  const std::vector<CompilerError> errors = ParseCompilerErrors(
      "/home/a/sub/x.cpp: In function 'int f()':\n"
      "/home/a/sub/x.cpp:12:5: error: expected ';' before '}' token\n"
      "/home/a/sub/x.cpp:12:5: note: something\n"
      "/home/a/sub/y.h:1:10: fatal error: z.h: No such file or directory\n"
      "/home/a/sub/x.cpp:3:1: warning: unused\n",
      "/home/a/sub");
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0].ToString(), "x.cpp:12:5: error: expected ';' before '}' token");
  EXPECT_EQ(errors[1].file, "y.h");
  EXPECT_EQ(errors[1].message, "z.h: No such file or directory");
}

}  // namespace
}  // namespace sirupp::grade
