// A controller that reads past the end of a vector with at() (std::out_of_range) when its trigger
// fires (misbehave.hpp): sirupp-control must brake the arm and name the exception.
#include <vector>

#include "misbehave.hpp"

namespace {

class Throws : public test_controllers::Tracking {
 public:
  explicit Throws(const std::string& args) : trigger_(args) {}
  void Update(const sirupp::State& state, double* effort) override {
    Track(state, effort);
    if (trigger_.Now(state)) effort[0] += history_.at(7);  // empty: throws
  }

 private:
  test_controllers::Trigger trigger_;
  std::vector<double> history_;
};

}  // namespace

SIRUPP_EXPORT_CONTROLLER(Throws)
