// Environment files (core/environment.hpp): parsing with unit conversion and defaults, the shipped
// files, the message round trip and refused messages, and the malformed-file corpus in
// tests/data/bad_environments/ (one defect per file; line 2 reads "<!-- expect: LINE: TEXT -->",
// where LINE: TEXT is what the error says after "FILE:").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/environment.hpp"
#include "core/errors.hpp"
#include "tests/helpers.hpp"

namespace sirupp::core {
namespace {

using sirupp::testing::ErrorText;

constexpr double kDeg = M_PI / 180.0;

std::string ParseError(const std::string& xml) {
  return ErrorText<ConfigError>([&] { ParseEnvironment(xml, "test.xml"); });
}

// ---- parsing ----------------------------------------------------------------------------------

TEST(ParseEnvironment, ConvertsLengthsAndAnglesToSi) {
  const Environment environment = ParseEnvironment(
      "<?xml version=\"1.0\"?>\n"
      "<environment name=\"units\" length_unit=\"mm\" angle_unit=\"deg\">\n"
      "  <box name=\"plate\" size=\"300 200 10\" position=\"400 -50 120\" rpy=\"90 0 -45\"/>\n"
      "</environment>\n",
      "units.xml");
  EXPECT_EQ(environment.name, "units");
  EXPECT_EQ(environment.source_file, "units.xml");
  ASSERT_EQ(environment.objects.size(), 1U);
  const EnvironmentObject& plate = environment.objects[0];
  EXPECT_EQ(plate.name, "plate");
  EXPECT_EQ(plate.source_line, 3);
  EXPECT_EQ(plate.shape.type, ShapeType::kBox);
  EXPECT_TRUE(plate.shape.size_m.isApprox(Eigen::Vector3d(0.3, 0.2, 0.01), 1e-15));
  EXPECT_TRUE(plate.shape.pose.position_m.isApprox(Eigen::Vector3d(0.4, -0.05, 0.12), 1e-15));
  const Eigen::Quaterniond expected = QuaternionFromRpy(90 * kDeg, 0, -45 * kDeg);
  EXPECT_TRUE(plate.shape.pose.orientation.isApprox(expected, 1e-15));
  // Roll 90 deg turns local y onto world z.
  EXPECT_TRUE((plate.shape.pose.orientation * Eigen::Vector3d::UnitY())
                  .isApprox(Eigen::Vector3d::UnitZ(), 1e-12));
}

TEST(ParseEnvironment, InchesAndRadians) {
  const Environment environment = ParseEnvironment(
      "<environment name=\"imperial\" length_unit=\"inch\" angle_unit=\"rad\">\n"
      "  <cylinder name=\"post\" radius=\"1\" length=\"10\" position=\"10 0 5\" rpy=\"0 1.5 0\"/>\n"
      "  <sphere name=\"ball\" radius=\"0.5\" position=\"12 2 0.5\" static=\"false\" "
      "mass=\"0.1\"/>\n"
      "  <capsule name=\"pill\" radius=\"0.25\" length=\"2\" position=\"0 0 0\"/>\n"
      "</environment>\n",
      "imperial.xml");
  ASSERT_EQ(environment.objects.size(), 3U);
  const EnvironmentObject& post = environment.objects[0];
  EXPECT_EQ(post.shape.type, ShapeType::kCylinder);
  EXPECT_DOUBLE_EQ(post.shape.size_m.x(), 0.0254);
  EXPECT_DOUBLE_EQ(post.shape.size_m.y(), 0.254);
  EXPECT_EQ(post.shape.size_m.z(), 0);
  EXPECT_TRUE(post.shape.pose.position_m.isApprox(Eigen::Vector3d(0.254, 0, 0.127), 1e-15));
  EXPECT_TRUE(post.shape.pose.orientation.isApprox(QuaternionFromRpy(0, 1.5, 0), 1e-15));
  const EnvironmentObject& ball = environment.objects[1];
  EXPECT_EQ(ball.shape.type, ShapeType::kSphere);
  EXPECT_DOUBLE_EQ(ball.shape.size_m.x(), 0.0127);
  EXPECT_EQ(ball.shape.size_m.y(), 0);
  EXPECT_FALSE(ball.is_static);
  EXPECT_EQ(ball.mass_kg, 0.1);
  const EnvironmentObject& pill = environment.objects[2];
  EXPECT_EQ(pill.shape.type, ShapeType::kCapsule);
  EXPECT_DOUBLE_EQ(pill.shape.size_m.y(), 0.0508);
  EXPECT_EQ(pill.source_line, 4);
}

TEST(ParseEnvironment, DefaultsAreMetresDegreesAndStaticObjects) {
  const Environment environment = ParseEnvironment(
      "<environment name=\"defaults\">\n"
      "  <box name=\"b\" size=\"1 2 3\" rpy=\"0 0 90\"/>\n"
      "  <sphere name=\"s\" radius=\"0.1\" color=\"0.1 0.2 0.3\"/>\n"
      "  <sphere name=\"t\" radius=\"0.1\" color=\"0.1 0.2 0.3 0.4\" friction=\"0\""
      " restitution=\"1\" mass=\"2\"/>\n"
      "</environment>\n",
      "defaults.xml");
  ASSERT_EQ(environment.objects.size(), 3U);
  const EnvironmentObject& b = environment.objects[0];
  EXPECT_EQ(b.shape.size_m, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(b.shape.pose.position_m, Eigen::Vector3d::Zero());
  EXPECT_TRUE(b.shape.pose.orientation.isApprox(QuaternionFromRpy(0, 0, M_PI / 2), 1e-15));
  EXPECT_TRUE(b.is_static);
  EXPECT_EQ(b.mass_kg, 0);
  EXPECT_EQ(b.friction, 0.8);
  EXPECT_EQ(b.restitution, 0);
  const Shape plain;
  EXPECT_EQ(b.shape.rgba, plain.rgba);
  const EnvironmentObject& s = environment.objects[1];
  EXPECT_EQ(s.shape.pose.orientation.coeffs(), Eigen::Quaterniond::Identity().coeffs());
  EXPECT_EQ(s.shape.rgba, (std::array<float, 4>{{0.1F, 0.2F, 0.3F, 1.0F}}));
  const EnvironmentObject& t = environment.objects[2];
  EXPECT_EQ(t.shape.rgba, (std::array<float, 4>{{0.1F, 0.2F, 0.3F, 0.4F}}));
  EXPECT_EQ(t.friction, 0);
  EXPECT_EQ(t.restitution, 1);
  EXPECT_TRUE(t.is_static);
  EXPECT_EQ(t.mass_kg, 2);  // kept for a static object, though the simulator ignores it
  EXPECT_EQ(environment.Find("t"), &t);
  EXPECT_EQ(environment.Find("nothing"), nullptr);
}

TEST(ParseEnvironment, NumberSpellings) {
  const Environment environment = ParseEnvironment(
      "<environment name=\"n\">\n"
      "  <box name=\"b\" size=\"1e-1\t+.5\n 2.\" position=\"  -0.25   0   1E1 \"/>\n"
      "</environment>\n",
      "n.xml");
  EXPECT_EQ(environment.objects[0].shape.size_m, Eigen::Vector3d(0.1, 0.5, 2));
  EXPECT_EQ(environment.objects[0].shape.pose.position_m, Eigen::Vector3d(-0.25, 0, 10));

  const std::string box = "<environment name=\"n\"><box name=\"b\" size=\"";
  EXPECT_EQ(ParseError(box + "0x10 1 1\"/></environment>"),
            "test.xml:1: box \"b\".size: x = '0x10' is not a number; expected a finite number > "
            "0 (m)");
  EXPECT_EQ(ParseError(box + "1e999 1 1\"/></environment>"),
            "test.xml:1: box \"b\".size: x = inf is not allowed; expected a finite number > 0 (m)");
  EXPECT_EQ(
      ParseError(box + "1 1 1m\"/></environment>"),
      "test.xml:1: box \"b\".size: z = '1m' is not a number; expected a finite number > 0 (m)");
  EXPECT_EQ(ParseError(box + "\"/></environment>"),
            "test.xml:1: box \"b\".size: \"\" has 0 numbers; expected 3 (x y z), each a finite "
            "number > 0 (m)");
  EXPECT_EQ(ParseError(box + "1 1 1 1\"/></environment>"),
            "test.xml:1: box \"b\".size: \"1 1 1 1\" has 4 numbers; expected 3 (x y z), each a "
            "finite number > 0 (m)");
}

TEST(ParseEnvironment, CommentsAndEmptyEnvironments) {
  EXPECT_TRUE(ParseEnvironment("<environment name=\"e\"/>", "e.xml").objects.empty());
  const Environment commented = ParseEnvironment(
      "<!-- before -->\n<environment name=\"e\">\n  <!-- nothing yet -->\n</environment>\n"
      "<!-- after -->\n",
      "e.xml");
  EXPECT_EQ(commented.name, "e");
  EXPECT_TRUE(commented.objects.empty());
}

TEST(ParseEnvironment, DocumentLevelProblems) {
  EXPECT_EQ(ParseError(""), "test.xml: the file is empty; expected an <environment> element");
  EXPECT_EQ(ParseError("  \n"), "test.xml: the file is empty; expected an <environment> element");
  EXPECT_EQ(ParseError("<!-- only a comment -->\n"),
            "test.xml: no <environment> element; expected one holding the objects");
  EXPECT_EQ(ParseError("<!DOCTYPE environment>\n<environment name=\"e\"/>"),
            "test.xml:1: <DOCTYPE environment> is not allowed; an environment file holds comments "
            "and one <environment> element");
  EXPECT_EQ(ParseError("<environment name=\"e\">\n<box name=\"b\" size=\"1 1 1\">\n"),
            "test.xml:2: XML syntax error: an element that is never closed, or a malformed tag "
            "(tinyxml2: XML_ERROR_PARSING)");
  EXPECT_EQ(ParseError("<environment name=\"  \"/>"),
            "test.xml:1: environment.name: an empty name is not allowed; expected a non-empty "
            "environment name");
}

TEST(ParseEnvironment, ErrorsCarryPlaceAndKeyPath) {
  try {
    ParseEnvironment(
        "<environment name=\"e\">\n"
        "  <box name=\"table\"\n"
        "       size=\"1 0 1\"/>\n"
        "</environment>\n",
        "place.xml");
    FAIL() << "parsed a box of zero width";
  } catch (const ConfigError& error) {
    EXPECT_EQ(error.where().file, "place.xml");
    EXPECT_EQ(error.where().line, 3);  // the attribute's own line
    EXPECT_EQ(error.key_path(), "box \"table\".size");
    EXPECT_EQ(error.problem(), "y = 0 is not allowed; expected a finite number > 0 (m)");
  }
}

TEST(LoadEnvironment, UnreadableFiles) {
  EXPECT_EQ(ErrorText<ConfigError>([] { LoadEnvironment("tests/data/no_such_environment.xml"); }),
            "tests/data/no_such_environment.xml: cannot read the file: No such file or directory");
  EXPECT_EQ(ErrorText<ConfigError>([] { LoadEnvironment("tests/data"); }),
            "tests/data: cannot read the file: it is a directory; expected an environment file");
}

// ---- shipped files ------------------------------------------------------------------------------

std::vector<std::string> FilesIn(const std::string& folder, const std::string& extension) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.path().extension() == extension) files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(ShippedEnvironments, EveryFileLoads) {
  const std::vector<std::string> files = FilesIn("config/environments", ".xml");
  EXPECT_GE(files.size(), 2U);
  for (const std::string& file : files) {
    SCOPED_TRACE(file);
    const Environment environment = LoadEnvironment(file);
    EXPECT_FALSE(environment.name.empty());
    EXPECT_EQ(environment.source_file, file);
  }
}

TEST(ShippedEnvironments, EmptyHasNoObjects) {
  EXPECT_TRUE(LoadEnvironment("config/environments/empty.xml").objects.empty());
}

// Half the extent of a shape along world z (its rotation taken into account).
double HalfHeight(const Shape& shape) {
  const Eigen::Matrix3d r = shape.pose.orientation.toRotationMatrix();
  const Eigen::Vector3d& s = shape.size_m;
  switch (shape.type) {
    case ShapeType::kBox:
      return 0.5 *
             (std::abs(r(2, 0)) * s.x() + std::abs(r(2, 1)) * s.y() + std::abs(r(2, 2)) * s.z());
    case ShapeType::kSphere:
      return s.x();
    case ShapeType::kCylinder:
    case ShapeType::kCapsule:
      break;
  }
  const double axis_z = std::abs(r(2, 2));  // the local z axis against world z
  if (shape.type == ShapeType::kCapsule) return axis_z * 0.5 * s.y() + s.x();
  return axis_z * 0.5 * s.y() + s.x() * std::sqrt(std::max(0.0, 1 - axis_z * axis_z));
}

TEST(ShippedEnvironments, TableStandsInFrontOfThePumaBelowItsArm) {
  const Environment environment = LoadEnvironment("config/environments/table.xml");
  const EnvironmentObject* top = environment.Find("table_top");
  ASSERT_NE(top, nullptr);
  EXPECT_TRUE(top->is_static);
  const double top_face = top->shape.pose.position_m.z() + HalfHeight(top->shape);
  EXPECT_GE(top_face, 0.10);
  EXPECT_LE(top_face, 0.15);
  EXPECT_GE(top->shape.pose.position_m.x() - top->shape.size_m.x() / 2, 0.25 - 1e-12);
  EXPECT_LE(top->shape.pose.position_m.x() + top->shape.size_m.x() / 2, 0.60 + 1e-12);

  int free_objects = 0;
  for (const EnvironmentObject& object : environment.objects) {
    SCOPED_TRACE(object.name);
    const Eigen::Vector3d& p = object.shape.pose.position_m;
    // Well below the upper arm (0.33 m at the zero pose) and in front of the base (|x| <= 0.1 m).
    EXPECT_LT(p.z() + HalfHeight(object.shape), 0.25);
    EXPECT_GE(p.z() - HalfHeight(object.shape), -1e-12);
    EXPECT_GT(p.x(), 0.2);
    if (!object.is_static) {
      ++free_objects;
      EXPECT_GT(object.mass_kg, 0);
      EXPECT_LT(object.mass_kg, 0.5);
      // Resting on the table top.
      EXPECT_NEAR(p.z() - HalfHeight(object.shape), top_face, 1e-9);
    }
  }
  EXPECT_GE(free_objects, 2);
}

// ---- messages -----------------------------------------------------------------------------------

using sirupp::testing::ThroughTheWire;

Environment RichEnvironment() {
  Environment environment = LoadEnvironment("config/environments/table.xml");
  EnvironmentObject pill;
  pill.name = "pill";
  pill.shape.type = ShapeType::kCapsule;
  pill.shape.size_m = Eigen::Vector3d(0.01, 0.03, 0);
  pill.shape.pose.position_m = Eigen::Vector3d(0.45, -0.2, 0.13);
  pill.shape.pose.orientation = QuaternionFromRpy(0.1, M_PI / 2, -0.3);
  pill.shape.rgba = {{0.2F, 0.4F, 0.6F, 0.5F}};
  pill.is_static = false;
  pill.mass_kg = 0.0123;
  pill.friction = 1.25;
  pill.restitution = 0.3;
  environment.objects.push_back(pill);
  return environment;
}

TEST(EnvironmentMessage, RoundTripIsExact) {
  const Environment sent = RichEnvironment();
  const sirupp::environment_t message = ToMessage(sent, 1234567, 42);
  EXPECT_EQ(message.utime, 1234567);
  EXPECT_EQ(message.seq, 42);
  EXPECT_EQ(message.num_objects, static_cast<int32_t>(sent.objects.size()));
  const Environment got = EnvironmentFromMessage(ThroughTheWire(message), "ENVIRONMENT");
  EXPECT_EQ(got.name, sent.name);
  EXPECT_EQ(got.source_file, sent.source_file);
  ASSERT_EQ(got.objects.size(), sent.objects.size());
  for (size_t i = 0; i < sent.objects.size(); ++i) {
    const EnvironmentObject& a = sent.objects[i];
    const EnvironmentObject& b = got.objects[i];
    SCOPED_TRACE(a.name);
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.shape.type, b.shape.type);
    EXPECT_EQ(a.shape.size_m, b.shape.size_m);
    EXPECT_EQ(a.shape.pose.position_m, b.shape.pose.position_m);
    EXPECT_EQ(a.shape.pose.orientation.coeffs(), b.shape.pose.orientation.coeffs());
    EXPECT_EQ(a.shape.rgba, b.shape.rgba);
    EXPECT_EQ(a.is_static, b.is_static);
    EXPECT_EQ(a.mass_kg, b.mass_kg);
    EXPECT_EQ(a.friction, b.friction);
    EXPECT_EQ(a.restitution, b.restitution);
    EXPECT_EQ(b.source_line, 0);  // not sent
  }
}

TEST(EnvironmentMessage, EmptyEnvironmentTravels) {
  const Environment none;
  const Environment got = EnvironmentFromMessage(ThroughTheWire(ToMessage(none, 0, 0)), "ENV");
  EXPECT_EQ(got.name, "");
  EXPECT_TRUE(got.objects.empty());
}

TEST(EnvironmentMessage, BadMessagesAreRefused) {
  const sirupp::environment_t good = ToMessage(RichEnvironment(), 0, 0);
  ASSERT_NO_THROW(EnvironmentFromMessage(good, "ENVIRONMENT"));
  ASSERT_EQ(good.objects[2].shape.type, sirupp::shape_t::TYPE_CYLINDER);  // leg_front_right
  ASSERT_EQ(good.objects[7].shape.type, sirupp::shape_t::TYPE_SPHERE);    // ball
  struct Case {
    std::string expected;
    void (*spoil)(sirupp::environment_t&);
  };
  const Case cases[] = {
      {"num_objects: count 3 does not match the 9 entries sent",
       [](sirupp::environment_t& m) { m.num_objects = 3; }},
      {"objects[0].shape.type: 7 is not allowed; expected 0..3 (TYPE_*)",
       [](sirupp::environment_t& m) { m.objects[0].shape.type = 7; }},
      {"objects[1].shape.position[2]: nan is not allowed; expected a finite number (m)",
       [](sirupp::environment_t& m) { m.objects[1].shape.position[2] = std::nan(""); }},
      {"objects[0].shape.orientation: a quaternion of norm 2 is not allowed; expected a unit "
       "quaternion (w x y z)",
       [](sirupp::environment_t& m) { m.objects[0].shape.orientation[0] = 2; }},
      {"objects[0].shape.orientation: a quaternion of norm inf is not allowed; expected a unit "
       "quaternion (w x y z)",
       [](sirupp::environment_t& m) { m.objects[0].shape.orientation[3] = INFINITY; }},
      {"objects[0].shape.size[1]: 0 is not allowed; expected a finite number > 0 (m, box y edge)",
       [](sirupp::environment_t& m) { m.objects[0].shape.size[1] = 0; }},
      {"objects[2].shape.size[1]: -0.1 is not allowed; expected a finite number > 0 (m, "
       "cylinder length)",
       [](sirupp::environment_t& m) { m.objects[2].shape.size[1] = -0.1; }},
      {"objects[7].shape.size[2]: 0.5 is not allowed; expected 0 (a sphere uses 1 size)",
       [](sirupp::environment_t& m) { m.objects[7].shape.size[2] = 0.5; }},
      {"objects[7].shape.size[0]: inf is not allowed; expected a finite number > 0 (m, sphere "
       "radius)",
       [](sirupp::environment_t& m) { m.objects[7].shape.size[0] = INFINITY; }},
      {"objects[1].shape.color[3]: 1.5 is not allowed; expected 0..1",
       [](sirupp::environment_t& m) { m.objects[1].shape.color[3] = 1.5F; }},
      {"objects[0].is_static: 2 is not allowed; expected 1 (static) or 0 (free)",
       [](sirupp::environment_t& m) { m.objects[0].is_static = 2; }},
      {"objects[7].mass: 0 is not allowed; expected a finite number > 0 (kg) for a free object",
       [](sirupp::environment_t& m) { m.objects[7].mass = 0; }},
      {"objects[0].mass: -1 is not allowed; expected a finite number >= 0 (kg)",
       [](sirupp::environment_t& m) { m.objects[0].mass = -1; }},
      {"objects[3].friction: nan is not allowed; expected a finite number >= 0",
       [](sirupp::environment_t& m) { m.objects[3].friction = std::nan(""); }},
      {"objects[3].friction: -0.5 is not allowed; expected a finite number >= 0",
       [](sirupp::environment_t& m) { m.objects[3].friction = -0.5; }},
      {"objects[7].restitution: 2 is not allowed; expected a finite number in [0, 1]",
       [](sirupp::environment_t& m) { m.objects[7].restitution = 2; }},
      {"objects[4].name: an empty name is not allowed; expected a unique, non-empty object name",
       [](sirupp::environment_t& m) { m.objects[4].name = ""; }},
      {"objects[5].name: \"table_top\" is already the name of objects[0]; expected unique object "
       "names",
       [](sirupp::environment_t& m) { m.objects[5].name = "table_top"; }},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.expected);
    sirupp::environment_t bad = good;
    c.spoil(bad);
    EXPECT_EQ(ErrorText<MessageError>([&] { EnvironmentFromMessage(bad, "ENVIRONMENT"); }),
              "channel ENVIRONMENT: " + c.expected);
  }
}

