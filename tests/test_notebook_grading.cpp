// Notebook assignments' parts without a kernel (grade/notebook_assignment.hpp,
// class/gradebook.hpp, class/notebook_submissions.hpp): the gradebook's CSV (header, quoting,
// empty cells, numbers), the hidden tests' names and points read from their file, a result as JSON
// and back, the table a teacher reads, the checks of a submitted notebook, where the hub's copy of
// an assignment is. Grading itself: tests/python/test_grade_notebook.py; through the class
// server: tests/class/class_notebook_test.py.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "class/class_config.hpp"
#include "class/gradebook.hpp"
#include "class/notebook_submissions.hpp"
#include "grade/notebook_assignment.hpp"

namespace sirupp::classroom {
namespace {

namespace fs = std::filesystem;

std::string Temp(const std::string& name, const std::string& text) {
  const fs::path file = fs::path(::testing::TempDir()) / name;
  std::ofstream(file) << text;
  return file.string();
}

TEST(GradebookCsvTest, HeaderCanvasTakesThenOneRowPerStudent) {
  const std::string csv = GradebookCsv(
      {{"controller", 100}, {"fk3", 6}},
      {{"alice", {83.333333, 3.0}}, {"bob", {std::nullopt, 6.0}}, {"carol", {0.0, std::nullopt}}});
  EXPECT_EQ(csv,
            "Student,ID,SIS User ID,SIS Login ID,Section,controller,fk3\r\n"
            "alice,,,alice,,83.33,3\r\n"
            "bob,,,bob,,,6\r\n"
            "carol,,,carol,,0,\r\n");
}

TEST(GradebookCsvTest, NoColumnsStillNamesEveryStudent) {
  EXPECT_EQ(GradebookCsv({}, {{"alice", {}}}),
            "Student,ID,SIS User ID,SIS Login ID,Section\r\nalice,,,alice,\r\n");
}

TEST(GradebookCsvTest, FieldsQuotedWhenTheyMustBe) {
  EXPECT_EQ(CsvField("fk3"), "fk3");
  EXPECT_EQ(CsvField("a,b"), "\"a,b\"");
  EXPECT_EQ(CsvField("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(CsvField("two\nlines"), "\"two\nlines\"");
  // A spreadsheet would run these as formulas: quoted, behind a text mark.
  EXPECT_EQ(CsvField("=HYPERLINK(\"x\")"), "\"'=HYPERLINK(\"\"x\"\")\"");
  EXPECT_EQ(CsvField("+1"), "\"'+1\"");
  EXPECT_EQ(CsvField("-1"), "\"'-1\"");
  EXPECT_EQ(CsvField("@sum"), "\"'@sum\"");
  EXPECT_EQ(GradebookCsv({{"a,b", 1}}, {{"x", {0.5}}}),
            "Student,ID,SIS User ID,SIS Login ID,Section,\"a,b\"\r\nx,,,x,,0.5\r\n");
}

TEST(GradebookCsvTest, ARowWithTheWrongNumberOfGradesIsRefused) {
  EXPECT_THROW(GradebookCsv({{"fk3", 6}}, {{"alice", {}}}), std::invalid_argument);
}

TEST(NotebookTestsFileTest, NamesAndPointsInTheirOrder) {
  const std::string file = Temp("hidden_ok.py",
                                "import numpy as np\n"
                                "def helper():\n    pass\n"
                                "@points(2)\n"
                                "def test_first():\n    assert True\n"
                                "def test_second():\n    pass\n"
                                "@points(0.5)  # half a point\n"
                                "# a comment between\n"
                                "def test_third(): pass\n"
                                "    def test_nested():\n        pass\n");
  const std::vector<grade::NotebookTest> tests = grade::ReadNotebookTests(file);
  ASSERT_EQ(tests.size(), 3u);
  EXPECT_EQ(tests[0].name, "test_first");
  EXPECT_EQ(tests[0].points, 2);
  EXPECT_EQ(tests[1].name, "test_second");
  EXPECT_EQ(tests[1].points, 1);
  EXPECT_EQ(tests[2].name, "test_third");
  EXPECT_EQ(tests[2].points, 0.5);
}

TEST(NotebookTestsFileTest, ShippedHiddenTestsAreSixPoints) {
  const std::vector<grade::NotebookTest> tests =
      grade::ReadNotebookTests("config/grading/notebooks/fk3_hidden.py");
  ASSERT_EQ(tests.size(), 3u);
  EXPECT_EQ(tests[2].name, "test_a_table_you_have_not_seen");
  EXPECT_EQ(tests[0].points + tests[1].points + tests[2].points, 6);
}

std::string ErrorOf(const std::string& name, const std::string& text) {
  try {
    grade::ReadNotebookTests(Temp(name, text));
  } catch (const std::runtime_error& error) {
    return error.what();
  }
  return "";
}

TEST(NotebookTestsFileTest, BadFilesNameTheLine) {
  EXPECT_NE(ErrorOf("none.py", "def helper():\n    pass\n").find("none.py: no test"),
            std::string::npos);
  EXPECT_NE(
      ErrorOf("neg.py", "@points(-1)\ndef test_a():\n    pass\n").find("neg.py:1: @points(-1)"),
      std::string::npos);
  EXPECT_NE(ErrorOf("word.py", "@points(many)\ndef test_a():\n    pass\n").find("word.py:1:"),
            std::string::npos);
  EXPECT_NE(ErrorOf("twice.py", "def test_a():\n    pass\ndef test_a():\n    pass\n")
                .find("twice.py:3: test_a is defined twice"),
            std::string::npos);
  EXPECT_NE(ErrorOf("stray.py", "@points(2)\nx = 1\ndef test_a():\n    pass\n")
                .find("stray.py:1: @points(...) must be right above"),
            std::string::npos);
  EXPECT_THROW(grade::ReadNotebookTests("/nonexistent/hidden.py"), std::runtime_error);
}

TEST(NotebookTestsFileTest, TestsASandboxCouldReadAreNamed) {
  EXPECT_EQ(grade::HiddenTestsExposed(Temp("mine.py", "def test_a(): pass\n"), "build/bin"), "");
  const std::string usr = grade::HiddenTestsExposed("/usr/share/sirupp/config/x.py", "build/bin");
  EXPECT_NE(usr.find("is under /usr, which every student's sandbox reads"), std::string::npos)
      << usr;
  // A build folder of its own (the test's may be build/, build2/ or build-asan/).
  const fs::path build = fs::path(::testing::TempDir()) / "exposed-build";
  fs::create_directories(build / "bin");
  fs::create_directories(build / "python" / "sirupp");
  EXPECT_NE(grade::HiddenTestsExposed((build / "python" / "sirupp" / "t.py").string(),
                                      (build / "bin").string())
                .find("the Python module's folder"),
            std::string::npos);
  EXPECT_NE(grade::HiddenTestsExposed("config/robots/t.py", "build/bin").find("robot models"),
            std::string::npos);
}

TEST(NotebookResultTest, JsonAndBackAndTheTable) {
  grade::NotebookResult result;
  result.tests = {{"test_a", 1, 1, true, ""}, {"test_b", 3, 0, false, "fk differs"}};
  result.cells = 4;
  result.cell_errors = {{2, "NameError: name 'x' is not defined"}};
  result.output = "[cell 1]\nhello\n";
  EXPECT_EQ(result.score(), 1);
  EXPECT_EQ(result.max_score(), 4);
  const nlohmann::ordered_json json = grade::NotebookResultJson(result);
  EXPECT_EQ(json["format"], grade::kNotebookResultFormat);
  EXPECT_EQ(json["score"], 1.0);
  EXPECT_EQ(json["max_score"], 4.0);
  const grade::NotebookResult back =
      grade::NotebookResultFromJson(nlohmann::json::parse(json.dump()));
  ASSERT_EQ(back.tests.size(), 2u);
  EXPECT_EQ(back.tests[1].message, "fk differs");
  EXPECT_FALSE(back.tests[1].passed);
  EXPECT_EQ(back.cell_errors.at(0).cell, 2);
  EXPECT_EQ(back.output, result.output);
  const std::string table = grade::NotebookResultTable(result);
  EXPECT_NE(table.find("test_b     0/3  FAIL: fk differs"), std::string::npos) << table;
  EXPECT_NE(table.find("total      1/4"), std::string::npos) << table;
  EXPECT_NE(table.find("code cell 2 raised NameError"), std::string::npos) << table;
  EXPECT_THROW(grade::NotebookResultFromJson(nlohmann::json{{"format", "other"}}),
               std::runtime_error);
}

TEST(NotebookBodyTest, OnlyANotebookWithinTheLimitIsTaken) {
  EXPECT_FALSE(CheckNotebookBody(R"({"cells": [], "nbformat": 4, "nbformat_minor": 5})", 900));
  const auto status = [](const std::string& body, size_t kb) {
    const auto refusal = CheckNotebookBody(body, kb);
    return refusal ? refusal->status : 0;
  };
  EXPECT_EQ(status("", 900), 400);
  EXPECT_EQ(status("print('hi')", 900), 400);
  EXPECT_EQ(status("[1, 2]", 900), 400);
  EXPECT_EQ(status(R"({"nbformat": 4})", 900), 400);
  EXPECT_EQ(status(R"({"cells": {}, "nbformat": 4})", 900), 400);
  EXPECT_EQ(status(R"({"cells": [], "nbformat": 3})", 900), 400);
  EXPECT_EQ(status(R"({"cells": [], "nbformat": "4"})", 900), 400);
  EXPECT_EQ(status(std::string(2048, ' ') + R"({"cells": [], "nbformat": 4})", 1), 413);
  const auto refusal = CheckNotebookBody(R"({"cells": [], "nbformat": 3})", 900);
  ASSERT_TRUE(refusal);
  EXPECT_NE(refusal->body.find("nbformat"), std::string::npos) << refusal->body;
}

TEST(NotebookCopyTest, TheHubsCopyKeepsThePathUnderTheNotebooksFolder) {
  ClassConfig config;
  config.data_dir = "/data";
  config.notebooks = NotebooksConfig{};
  config.notebooks->folder = "/src/notebooks";
  NotebookAssignment inside{"fk3", "/src/notebooks/assignments/fk3.ipynb", "/t.py"};
  EXPECT_EQ(StudentNotebookFile(config, "alice", inside),
            "/data/students/alice/notebooks/assignments/fk3.ipynb");
  NotebookAssignment outside{"ik", "/elsewhere/ik.ipynb", "/t.py"};
  EXPECT_EQ(StudentNotebookFile(config, "bob", outside), "/data/students/bob/notebooks/ik.ipynb");
}

}  // namespace
}  // namespace sirupp::classroom
