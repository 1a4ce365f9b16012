#include "control/plan.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string_view>

#include "control/pose_goal.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "core/motion_limits.hpp"
#include "core/printable.hpp"

namespace sirupp::control {
namespace {

constexpr double kDegree = M_PI / 180.0;
constexpr const char kByteOrderMark[] = "\xEF\xBB\xBF";

// A token of the plan as it may be shown in a message: escaped, and cut if very long.
std::string Show(const std::string& text) { return core::Printable(text, 64); }

struct Token {
  std::string text;
  int column = 0;  // 1-based
};

// Splits a line (comment already removed) at spaces and tabs, keeping each token's column.
std::vector<Token> Tokenize(const std::string& line) {
  std::vector<Token> tokens;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= line.size()) break;
    const size_t begin = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    tokens.push_back({line.substr(begin, i - begin), static_cast<int>(begin) + 1});
  }
  return tokens;
}

// A speed or acceleration as written: a fraction of each joint's default, or a value in the
// plan's units per second (or per second squared).
struct Rate {
  bool percent = true;
  double value = 100;
  int column = 0;  // where it was written on a move line; 0 for the plan-wide setting
};

struct Units {
  std::string angle = "deg";
  double angle_si = kDegree;
  std::string length = "m";
  double length_si = 1;
};

class Parser {
 public:
  Parser(const std::string& name, const core::RobotModel& model, const std::vector<double>& start,
         bool allow_avoid = false)
      : name_(core::Printable(name, 256)),
        model_(model),
        reached_(start),
        allow_avoid_(allow_avoid) {
    if (static_cast<int>(start.size()) != model.num_joints()) {
      throw std::invalid_argument("plan start has " + std::to_string(start.size()) +
                                  " joints; the model has " + std::to_string(model.num_joints()));
    }
  }

  Plan Parse(std::string_view text) {
    if (text.size() > kMaxPlanBytes) {
      throw core::ConfigError({name_, 0, 0}, "",
                              "the plan has " + std::to_string(text.size()) +
                                  " bytes; allowed at most " + std::to_string(kMaxPlanBytes) +
                                  " (256 KiB, so that it travels in one ARM_PLAN message); split "
                                  "it into several plans");
    }
    // An editor's UTF-8 byte-order mark is not part of the first statement.
    if (text.substr(0, 3) == kByteOrderMark) text.remove_prefix(3);
    Plan plan;
    plan.name = name_;
    std::istringstream lines{std::string(text)};
    std::string raw;
    while (std::getline(lines, raw)) {
      ++line_;
      const std::string content = raw.substr(0, raw.find('#'));
      tokens_ = Tokenize(content);
      if (tokens_.empty()) continue;
      text_ = content.substr(static_cast<size_t>(tokens_.front().column - 1));
      while (!text_.empty() &&
             (text_.back() == ' ' || text_.back() == '\t' || text_.back() == '\r')) {
        text_.pop_back();
      }
      for (char& c : text_) c = c == '\t' ? ' ' : c;  // shown in one line of status output
      text_ = core::Printable(text_);
      Statement(plan);
    }
    if (plan.moves() == 0) {
      throw core::ConfigError({name_, line_ > 0 ? line_ : 1, 0}, "",
                              "the plan has no move; write at least one `move` line "
                              "(docs/plan-format.md)");
    }
    plan.final_goal = reached_;
    return plan;
  }

 private:
  [[noreturn]] void Fail(const Token& at, const std::string& problem) const {
    throw core::ConfigError({name_, line_, at.column}, Show(tokens_.front().text), problem);
  }

  double Number(const Token& token, const std::string& what) const {
    const char* begin = token.text.c_str();
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(begin, &end);
    if (end == begin || end != begin + token.text.size() || errno == ERANGE ||
        !std::isfinite(value)) {
      Fail(token, what + " '" + Show(token.text) + "' is not a finite number");
    }
    return value;
  }