// ---- limits -------------------------------------------------------------------------------------

// An environment of `statics` static 2 cm cubes on the floor and `frees` free ones, one per line
// after the two header lines.
std::string ManyBoxes(size_t statics, size_t frees) {
  std::string xml = "<?xml version=\"1.0\"?>\n<environment name=\"many\">\n";
  for (size_t i = 0; i < statics + frees; ++i) {
    const bool free = i >= statics;
    xml += std::string("  <box name=\"b") + std::to_string(i) +
           "\" size=\"0.02 0.02 0.02\" position=\"" +
           std::to_string(0.35 + 0.04 * static_cast<double>(i / 100)) + " " +
           std::to_string(-2.0 + 0.04 * static_cast<double>(i % 100)) + " 0.01\"" +
           (free ? " static=\"false\" mass=\"0.02\"" : "") + "/>\n";
  }
  return xml + "</environment>\n";
}

TEST(EnvironmentLimits, TheLimitsLoad) {
  const Environment environment =
      ParseEnvironment(ManyBoxes(kMaxStaticObjects, kMaxFreeObjects), "test.xml");
  EXPECT_EQ(environment.objects.size(), kMaxStaticObjects + kMaxFreeObjects);
  EXPECT_NO_THROW(EnvironmentFromMessage(ToMessage(environment, 0, 0), "ENVIRONMENT"));
}

