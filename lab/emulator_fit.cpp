#include "lab/emulator_fit.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/errors.hpp"

namespace sirupp::lab {
namespace {

namespace range = hardware::real_arm_range;

double Robust(double z) { return z * z / (1 + z * z / 4); }

double Tolerance(double paper) { return std::max(0.3 * paper, 0.5); }

// One fitted number: how to read and write it, its range, and whether steps multiply it.
struct Param {
  std::string name;
  std::function<double(const hardware::RealArmParams&)> get;
  std::function<void(hardware::RealArmParams&, double)> set;
  double min, max;
  bool multiplicative;
  double step;
};

std::vector<Param> Params() {
  std::vector<Param> p;
  p.push_back({"board.command_latency_s",
               [](const hardware::RealArmParams& a) { return a.command_latency_s; },
               [](hardware::RealArmParams& a, double v) { a.command_latency_s = v; },
               range::kCommandLatency.min, range::kCommandLatency.max, false, 0.04});
  p.push_back({"supply.voltage_v",
               [](const hardware::RealArmParams& a) { return a.supply_voltage_v; },
               [](hardware::RealArmParams& a, double v) { a.supply_voltage_v = v; },
               range::kSupplyVoltage.min, range::kSupplyVoltage.max, true, 0.25});
  p.push_back({"supply.resistance_ohm",
               [](const hardware::RealArmParams& a) { return a.supply_resistance_ohm; },
               [](hardware::RealArmParams& a, double v) { a.supply_resistance_ohm = v; },
               range::kSupplyResistance.min, range::kSupplyResistance.max, false, 0.5});
  for (size_t j = 0; j < 3; ++j) {
    const std::string at = "joints[" + std::to_string(j) + "].";
    p.push_back({at + "motor.torque_constant_nm_a",
                 [j](const hardware::RealArmParams& a) {
                   return a.joints[j].motor.torque_constant_nm_per_a;
                 },
                 [j](hardware::RealArmParams& a, double v) {
                   a.joints[j].motor.torque_constant_nm_per_a = v;
                 },
                 range::kTorqueConstant.min, range::kTorqueConstant.max, true, 0.3});
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
                 0.05, range::kStatic.max / 1.2, true, 0.3});
  }
  return p;
}

std::string Describe(const Param& p, double value) {
  return p.name + " " + core::FormatNumber(std::round(value * 1e5) / 1e5) + " (range " +
         core::FormatNumber(p.min) + ".." + core::FormatNumber(p.max) + ")";
}

}  // namespace

double FitCost(const std::vector<TableRow>& table) {
  double cost = 0;
  for (const TableRow& row : table) {
    for (const PaperRow& p : PaperTable()) {
      if (p.set != row.set || p.joint != row.joint) continue;
      const auto misfit = [](double ours, double paper) {
        return std::isfinite(ours) ? Robust((ours - paper) / Tolerance(paper)) : 4.0;
      };
      cost += misfit(row.transient_deg, p.transient_deg) + misfit(row.steady_deg, p.steady_deg);
    }
    if (row.joint == 1) {
      const double mid = (kPaperStartDelayMin + kPaperStartDelayMax) / 2;
      cost += std::isfinite(row.start_delay_real_s) ? Robust((row.start_delay_real_s - mid) / 0.05)
                                                    : 4.0;
    }
  }
  // The paper's main finding: joints moving together lag more than alone (sets IV, VII vs I-III).
  const Comparison c = Compare(table);
  cost += Robust((c.coupling_ours_deg - c.coupling_paper_deg) / 0.25);
  return cost;
}

FitResult FitEmulator(const core::RobotModel& virtual_model, const core::RobotModel& real_model,
                      const hardware::RealArmParams& start, const FitOptions& options) {
  std::vector<VirtualRun> virtual_runs;
  for (int set : options.experiment.sets) {
    virtual_runs.push_back(RunVirtual(virtual_model, set, options.experiment));
  }
  FitResult result;
  auto evaluate = [&](const hardware::RealArmParams& params, std::vector<TableRow>* table) {
    std::vector<logger::RunTable> tables;
    for (const VirtualRun& v : virtual_runs) {
      tables.push_back(MakeTable(real_model, v, RunReal(real_model, params, v)));
    }
    *table = TableII(tables);
    ++result.evaluations;
    return FitCost(*table);
  };
  hardware::RealArmParams best = start;
  hardware::CheckRealArmParams(best, real_model);
  std::vector<TableRow> best_table;
  double best_cost = evaluate(best, &best_table);
  result.cost_before = best_cost;
  std::vector<Param> params = Params();
  bool any_step = true;
  while (any_step && result.evaluations < options.max_evaluations) {
    any_step = false;
    for (Param& p : params) {
      if (result.evaluations >= options.max_evaluations) break;
      if (p.step < (p.multiplicative ? 0.02 : 0.002 * (p.max - p.min + 1))) continue;
      any_step = true;
      const double x = p.get(best);
      bool improved = false;
      for (double sign : {1.0, -1.0}) {
        double candidate = p.multiplicative ? x * (1 + sign * p.step) : x + sign * p.step;
        candidate = std::clamp(candidate, p.min, p.max);
        if (candidate == x) continue;
        hardware::RealArmParams trial = best;
        p.set(trial, candidate);
        try {
          hardware::CheckRealArmParams(trial, real_model);
        } catch (const std::invalid_argument&) {
          continue;  // outside a range the file allows
        }
        std::vector<TableRow> table;
        const double cost = evaluate(trial, &table);
        if (cost < best_cost) {
          best = trial;
          best_cost = cost;
          best_table = table;
          improved = true;
          if (options.progress) options.progress(result.evaluations, cost, Describe(p, candidate));
          break;
        }
      }
      if (!improved) p.step /= 2;
    }
  }
  result.params = best;
  result.table = best_table;
  result.cost_after = best_cost;
  for (const Param& p : params) result.fitted.push_back(Describe(p, p.get(best)));
  return result;
}

}  // namespace sirupp::lab