  void Statement(Plan& plan) {
    const std::string& word = tokens_.front().text;
    if (word == "units") return UnitsLine();
    if (word == "speed" || word == "accel") {
      if (tokens_.size() != 2) {
        Fail(tokens_.front(), "expected one value, e.g. `" + word + " 50%` or `" + word + " " +
                                  (word == "speed" ? "30` (deg/s)" : "60` (deg/s^2)"));
      }
      (word == "speed" ? speed_ : accel_) = ParseRate(tokens_[1], word);
      (word == "speed" ? speed_ : accel_).column = 0;
      return;
    }
    if (word == "wait") return WaitLine(plan);
    if (word == "move") return MoveLine(plan);
    Fail(tokens_.front(), "unknown statement '" + Show(word) +
                              "'; allowed: move, wait, speed, accel, units (lines starting with # "
                              "are comments)");
  }

  void UnitsLine() {
    if (tokens_.size() < 2) Fail(tokens_.front(), "expected deg|rad and/or m|mm|cm|inch");
    for (size_t i = 1; i < tokens_.size(); ++i) {
      const std::string& unit = tokens_[i].text;
      if (unit == "deg" || unit == "rad") {
        units_.angle = unit;
        units_.angle_si = unit == "deg" ? kDegree : 1.0;
      } else if (unit == "m" || unit == "mm" || unit == "cm" || unit == "inch") {
        units_.length = unit;
        units_.length_si = unit == "m" ? 1.0 : unit == "mm" ? 1e-3 : unit == "cm" ? 1e-2 : 0.0254;
      } else {
        Fail(tokens_[i], "unknown unit '" + Show(unit) + "'; allowed: deg, rad, m, mm, cm, inch");
      }
    }
  }

  Rate ParseRate(const Token& token, const std::string& what) const {
    Rate rate;
    Token number = token;
    rate.percent = !token.text.empty() && token.text.back() == '%';
    if (rate.percent) number.text.pop_back();
    rate.value = Number(number, what);
    rate.column = token.column;
    if (!(rate.value > 0)) {
      Fail(token, what + " " + Show(token.text) + " must be greater than 0");
    }
    return rate;
  }

  void WaitLine(Plan& plan) {
    PlanStep step;
    step.line = line_;
    step.text = text_;
    if (tokens_.size() != 2) {
      Fail(tokens_.front(), "expected `wait done` or `wait SECONDS` (e.g. `wait 0.5`)");
    }
    if (tokens_[1].text == "done") {
      step.kind = PlanStep::Kind::kWaitDone;
    } else {
      Token seconds = tokens_[1];
      if (!seconds.text.empty() && seconds.text.back() == 's') seconds.text.pop_back();
      step.kind = PlanStep::Kind::kWaitTime;
      step.wait_s = Number(seconds, "wait time");
      if (step.wait_s < 0 || step.wait_s > 3600) {
        Fail(tokens_[1], "wait time " + Show(tokens_[1].text) + " is outside 0..3600 s");
      }
    }
    plan.steps.push_back(step);
  }

  // The unit a joint's values are written in, and the factor to SI.
  double JointUnit(const core::Joint& joint) const {
    return joint.type == core::JointType::kRevolute ? units_.angle_si : units_.length_si;
  }
  std::string JointUnitName(const core::Joint& joint) const {
    return joint.type == core::JointType::kRevolute ? units_.angle : units_.length;
  }

  // The joint named by `j3` (1-based) or by its name in the model; -1 if none.
  int FindJoint(const std::string& key) const {
    for (int j = 0; j < model_.num_joints(); ++j) {
      if (model_.joints[static_cast<size_t>(j)].name == key) return j;
    }
    if (key.size() >= 2 && key[0] == 'j') {
      const std::string digits = key.substr(1);
      if (digits.find_first_not_of("0123456789") == std::string::npos && digits.size() <= 3) {
        const int number = std::stoi(digits);
        if (number >= 1 && number <= model_.num_joints()) return number - 1;
      }
    }
    return -1;
  }

  std::string JointNames() const {
    std::string names = "j1..j" + std::to_string(model_.num_joints());
    std::string list;
    for (const core::Joint& joint : model_.joints) {
      if (joint.name.empty()) continue;
      list += (list.empty() ? "" : ", ") + joint.name;
    }
    return list.empty() ? names : names + " or " + list;
  }