TEST(EnvironmentLimits, MoreStaticObjectsAreRefusedNamingTheCountAndTheLimit) {
  EXPECT_EQ(ParseError(ManyBoxes(kMaxStaticObjects + 2, 0)),
            "test.xml:10003: box \"b10000\": the file has 10002 static objects; allowed at most "
            "10000 (this is the first one over the limit; docs/environment-format.md, \"Limits\")");
}

TEST(EnvironmentLimits, MoreFreeObjectsAreRefusedNamingTheCountAndTheLimit) {
  EXPECT_EQ(ParseError(ManyBoxes(3, kMaxFreeObjects + 1)),
            "test.xml:56: box \"b53\": the file has 51 free objects; allowed at most 50 (this is "
            "the first one over the limit; docs/environment-format.md, \"Limits\")");
}

TEST(EnvironmentLimits, MessagesOverTheLimitsAreRefused) {
  const Environment few = ParseEnvironment(ManyBoxes(2, 1), "test.xml");
  sirupp::environment_t message = ToMessage(few, 0, 0);
  const sirupp::environment_object_t free_box = message.objects.back();
  for (size_t i = 0; i < kMaxFreeObjects; ++i) {
    message.objects.push_back(free_box);
    message.objects.back().name = "extra" + std::to_string(i);
  }
  message.num_objects = static_cast<int32_t>(message.objects.size());
  EXPECT_EQ(ErrorText<MessageError>([&] { EnvironmentFromMessage(message, "ENVIRONMENT"); }),
            "channel ENVIRONMENT: objects: 51 free objects; allowed at most 50");
}

