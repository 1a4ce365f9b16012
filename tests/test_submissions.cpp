// Students' controllers from the browser (class/submissions.hpp): the class file's grading: key,
// the POST body's checks, the submission store, the compiler's errors as the page gets them, the
// real arm's gate, and the routes over HTTP (refusals; a C++ source that does not compile comes
// back with its error at its line). Grading itself and runs on rigs:
// tests/class/submit_browser_test.py.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "class/class_config.hpp"
#include "class/class_server.hpp"
#include "class/rig.hpp"
#include "class/submissions.hpp"
#include "core/errors.hpp"
#include "panel/httplib_include.hpp"
#include "sandbox/sandbox.hpp"
#include "tests/class_server_harness.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

using testing::TempDir;

const char* const kClass = testing::kClassOfTwo;
const auto ErrorOf = testing::ClassFileError;

TEST(SubmissionConfigTest, GradingKeyReadStrictly) {
  const ClassConfig none = ParseClassConfig(kClass, "c.yaml", fs::current_path().string());
  EXPECT_EQ(none.grading_suite, "");
  const ClassConfig c = ParseClassConfig(
      std::string(kClass) + "grading: {suite: tests/data/grade_small.yaml, max_source_kb: 64}\n",
      "c.yaml", fs::current_path().string());
  EXPECT_TRUE(fs::path(c.grading_suite).is_absolute());
  EXPECT_EQ(c.safety_tasks, (std::vector<std::string>{"set1", "step_j2"})) << "default: all";
  EXPECT_EQ(c.max_source_kb, 64);
  const ClassConfig s = ParseClassConfig(
      std::string(kClass) +
          "grading:\n  suite: tests/data/grade_small.yaml\n  safety_tasks: [set1]\n",
      "c.yaml", fs::current_path().string());
  EXPECT_EQ(s.safety_tasks, (std::vector<std::string>{"set1"}));
  {
    const std::string e = ErrorOf(std::string(kClass) +
                                  "grading:\n  suite: tests/data/grade_small.yaml\n"
                                  "  safety_tasks: [set1, set9]\n");
    EXPECT_NE(e.find("c.yaml:9"), std::string::npos) << e;
    EXPECT_NE(e.find("'set9' is not a task of small; allowed: set1, step_j2"), std::string::npos)
        << e;
  }
  {
    const std::string e = ErrorOf(std::string(kClass) + "grading: {suite: nowhere.yaml}\n");
    EXPECT_NE(e.find("c.yaml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("no such file"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(std::string(kClass) +
                                  "grading: {suite: tests/data/grade_small.yaml, colour: red}\n");
    EXPECT_NE(e.find("c.yaml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("colour"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(
        std::string(kClass) + "grading: {suite: tests/data/grade_small.yaml, max_source_kb: 0}\n");
    EXPECT_NE(e.find("c.yaml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("max_source_kb"), std::string::npos) << e;
  }
  {
    const std::string e = ErrorOf(std::string(kClass) + "grading: {safety_tasks: [set1]}\n");
    EXPECT_NE(e.find("suite"), std::string::npos) << e;
  }
  {
    // A suite that does not load is named with the class file's line.
    const std::string e =
        ErrorOf(std::string(kClass) + "grading: {suite: config/robots/puma260.yaml}\n");
    EXPECT_NE(e.find("c.yaml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("does not load"), std::string::npos) << e;
  }
}

TEST(SubmissionBodyTest, RefusalsNameTheFieldAndWhatIsAllowed) {
  std::string language;
  std::string source;
  const auto check = [&](const std::string& body) {
    return CheckSubmissionBody(body, 1, &language, &source);
  };
  EXPECT_EQ(check("[1")->status, 400);
  EXPECT_EQ(check("[1, 2]")->status, 400);
  auto r = check(R"({"language": "rust", "source": "x"})");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(r->body.find("language: '\\\"rust\\\"'; allowed: \\\"cpp\\\""), std::string::npos)
      << r->body;
  r = check(R"({"source": "x"})");
  EXPECT_NE(r->body.find("language: missing"), std::string::npos) << r->body;
  r = check(R"({"language": "cpp"})");
  EXPECT_NE(r->body.find("source: expected"), std::string::npos) << r->body;
  r = check(R"({"language": "cpp", "source": "  \n"})");
  EXPECT_NE(r->body.find("source: empty"), std::string::npos) << r->body;
  r = check(R"({"language": "cpp", "source": "x", "author": "me"})");
  EXPECT_NE(r->body.find("unknown field 'author'"), std::string::npos) << r->body;
  r = check(Json{{"language", "cpp"}, {"source", std::string(1025, 'x')}}.dump());
  EXPECT_EQ(r->status, 413);
  EXPECT_NE(r->body.find("source: 2 KB; allowed: at most 1 KB"), std::string::npos) << r->body;
  r = check(Json{{"language", "cpp"}, {"source", std::string("a\0b", 3)}}.dump());
  EXPECT_EQ(r->status, 400);
  EXPECT_FALSE(check(R"({"language": "python", "source": "class Controller: pass\n"})"));
  EXPECT_EQ(language, "python");
  EXPECT_EQ(source, "class Controller: pass\n");
}

TEST(SubmissionStoreTest, HistoryRunningAndTheCountedOne) {
  const std::string dir = TempDir("sirupp-submissions");
  SubmissionStore store(dir);
  EXPECT_TRUE(store.Ids("alice").empty());
  EXPECT_FALSE(store.Running("alice"));
  EXPECT_FALSE(store.Counted("alice"));
  EXPECT_EQ(store.Create("alice", "cpp", "int x;\n"), 1);
  EXPECT_EQ(store.Create("alice", "python", "class Controller: pass\n"), 2);
  EXPECT_EQ(store.Create("bob", "cpp", "int y;\n"), 1) << "numbers per student";
  EXPECT_EQ(store.Ids("alice"), (std::vector<int>{1, 2}));
  EXPECT_EQ(store.SourceFile("alice", 1), dir + "/students/alice/submissions/1/src/controller.cpp");
  EXPECT_EQ(store.SourceFile("alice", 2), dir + "/students/alice/submissions/2/src/controller.py");
  std::ifstream in(store.SourceFile("alice", 2));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "class Controller: pass");
  EXPECT_EQ(fs::status(store.SourceFile("alice", 1)).permissions() & fs::perms::others_read,
            fs::perms::others_read)
      << "the sandbox's own uid (as root) reads it";
  Json meta = store.Read("alice", 1);
  EXPECT_EQ(meta["state"], "new");
  EXPECT_EQ(meta["language"], "cpp");
  EXPECT_FALSE(store.Counted("alice")) << "none in a final state";
  meta["state"] = "graded";
  store.Write("alice", 1, meta);
  EXPECT_EQ(store.Counted("alice"), 1);
  Json second = store.Read("alice", 2);
  second["state"] = "grading";
  store.Write("alice", 2, second);
  EXPECT_EQ(store.Counted("alice"), 1) << "the latest in a final state";
  second["state"] = "build failed";
  store.Write("alice", 2, second);
  EXPECT_EQ(store.Counted("alice"), 2);
  store.SetRunning("alice", 2);
  EXPECT_EQ(store.Running("alice"), 2);
  store.SetRunning("alice", std::nullopt);
  EXPECT_FALSE(store.Running("alice"));
  store.SetRunning("alice", 7);
  EXPECT_FALSE(store.Running("alice")) << "no such submission";
  EXPECT_TRUE(store.Read("alice", 9).is_null());
  fs::remove_all(dir);
}

TEST(SubmissionErrorsTest, CompilerErrorsAsJsonAtTheirLines) {
  const std::string output =
      "/x/sub/src/controller.cpp: In member function 'void F()':\n"
      "/x/sub/src/controller.cpp:3:19: error: expected ';' before '}' token\n"
      "/x/sub/src/controller.cpp:7:1: error: 'foo' was not declared in this scope\n"
      "/x/sub/src/controller.cpp:9:2: warning: unused\n";
  const Json errors = CompilerErrorsJson(grade::ParseCompilerErrors(output, "/x/sub/src"));
  ASSERT_EQ(errors.size(), 2u) << errors.dump();
  EXPECT_EQ(errors[0], (Json{{"file", "controller.cpp"},
                             {"line", 3},
                             {"column", 19},
                             {"message", "expected ';' before '}' token"}}));
  EXPECT_EQ(errors[1]["line"], 7);
}

TEST(RealArmRefusalTest, OnlyTheBuiltInLawOrAPassingSubmission) {
  const std::string dir = TempDir("sirupp-submissions");
  const ClassConfig config = ParseClassConfig(
      std::string(kClass) +
          "grading:\n  suite: tests/data/grade_small.yaml\n  safety_tasks: [set1]\n",
      "c.yaml", dir);
  ProcessLauncher launcher;
  SubmissionService service(config, SubmissionOptions{}, launcher, [](const std::string&) {});
  const SubmissionStore& store = service.store();
  EXPECT_FALSE(service.RealArmRefusal("alice")) << "the built-in law";
  EXPECT_EQ(service.RigController("alice"), "");
  const int id = store.Create("alice", "cpp", "int x;\n");
  Json meta = store.Read("alice", id);
  meta["state"] = "queued";
  store.Write("alice", id, meta);
  store.SetRunning("alice", id);
  EXPECT_EQ(service.RigController("alice"), store.Folder("alice", id) + "/build/controller.so");
  auto refusal = service.RealArmRefusal("alice");
  ASSERT_TRUE(refusal);
  EXPECT_NE(refusal->find("(submission 1) has not been graded yet (queued)"), std::string::npos)
      << *refusal;
  meta["state"] = "graded";
  meta["grade"] = Json{{"safety_passed", false},
                       {"safety_failed", {"set1 (ended: crashed with SIGSEGV in Update)"}}};
  store.Write("alice", id, meta);
  refusal = service.RealArmRefusal("alice");
  ASSERT_TRUE(refusal);
  EXPECT_EQ(*refusal,
            "your controller (submission 1) failed the class's safety tasks in simulation: set1 "
            "(ended: crashed with SIGSEGV in Update)");
  meta["grade"] = Json{{"safety_passed", true}, {"safety_failed", Json::array()}};
  store.Write("alice", id, meta);
  EXPECT_FALSE(service.RealArmRefusal("alice")) << "passed the safety tasks";
  EXPECT_FALSE(service.RealArmRefusal("bob"));
  store.SetRunning("alice", std::nullopt);
  EXPECT_FALSE(service.RealArmRefusal("alice")) << "back on the built-in law";
  // Python: the rig loads the file itself.
  const int py = store.Create("bob", "python", "class Controller: pass\n");
  store.SetRunning("bob", py);
  EXPECT_EQ(service.RigController("bob"), store.SourceFile("bob", py));
  service.Stop();

  // A class without a suite: a submission on the rig is refused, with what the teacher sets.
  const ClassConfig plain = ParseClassConfig(kClass, "c.yaml", dir);
  SubmissionService ungraded(plain, SubmissionOptions{}, launcher, [](const std::string&) {});
  refusal = ungraded.RealArmRefusal("bob");
  ASSERT_TRUE(refusal);
  EXPECT_NE(refusal->find("no grading suite"), std::string::npos) << *refusal;
  ungraded.Stop();
  fs::remove_all(dir);
}

// The routes over HTTP, no rig started.
class SubmissionRoutesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* bin = std::getenv("SIRUPP_BIN_DIR");
    if (bin == nullptr) GTEST_SKIP() << "SIRUPP_BIN_DIR not set (ctest sets it)";
    dir_ = TempDir("sirupp-submit-test");
    config_ = ParseClassConfig(std::string(kClass) + "grading: {suite: " +
                                   fs::absolute("tests/data/grade_small.yaml").string() +
                                   ", max_source_kb: 4}\n",
                               "class.yaml", dir_);
    harness_ = std::make_unique<testing::TestClassServer>(config_, bin, 60);
    tokens_ = harness_->tokens;
    client_ = harness_->client.get();
    port_ = harness_->port;
  }
  void TearDown() override {
    harness_.reset();
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  httplib::Result Get(const std::string& path, const std::string& token) {
    httplib::Headers headers;
    if (!token.empty()) headers.emplace("X-Sirupp-Token", token);
    return client_->Get(path.c_str(), headers);
  }
  httplib::Result Post(const std::string& path, const std::string& token, const std::string& body) {
    httplib::Headers headers{{"X-Sirupp-Client", "test"}};
    if (!token.empty()) headers.emplace("X-Sirupp-Token", token);
    return client_->Post(path.c_str(), headers, body, "application/json");
  }
  static std::string Error(const httplib::Result& r) {
    const Json body = Json::parse(r->body, nullptr, false);
    if (!body.is_object() || !body.contains("error")) return "(no error)";
    return body.at("error").get<std::string>();
  }
  std::string dir_;
  ClassConfig config_;
  std::unique_ptr<testing::TestClassServer> harness_;
  int port_ = 0;
  std::map<std::string, std::string> tokens_;
  httplib::Client* client_ = nullptr;  // harness_'s
};

TEST_F(SubmissionRoutesTest, RefusalsAre4xxJsonNamingTheField) {
  const std::string good = R"({"language": "python", "source": "class Controller: pass\n"})";
  auto r = Post("/s/bob/class/submissions", tokens_["alice"], good);
  EXPECT_EQ(r->status, 403) << "alice's token on bob's page";
  r = Post("/s/alice/class/submissions", tokens_["teacher"], good);
  EXPECT_EQ(r->status, 403) << "the teacher's view is read-only";
  EXPECT_NE(Error(r).find("only alice submits"), std::string::npos) << Error(r);
  r = Post("/s/alice/class/submissions", tokens_["alice"],
           R"({"language": "java", "source": "x"})");
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(Error(r).find("language:"), std::string::npos) << Error(r);
  r = Post("/s/alice/class/submissions", tokens_["alice"], "not json");
  EXPECT_EQ(r->status, 400);
  r = Post("/s/alice/class/submissions", tokens_["alice"],
           Json{{"language", "cpp"}, {"source", std::string(5000, 'x')}}.dump());
  EXPECT_EQ(r->status, 413);
  EXPECT_NE(Error(r).find("at most 4 KB"), std::string::npos) << Error(r);
  r = Post("/s/alice/class/submissions", tokens_["alice"], std::string(2 * 1024 * 1024, 'x'));
  EXPECT_EQ(r->status, 413) << "past the server's payload limit";
  httplib::Headers no_client{{"X-Sirupp-Token", tokens_["alice"]}};
  EXPECT_EQ(
      client_->Post("/s/alice/class/submissions", no_client, good, "application/json")->status,
      400);
  r = Post("/s/alice/class/run", tokens_["alice"], R"({"id": "one"})");
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(Error(r).find("id:"), std::string::npos) << Error(r);
  r = Post("/s/alice/class/run", tokens_["alice"], R"({"id": 4})");
  EXPECT_EQ(r->status, 404);
  r = Post("/s/alice/class/run", tokens_["alice"], "{}");
  EXPECT_EQ(r->status, 400);
  EXPECT_EQ(Get("/s/alice/class/submissions/1/source", tokens_["alice"])->status, 404);
  EXPECT_EQ(Get("/s/alice/class/submissions/../../tokens.json", tokens_["alice"])->status, 404);
  EXPECT_EQ(Get("/s/alice/class/submissions/1/plots/../x.png", tokens_["alice"])->status, 404);
  r = Get("/s/alice/class/submissions", tokens_["alice"]);
  ASSERT_EQ(r->status, 200);
  const Json list = Json::parse(r->body);
  EXPECT_TRUE(list["submissions"].empty());
  EXPECT_TRUE(list["running"].is_null());
  EXPECT_TRUE(list["real_arm"].is_null());
  EXPECT_EQ(list["grading"]["suite"], "small");
  EXPECT_EQ(Get("/s/alice/class/submissions", tokens_["bob"])->status, 403);
  EXPECT_EQ(Get("/teacher/api/grades", tokens_["alice"])->status, 403);
  r = Get("/teacher/api/class.csv", tokens_["teacher"]);
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(r->body,
            "submission,score,passed,tasks,failed_tasks,problem\n"
            "\"alice\",,,2,\"\",\"no submission graded yet\"\n"
            "\"bob\",,,2,\"\",\"no submission graded yet\"\n");
  EXPECT_EQ(Get("/teacher/api/class.md", tokens_["teacher"])->status, 200);
}

TEST_F(SubmissionRoutesTest, ACompileErrorComesBackAtItsLine) {
  if (!sandbox::ProbeMachine().usable) GTEST_SKIP() << sandbox::ProbeMachine().problem;
  const std::string source =
      "#include <sirupp/controller.h>\n"
      "int Broken() {\n"
      "  return 1\n"
      "}\n";
  auto r = Post("/s/alice/class/submissions", tokens_["alice"],
                Json{{"language", "cpp"}, {"source", source}}.dump());
  ASSERT_EQ(r->status, 200) << r->body;
  const Json sub = Json::parse(r->body);
  EXPECT_EQ(sub["state"], "build failed");
  ASSERT_FALSE(sub["errors"].empty()) << sub.dump();
  EXPECT_EQ(sub["errors"][0]["file"], "controller.cpp");
  EXPECT_EQ(sub["errors"][0]["line"], 3);
  EXPECT_NE(sub["errors"][0]["message"].get<std::string>().find("expected ';'"), std::string::npos);
  r = Post("/s/alice/class/run", tokens_["alice"], R"({"id": 1})");
  EXPECT_EQ(r->status, 409) << "a build that failed does not run";
  r = Get("/s/alice/class/submissions/1/source", tokens_["alice"]);
  ASSERT_EQ(r->status, 200);
  EXPECT_EQ(r->body, source);
  EXPECT_EQ(Get("/s/alice/class/submissions/1/source", tokens_["teacher"])->status, 200)
      << "the teacher reads it";
  r = Get("/teacher/api/class.csv", tokens_["teacher"]);
  EXPECT_NE(r->body.find("\"alice\",,,2,\"\",\"does not build"), std::string::npos) << r->body;
}

}  // namespace
}  // namespace sirupp::classroom