  // One `move` line as read: the goals (SI) of the joints that move, where each was written, the
  // options, and the words of a `joints`, `pose` or `tool` form.
  struct MoveRequest {
    std::vector<std::optional<double>> goal;
    std::vector<int> goal_column;
    Rate speed;
    Rate accel;
    std::optional<core::IkConfiguration> config;
    bool config_given = false;
    std::vector<Token> words;
    std::optional<Token> avoid;  // the `avoid` word: a planned path to this line's goal
  };

  void MoveLine(Plan& plan) {
    if (tokens_.size() < 2) {
      Fail(tokens_.front(),
           "expected what to move: `move J=VALUE ...`, `move joints V1 .. VN`, "
           "`move pose NAME` or `move tool X Y Z [ROLL PITCH YAW]`");
    }
    MoveRequest request = MoveKeys();
    if (request.words.empty()) {
      bool any = false;
      for (const auto& g : request.goal) any = any || g.has_value();
      if (!any) Fail(tokens_.front(), "no joint to move; e.g. `move j1=90`");
    } else {
      MoveForm(request);
    }
    if (request.config_given && (request.words.empty() || request.words.front().text != "tool")) {
      Fail(tokens_.front(), "config= applies only to `move tool`");
    }
    if (request.avoid) {
      if (!allow_avoid_) {
        Fail(*request.avoid,
             "`avoid` asks for a path planned around the environment, which is made before the "
             "plan runs: expand it with `sirupp plan make --expand FILE --env ENV -o OUT` "
             "(docs/planning.md)");
      }
      if (!plan.steps.empty() && plan.steps.back().kind != PlanStep::Kind::kWaitDone) {
        Fail(*request.avoid,
             "`avoid` plans from where the arm stands: put `wait done` before this line");
      }
    }
    const std::vector<double> from = reached_;
    plan.steps.push_back(MoveStep(request));
    if (request.avoid) {
      plan.steps.back().avoid = true;
      plan.steps.back().from = from;
    }
  }

  // The KEY=VALUE tokens of a `move` line (joints, and the options speed, accel, config, which may
  // follow any form); the other tokens are the request's words.
  MoveRequest MoveKeys() {
    const size_t n = static_cast<size_t>(model_.num_joints());
    MoveRequest request;
    request.goal.resize(n);
    request.goal_column.assign(n, 0);
    request.speed = speed_;
    request.accel = accel_;
    for (size_t i = 1; i < tokens_.size(); ++i) {
      const Token& token = tokens_[i];
      const size_t equals = token.text.find('=');
      if (token.text == "avoid") {
        request.avoid = token;
        continue;
      }
      if (equals == std::string::npos) {
        request.words.push_back(token);
        continue;
      }
      const std::string key = token.text.substr(0, equals);
      Token value{token.text.substr(equals + 1), token.column + static_cast<int>(equals) + 1};
      if (value.text.empty()) Fail(token, "'" + Show(key) + "=' has no value");
      if (key == "speed") {
        request.speed = ParseRate(value, "speed");
      } else if (key == "accel") {
        request.accel = ParseRate(value, "accel");
      } else if (key == "config") {
        request.config_given = true;
        if (value.text != "nearest") {
          request.config = core::IkConfiguration::Parse(value.text);
          if (!request.config) {
            Fail(value, "configuration '" + Show(value.text) +
                            "' is not allowed; expected nearest or SHOULDER-ELBOW-WRIST with "
                            "left|right, up|down, noflip|flip (e.g. right-up-noflip)");
          }
        }
      } else {
        const int joint = FindJoint(key);
        if (joint < 0) {
          Fail(token, "'" + Show(key) + "' is neither a joint (" + JointNames() +
                          ") nor an option (speed, accel, config)");
        }
        const auto j = static_cast<size_t>(joint);
        if (request.goal[j]) Fail(token, "joint " + Show(key) + " is given twice on this line");
        request.goal[j] =
            Number(value, "joint " + Show(key) + " value") * JointUnit(model_.joints[j]);
        request.goal_column[j] = value.column;
      }
    }
    return request;
  }

