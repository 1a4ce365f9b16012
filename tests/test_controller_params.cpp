// sirupp::Params (include/sirupp/controller.h): the "key=number" arguments of a student's
// controller.
#include <gtest/gtest.h>
#include <sirupp/controller.h>

#include <stdexcept>
#include <string>

namespace {

std::string Refusal(const std::string& args) {
  try {
    sirupp::Params params(args);
    params.Positive("wn", 100);
    params.Number("bias", 0);
    params.Finish();
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "";
}

TEST(ControllerParams, GivenNumbersAndDefaults) {
  sirupp::Params params("  wn=150\tbias=-2.5e-1 ");
  EXPECT_EQ(params.Positive("wn", 100), 150);
  EXPECT_EQ(params.Positive("zeta", 1), 1);
  EXPECT_EQ(params.Number("bias", 0), -0.25);
  EXPECT_NO_THROW(params.Finish());
  sirupp::Params none("");
  EXPECT_EQ(none.Number("wn", 7), 7);
  EXPECT_NO_THROW(none.Finish());
}

TEST(ControllerParams, EachBadWordIsNamedWithWhatIsAllowed) {
  EXPECT_EQ(Refusal("wn=fast"), "'wn=fast': expected key=number");
  EXPECT_EQ(Refusal("wn"), "'wn': expected key=number");
  EXPECT_EQ(Refusal("=3"), "'=3': expected key=number");
  EXPECT_EQ(Refusal("wn=3x"), "'wn=3x': expected key=number");
  EXPECT_EQ(Refusal("wn=nan"), "'wn=nan': expected key=number");
  EXPECT_EQ(Refusal("wn=inf"), "'wn=inf': expected key=number");
  EXPECT_EQ(Refusal("wn=-3"), "'wn=-3': wn must be > 0");
  EXPECT_EQ(Refusal("wn=0"), "'wn=0': wn must be > 0");
  EXPECT_EQ(Refusal("wn=1 wn=2"), "'wn=1 wn=2': wn given twice");
  EXPECT_EQ(Refusal("wn=100 gain=3"), "unknown argument 'gain' (allowed: wn, bias)");
  sirupp::Params nothing_asked("gain=3");
  try {
    nothing_asked.Finish();
    ADD_FAILURE() << "Finish accepted a key nobody asked for";
  } catch (const std::invalid_argument& error) {
    EXPECT_STREQ(error.what(), "unknown argument 'gain' (allowed: none)");
  }
}

}  // namespace
