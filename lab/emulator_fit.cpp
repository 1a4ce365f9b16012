#include "lab/emulator_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "core/dynamics.hpp"
#include "core/errors.hpp"
#include "lab/box_search.hpp"

namespace sirupp::lab {
namespace {

namespace range = hardware::real_arm_range;

constexpr double kDegToRad = 3.14159265358979323846 / 180;

double Robust(double z) { return z * z / (1 + z * z / 4); }

double Tolerance(double paper) { return std::max(0.3 * paper, 0.5); }

// One fitted number: how to read and write it and its range. The search works on u in [0, 1]:
// x = min + u (max - min), or min (max / min)^u for a log-scaled number.
struct Param {
  std::string name;
  std::function<double(const hardware::RealArmParams&)> get;
  std::function<void(hardware::RealArmParams&, double)> set;
  double min, max;
  bool log_scale;

  double FromUnit(double u) const { return BoxAxis{min, max, log_scale}.FromUnit(u); }
  double ToUnit(double x) const { return BoxAxis{min, max, log_scale}.ToUnit(x); }
};

// The fitted numbers. The fit's ranges are the file's, narrowed to what a PUMA 260's small DC
// servo motors and their supply plausibly are (docs/emulator-fit.md): torque constant 0.02..0.08
// N*m/A, winding resistance 1..8 ohm, supply 18..48 V with at most 2 ohm source resistance.
std::vector<Param> Params(bool fit_latency) {
  std::vector<Param> p;
  if (fit_latency) {
    p.push_back({"board.command_latency_s",
                 [](const hardware::RealArmParams& a) { return a.command_latency_s; },
                 [](hardware::RealArmParams& a, double v) { a.command_latency_s = v; },
                 range::kCommandLatency.min, 0.2, false});
  }
  p.push_back({"supply.voltage_v",
               [](const hardware::RealArmParams& a) { return a.supply_voltage_v; },
               [](hardware::RealArmParams& a, double v) { a.supply_voltage_v = v; }, 18, 48, true});
  p.push_back({"supply.resistance_ohm",
               [](const hardware::RealArmParams& a) { return a.supply_resistance_ohm; },
               [](hardware::RealArmParams& a, double v) { a.supply_resistance_ohm = v; },
               range::kSupplyResistance.min, 2, false});
  for (size_t j = 0; j < 3; ++j) {
    const std::string at = "joints[" + std::to_string(j) + "].";
    p.push_back({at + "motor.torque_constant_nm_a",
                 [j](const hardware::RealArmParams& a) {
                   return a.joints[j].motor.torque_constant_nm_per_a;
                 },
                 [j](hardware::RealArmParams& a, double v) {
                   a.joints[j].motor.torque_constant_nm_per_a = v;
                 },
                 0.02, 0.08, true});
    p.push_back(
        {at + "motor.resistance_ohm",
         [j](const hardware::RealArmParams& a) { return a.joints[j].motor.resistance_ohm; },
         [j](hardware::RealArmParams& a, double v) { a.joints[j].motor.resistance_ohm = v; }, 1, 8,
         true});
    // The friction levels together (static and Coulomb, both ways), by the positive static level.
    p.push_back({at + "friction.static_nm[0] (all levels scaled)",
                 [j](const hardware::RealArmParams& a) { return a.joints[j].static_nm[0]; },
                 [j](hardware::RealArmParams& a, double v) {
                   hardware::JointEffects& e = a.joints[j];
                   const double k = v / e.static_nm[0];
                   for (int d = 0; d < 2; ++d) {
                     e.static_nm[d] *= k;
                     e.coulomb_nm[d] *= k;
                   }
                 },
                 0.1, range::kStatic.max / 1.2, true});
    // Coulomb over static (both ways scaled): how far the friction drops once the joint slides.
    p.push_back({at + "friction.coulomb_nm[0] / static_nm[0]",
                 [j](const hardware::RealArmParams& a) {
                   return a.joints[j].coulomb_nm[0] / a.joints[j].static_nm[0];
                 },
                 [j](hardware::RealArmParams& a, double v) {
                   hardware::JointEffects& e = a.joints[j];
                   const double k = v * e.static_nm[0] / e.coulomb_nm[0];
                   for (int d = 0; d < 2; ++d) {
                     e.coulomb_nm[d] = std::min(e.coulomb_nm[d] * k, e.static_nm[d]);
                   }
                 },
                 0.3, 1.0, false});
    // Viscous friction (gear and bearing losses growing with speed).
    p.push_back(
        {at + "friction.viscous_nm_s_rad",
         [j](const hardware::RealArmParams& a) { return a.joints[j].viscous_nm_s_per_rad; },
         [j](hardware::RealArmParams& a, double v) { a.joints[j].viscous_nm_s_per_rad = v; }, 0, 3,
         false});
  }
  return p;
}

std::string Describe(const Param& p, double value) {
  return p.name + " " + core::FormatNumber(std::round(value * 1e5) / 1e5) + " (range " +
         core::FormatNumber(p.min) + ".." + core::FormatNumber(p.max) + ")";
}

}  // namespace

std::vector<LeftOutMean> ParseLeftOutMeans(const std::string& text) {
  std::vector<LeftOutMean> result;
  if (text == "none") return result;
  std::string rows;
  for (const PaperRow& p : PaperTable()) {
    rows +=
        (rows.empty() ? "" : ", ") + std::string(RomanSet(p.set)) + "-" + std::to_string(p.joint);
  }
  const std::string allowed = "allowed: a comma list of the paper's rows (" + rows +
                              "; or 1-1, 2-2, ...), each optionally with :transient or "
                              ":steady, or none";
  std::stringstream list(text);
  std::string item;
  while (std::getline(list, item, ',')) {
    const size_t colon = item.find(':');
    const std::string row = item.substr(0, colon);
    const bool whole = colon == std::string::npos;
    const std::string mean = whole ? "" : item.substr(colon + 1);
    LeftOutMean m;
    m.transient = whole || mean == "transient";
    m.steady = whole || mean == "steady";
    const size_t dash = row.find('-');
    if (dash != std::string::npos && dash + 2 == row.size() && row[dash + 1] >= '1' &&
        row[dash + 1] <= '9') {
      m.set = SetFromName(row.substr(0, dash));
      m.joint = row[dash + 1] - '0';
    }
    const bool in_table =
        std::any_of(PaperTable().begin(), PaperTable().end(),
                    [&](const PaperRow& p) { return p.set == m.set && p.joint == m.joint; });
    if (!in_table || !(m.transient || m.steady)) {
      throw std::invalid_argument("'" + item + "' is not allowed; " + allowed);
    }
    result.push_back(m);
  }
  if (result.empty()) throw std::invalid_argument("'" + text + "' is not allowed; " + allowed);
  return result;
}

std::string FormatLeftOutMeans(const std::vector<LeftOutMean>& left_out) {
  std::string text;
  for (const LeftOutMean& m : left_out) {
    text += (text.empty() ? "" : ", ") + std::string(RomanSet(m.set)) + "-" +
            std::to_string(m.joint) +
            (m.transient && m.steady ? ""
             : m.transient           ? " transient"
                                     : " steady");
  }
  return text.empty() ? "none" : text;
}

const std::vector<LeftOutMean>& ContradictoryMeans() {
  static const std::vector<LeftOutMean> kMeans = {
      {5, 1, false, true}, {5, 3, true, false}, {6, 2, false, true}, {6, 3, true, false}};
  return kMeans;
}

double FitCost(const std::vector<TableRow>& table, double coupling_weight,
               const std::vector<LeftOutMean>& left_out) {
  // Whether the transient (or else the steady) mean of a row is left out.
  auto left = [&](const TableRow& row, bool transient) {
    return std::any_of(left_out.begin(), left_out.end(), [&](const LeftOutMean& m) {
      return m.set == row.set && m.joint == row.joint && (transient ? m.transient : m.steady);
    });
  };
  double cost = 0;
  std::vector<TableRow> coupled;  // the rows whose transient counts
  for (const TableRow& row : table) {
    if (!left(row, true)) coupled.push_back(row);
    for (const PaperRow& p : PaperTable()) {
      if (p.set != row.set || p.joint != row.joint) continue;
      const auto misfit = [](double ours, double paper) {
        return std::isfinite(ours) ? Robust((ours - paper) / Tolerance(paper)) : 4.0;
      };
      if (!left(row, true)) cost += misfit(row.transient_deg, p.transient_deg);
      if (!left(row, false)) cost += misfit(row.steady_deg, p.steady_deg);
    }
    if (row.joint == 1) {
      const double mid = (kPaperStartDelayMin + kPaperStartDelayMax) / 2;
      cost += std::isfinite(row.start_delay_real_s) ? Robust((row.start_delay_real_s - mid) / 0.05)
                                                    : 4.0;
    }
  }
  // The paper's main finding: joints moving together lag more than alone (sets IV, VII vs I-III),
  // over the pairs whose transients both count.
  const Comparison c = Compare(coupled);
  cost += coupling_weight * Robust((c.coupling_ours_deg - c.coupling_paper_deg) / 0.25);
  return cost;
}

std::vector<double> SpeedMargins(const hardware::RealArmParams& arm,
                                 const core::RobotModel& model) {
  // The largest gravity load of each joint over the shoulder and elbow's range (15 deg steps; the
  // waist's and the wrist's angles hardly change it).
  const size_t n = model.joints.size();
  std::vector<double> gravity(n, 0.0);
  if (n >= 3) {
    const core::Dynamics dynamics(model);
    core::JointVector q = core::JointVector::Zero(static_cast<Eigen::Index>(n));
    for (int a = -180; a < 180; a += 15) {
      for (int b = -180; b < 180; b += 15) {
        q[1] =
            std::clamp(a * kDegToRad, model.joints[1].position_min, model.joints[1].position_max);
        q[2] =
            std::clamp(b * kDegToRad, model.joints[2].position_min, model.joints[2].position_max);
        const core::JointVector g = dynamics.GravityEffort(q);
        for (size_t j = 0; j < n; ++j) {
          gravity[j] = std::max(gravity[j], std::abs(g[static_cast<Eigen::Index>(j)]));
        }
      }
    }
  }
  std::vector<double> margins;
  for (size_t j = 0; j < 3 && j < n; ++j) {
    const hardware::JointEffects& e = arm.joints[j];
    const double speed = model.joints[j].velocity_max;
    const double gear = std::abs(model.joints[j].servo.gear_ratio);
    const double kt = e.motor.torque_constant_nm_per_a;
    // At full PWM the motor sees the supply through its source resistance (an H-bridge at duty 1
    // draws the motor's current).
    const double current =
        std::min(e.motor.current_limit_a, (arm.supply_voltage_v - kt * gear * speed) /
                                              (e.motor.resistance_ohm + arm.supply_resistance_ohm));
    const double load =
        std::max(e.coulomb_nm[0], e.coulomb_nm[1]) + e.viscous_nm_s_per_rad * speed + gravity[j];
    margins.push_back(load > 0 ? std::max(0.0, current) * kt * gear / load
                               : std::numeric_limits<double>::infinity());
  }
  return margins;
}

double HoldCost(double hold_stray_deg) { return Robust(hold_stray_deg / 0.5); }

FitResult FitEmulator(const core::RobotModel& virtual_model, const core::RobotModel& real_model,
                      const hardware::RealArmParams& start, const FitOptions& options) {
  std::vector<VirtualRun> virtual_runs;
  for (int set : options.experiment.sets) {
    virtual_runs.push_back(RunVirtual(virtual_model, set, options.experiment));
  }
  FitResult result;
  double stray = 0;  // of the last evaluation
  auto evaluate = [&](const hardware::RealArmParams& params, std::vector<TableRow>* table) {
    std::vector<logger::RunTable> tables;
    double hold = 0;
    stray = 0;
    for (const VirtualRun& v : virtual_runs) {
      const std::vector<std::vector<double>> real = RunReal(real_model, params, v);
      const double s = HoldStrayDeg(v, real);
      hold += HoldCost(s);
      stray = std::max(stray, s);
      tables.push_back(MakeTable(real_model, v, real));
    }
    *table = TableII(tables);
    ++result.evaluations;
    return FitCost(*table, options.coupling_weight, options.left_out) + hold;
  };
  const std::vector<Param> params = Params(!options.latency_s);
  const size_t n = params.size();
  hardware::CheckRealArmParams(start, real_model);
  hardware::RealArmParams base = start;  // the start, with the latency held if asked
  if (options.latency_s) base.command_latency_s = *options.latency_s;
  hardware::CheckRealArmParams(base, real_model);
  // The parameters at u (those of `start`, latency held if asked, for the rest); the cost of an arm
  // outside a range the file allows is infinite.
  auto at = [&](const std::vector<double>& u) {
    hardware::RealArmParams a = base;
    for (size_t i = 0; i < n; ++i) params[i].set(a, params[i].FromUnit(u[i]));
    return a;
  };
  // The start's cost as given; the search's best starts as the start clamped into the fit's
  // ranges, so the result is always an arm within them.
  std::vector<TableRow> best_table;
  result.cost_before = evaluate(start, &best_table);
  std::vector<double> centre(n);
  for (size_t i = 0; i < n; ++i) centre[i] = params[i].ToUnit(params[i].get(base));
  hardware::RealArmParams best = at(centre);
  double best_cost = evaluate(best, &best_table);
  for (double margin : SpeedMargins(best, real_model)) {
    // A start that cannot drive itself at top speed is replaced by the first point that can.
    if (margin < kMinSpeedMargin) best_cost = std::numeric_limits<double>::infinity();
  }
  double best_stray = stray;
  auto cost_of = [&](const std::vector<double>& u) {
    const hardware::RealArmParams a = at(u);
    try {
      hardware::CheckRealArmParams(a, real_model);
    } catch (const std::invalid_argument&) {
      return std::numeric_limits<double>::infinity();
    }
    for (double margin : SpeedMargins(a, real_model)) {
      if (margin < kMinSpeedMargin) return std::numeric_limits<double>::infinity();
    }
    std::vector<TableRow> table;
    const double cost = evaluate(a, &table);
    if (cost < best_cost) {
      best = a;
      best_cost = cost;
      best_table = table;
      best_stray = stray;
      if (options.progress) options.progress(result.evaluations, cost, "new best");
    }
    return cost;
  };
  // Nelder-Mead on the unit box, restarted around the best point with a smaller simplex whenever
  // the simplex collapses (box_search.hpp), until the budget is spent.
  BoxSearch search(centre, best_cost);
  // Points out of range cost no simulation; the asks are bounded too, in case the search keeps
  // proposing them.
  for (long asked = 0; result.evaluations < options.max_evaluations &&
                       asked < 50L * std::max(options.max_evaluations, 1);
       ++asked) {
    search.Tell(cost_of(search.Ask()));
  }
  result.params = best;
  result.table = best_table;
  result.cost_after = best_cost;
  result.hold_stray_deg = best_stray;
  for (const Param& p : params) result.fitted.push_back(Describe(p, p.get(best)));
  return result;
}

}  // namespace sirupp::lab