  // The goals of `move joints V1 .. VN`, `move pose NAME` or `move tool ...`.
  void MoveForm(MoveRequest& request) {
    const size_t n = static_cast<size_t>(model_.num_joints());
    const std::vector<Token>& words = request.words;
    std::vector<std::optional<double>>& goal = request.goal;
    for (const auto& g : goal) {
      if (g) Fail(words.front(), "mixes J=VALUE with `" + Show(words.front().text) + " ...`");
    }
    const std::string& form = words.front().text;
    if (form == "joints") {
      if (words.size() != n + 1) {
        Fail(words.front(), "expected " + std::to_string(n) + " values (one per joint), got " +
                                std::to_string(words.size() - 1));
      }
      for (size_t j = 0; j < n; ++j) {
        goal[j] = Number(words[j + 1], "joint j" + std::to_string(j + 1) + " value") *
                  JointUnit(model_.joints[j]);
        request.goal_column[j] = words[j + 1].column;
      }
    } else if (form == "pose") {
      if (words.size() != 2) Fail(words.front(), "expected one pose name, e.g. `move pose ready`");
      const core::NamedPose* pose = model_.FindNamedPose(words[1].text);
      if (pose == nullptr && words[1].text != "home") {
        std::string names = "home";
        for (const core::NamedPose& p : model_.named_poses) names += ", " + p.name;
        Fail(words[1], "no pose named '" + Show(words[1].text) + "' in model " + model_.name +
                           "; allowed: " + names);
      }
      for (size_t j = 0; j < n; ++j) {
        goal[j] = pose != nullptr ? pose->position[j] : model_.joints[j].home;
        request.goal_column[j] = words[1].column;
      }
    } else if (form == "tool") {
      ToolGoal(words, request.config, goal, request.goal_column);
    } else {
      Fail(words.front(),
           "unknown move form '" + Show(form) + "'; allowed: J=VALUE ..., joints, pose, tool");
    }
  }

  // The step of a read `move` line: each goal within its joint's limits, speeds within its maximum.
  PlanStep MoveStep(const MoveRequest& request) {
    const size_t n = static_cast<size_t>(model_.num_joints());
    const Rate& speed = request.speed;
    const Rate& accel = request.accel;
    PlanStep step;
    step.kind = PlanStep::Kind::kMove;
    step.line = line_;
    step.text = text_;
    step.moves.resize(n);
    for (size_t j = 0; j < n; ++j) {
      if (!request.goal[j]) continue;
      const double goal = *request.goal[j];
      const core::Joint& joint = model_.joints[j];
      const double unit = JointUnit(joint);
      const std::string label =
          "joint j" + std::to_string(j + 1) + (joint.name.empty() ? "" : " (" + joint.name + ")");
      if (goal < joint.position_min || goal > joint.position_max) {
        throw core::ConfigError(
            {name_, line_, request.goal_column[j]}, Show(tokens_.front().text),
            label + " goal " + core::FormatApprox(goal / unit) + " " + JointUnitName(joint) +
                " is outside its limits [" + core::FormatApprox(joint.position_min / unit) + ", " +
                core::FormatApprox(joint.position_max / unit) + "] " + JointUnitName(joint));
      }
      JointMove& move = step.moves[j];
      move.active = true;
      move.goal = goal;
      move.velocity =
          speed.percent ? joint.servo.default_velocity * speed.value / 100.0 : speed.value * unit;
      move.acceleration = accel.percent ? joint.servo.default_acceleration * accel.value / 100.0
                                        : accel.value * unit;
      if (move.velocity > joint.velocity_max * (1 + 1e-12)) {
        Fail(Token{"", speed.column > 0 ? speed.column : 1},
             label + " speed " + core::FormatApprox(move.velocity / unit) + " " +
                 JointUnitName(joint) + "/s is above its maximum " +
                 core::FormatApprox(joint.velocity_max / unit) + " " + JointUnitName(joint) + "/s");
      }
      reached_[j] = move.goal;
    }
    return step;
  }