// ---- malformed files ----------------------------------------------------------------------------

constexpr const char* kCorpus = "tests/data/bad_environments";

// The "LINE: TEXT" of the file's "<!-- expect: LINE: TEXT -->" line (line 2), or "".
std::string ExpectedText(const std::string& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  std::getline(in, line);
  const std::string prefix = "<!-- expect: ";
  const std::string suffix = " -->";
  if (line.rfind(prefix, 0) != 0 || line.size() < prefix.size() + suffix.size() ||
      line.compare(line.size() - suffix.size(), suffix.size(), suffix) != 0) {
    return "";
  }
  return line.substr(prefix.size(), line.size() - prefix.size() - suffix.size());
}

TEST(BadEnvironments, CorpusHasAtLeastFifteenFiles) {
  EXPECT_GE(FilesIn(kCorpus, ".xml").size(), 15U);
}

TEST(BadEnvironments, EachFileFailsWithItsMessage) {
  for (const std::string& file : FilesIn(kCorpus, ".xml")) {
    SCOPED_TRACE(file);
    const std::string expected = ExpectedText(file);
    ASSERT_FALSE(expected.empty()) << "line 2 is not '<!-- expect: LINE: TEXT -->'";
    const int line = std::atoi(expected.c_str());
    ASSERT_GT(line, 0) << "the expected text does not start with the line number";
    try {
      LoadEnvironment(file);
      ADD_FAILURE() << "loaded without error";
    } catch (const ConfigError& error) {
      const std::string what = error.what();
      EXPECT_EQ(error.where().file, file);
      EXPECT_EQ(error.where().line, line);
      EXPECT_EQ(what.rfind(file + ":" + std::to_string(line) + ": ", 0), 0U) << what;
      EXPECT_NE(what.find(file + ":" + expected), std::string::npos) << what;
    }
  }
}

}  // namespace
}  // namespace sirupp::core