  // `move tool X Y Z [ROLL PITCH YAW]`: the IK solution (by configuration, or nearest the joints
  // the plan has reached) becomes every joint's goal.
  void ToolGoal(const std::vector<Token>& words, const std::optional<core::IkConfiguration>& config,
                std::vector<std::optional<double>>& goal, std::vector<int>& goal_column) {
    if (words.size() != 4 && words.size() != 7) {
      Fail(words.front(), "expected X Y Z (position only) or X Y Z ROLL PITCH YAW, got " +
                              std::to_string(words.size() - 1) + " values");
    }
    const char* names[] = {"X", "Y", "Z", "ROLL", "PITCH", "YAW"};
    double v[6] = {0, 0, 0, 0, 0, 0};
    for (size_t i = 1; i < words.size(); ++i) {
      v[i - 1] = Number(words[i], std::string("tool ") + names[i - 1]);
    }
    PoseRequest request;
    request.target.translation() << v[0] * units_.length_si, v[1] * units_.length_si,
        v[2] * units_.length_si;
    request.target.linear() =
        core::QuaternionFromRpy(v[3] * units_.angle_si, v[4] * units_.angle_si,
                                v[5] * units_.angle_si)
            .toRotationMatrix();
    request.position_only = words.size() == 4;
    if (config) request.SetConfig(*config);
    const PoseGoal solved = SolvePoseGoal(model_, request, core::ToJointVector(reached_));
    if (!solved.ok) Fail(words.front(), "no joint solution for this tool pose: " + solved.reason);
    for (size_t j = 0; j < goal.size(); ++j) {
      goal[j] = solved.q[static_cast<Eigen::Index>(j)];
      goal_column[j] = words.front().column;
    }
  }

  std::string name_;
  const core::RobotModel& model_;
  std::vector<double> reached_;
  bool allow_avoid_ = false;  // each joint's goal after the steps so far, SI
  Units units_;
  Rate speed_;
  Rate accel_;
  int line_ = 0;
  std::vector<Token> tokens_;
  std::string text_;
};

}  // namespace

int Plan::moves() const {
  int count = 0;
  for (const PlanStep& step : steps) count += step.kind == PlanStep::Kind::kMove ? 1 : 0;
  return count;
}

Plan ParsePlan(const std::string& text, const std::string& name, const core::RobotModel& model,
               const std::vector<double>& start) {
  return ParsePlanWithAvoid(text, name, model, start, false);
}

Plan ParsePlanWithAvoid(const std::string& text, const std::string& name,
                        const core::RobotModel& model, const std::vector<double>& start,
                        bool allow_avoid) {
  Parser parser(name, model, start, allow_avoid);
  Plan plan = parser.Parse(text);
  // One set of motion limits: what the real arm's bridge would refuse is refused here, before
  // the virtual arm moves (core/motion_limits.hpp).
  const core::MotionLimits limits = core::DefaultMotionLimits(model);
  for (const PlanStep& step : plan.steps) {
    for (int j = 0; j < static_cast<int>(step.moves.size()); ++j) {
      const JointMove& move = step.moves[static_cast<size_t>(j)];
      if (!move.active) continue;
      if (const auto reason =
              core::CheckJointMove(model, limits, j, move.goal, move.velocity, move.acceleration)) {
        throw core::ConfigError({core::Printable(name, 256), step.line, 1}, "move",
                                *reason + " (the real arm's bridge refuses it too)");
      }
    }
  }
  return plan;
}

std::string ReadPlanText(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  const std::string shown = core::Printable(path, 256);
  if (!file) throw core::ConfigError({shown, 0, 0}, "", "cannot open the plan file");
  // Never more than one byte over the limit: ParsePlan then refuses it, naming the limit.
  std::string text(kMaxPlanBytes + 1, '\0');
  file.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(file.gcount()));
  if (text.size() > kMaxPlanBytes) {
    std::error_code error;
    const auto size = std::filesystem::file_size(path, error);
    throw core::ConfigError(
        {shown, 0, 0}, "",
        "the plan file has " +
            (error ? "more than " + std::to_string(kMaxPlanBytes) : std::to_string(size)) +
            " bytes; allowed at most " + std::to_string(kMaxPlanBytes) +
            " (256 KiB, so that it travels in one ARM_PLAN message); split "
            "it into several plans");
  }
  return text;
}

Plan LoadPlan(const std::string& path, const core::RobotModel& model,
              const std::vector<double>& start) {
  return ParsePlan(ReadPlanText(path), path, model, start);
}

std::vector<double> HomePositions(const core::RobotModel& model) {
  std::vector<double> home;
  for (const core::Joint& joint : model.joints) home.push_back(joint.home);
  return home;
}

}  // namespace sirupp::control
