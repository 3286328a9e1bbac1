// Marking strategies on constructed indicator vectors: each selects exactly what Marking.hpp
// promises, ties are deterministic, zero indicators mark nothing, bad input is an obs::Error.
#include <gtest/gtest.h>

#include <cmath>

#include "obs/estimators/Marking.hpp"
#include "obs/mesh/Error.hpp"

using namespace obs::estimators;
using Cells = std::vector<Index>;

namespace {

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const obs::Error& e) {
    return e.what();
  }
  return "(no obs::Error thrown)";
}

TEST(Marking, MeanValue) {
  // eta^2 = 1, 4, 9, 16, 0: mean 6; theta = 1.1: threshold 1.21 * 6 = 7.26 -> cells 2, 3
  const std::vector<double> eta{1, 2, 3, 4, 0};
  EXPECT_EQ(markMeanValue(eta), (Cells{2, 3}));
  EXPECT_EQ(markMeanValue(eta, 1.0), (Cells{2, 3}));  // 6 <= 9
  EXPECT_EQ(markMeanValue(eta, 0.0), (Cells{0, 1, 2, 3, 4}));
  EXPECT_EQ(markMeanValue(eta, 2.0), Cells{});         // 24 > 16
  // equal indicators: all have eta_e^2 = mean, so theta <= 1 marks all, theta > 1 none
  const std::vector<double> equal(6, 0.5);
  EXPECT_EQ(markMeanValue(equal, 1.0).size(), 6u);
  EXPECT_TRUE(markMeanValue(equal, 1.1).empty());
}

TEST(Marking, DoerflerTakesTheSmallestSet) {
  // eta^2 = 16, 1, 9, 4, 1 (total 31); theta 0.5 -> 15.5: {0} holds 16
  const std::vector<double> eta{4, 1, 3, 2, 1};
  EXPECT_EQ(markDoerfler(eta, 0.5), (Cells{0}));
  EXPECT_EQ(markDoerfler(eta, 0.6), (Cells{0, 2}));        // 18.6 -> 16 + 9
  EXPECT_EQ(markDoerfler(eta, 0.9), (Cells{0, 2, 3}));     // 27.9 -> 29
  EXPECT_EQ(markDoerfler(eta, 0.95), (Cells{0, 1, 2, 3}));  // 29.45 -> 30: tie 1 vs 4, lower first
  EXPECT_EQ(markDoerfler(eta, 1.0), (Cells{0, 1, 2, 3, 4}));
  EXPECT_TRUE(markDoerfler(eta, 0.0).empty());
  // ties are broken by cell number, so the result does not depend on the sort implementation
  const std::vector<double> ties{1, 1, 1, 1};
  EXPECT_EQ(markDoerfler(ties, 0.5), (Cells{0, 1}));
}

TEST(Marking, MaximumAndFixedFraction) {
  const std::vector<double> eta{0.1, 0.5, 1.0, 0.49, 0.7};
  EXPECT_EQ(markMaximum(eta, 0.5), (Cells{1, 2, 4}));
  EXPECT_EQ(markMaximum(eta, 1.0), (Cells{2}));
  EXPECT_EQ(markMaximum(eta, 0.0).size(), 5u);

  const std::vector<double> ten{5, 1, 9, 3, 7, 3, 0, 2, 8, 4};
  EXPECT_EQ(markFixedFraction(ten, 0.3), (Cells{2, 4, 8}));  // exactly 3, not ceil(3.0000000000000004)
  EXPECT_EQ(markFixedFraction(ten, 0.25), (Cells{2, 4, 8}));  // ceil(2.5) = 3
  EXPECT_EQ(markFixedFraction(ten, 0.0), Cells{});
  EXPECT_EQ(markFixedFraction(ten, 1.0).size(), 10u);
  EXPECT_EQ(markFixedFraction(ten, 0.5), (Cells{0, 2, 4, 8, 9}));
  EXPECT_EQ(markFixedFraction(ten, 0.7), (Cells{0, 2, 3, 4, 5, 8, 9}));
  // tie at the cut (cells 3 and 5 both 3, one slot left): the lower cell number wins
  EXPECT_EQ(markFixedFraction(ten, 0.6), (Cells{0, 2, 3, 4, 8, 9}));
}

TEST(Marking, ZeroIndicatorsMarkNothingAndBadInputIsAnError) {
  const std::vector<double> zero(4, 0.0), none;
  for (const auto& info : MarkingStrategy::available()) {
    EXPECT_TRUE(MarkingStrategy(info.name).mark(zero).empty()) << info.name;
    EXPECT_TRUE(MarkingStrategy(info.name).mark(none).empty()) << info.name;
  }
  const std::vector<double> bad{1, -1}, nan{1, std::nan("")};
  EXPECT_NE(errorOf([&] { markMeanValue(bad); }).find("indicator of cell 1"), std::string::npos);
  EXPECT_NE(errorOf([&] { markDoerfler(nan); }).find("indicator of cell 1"), std::string::npos);
  EXPECT_NE(errorOf([&] { markMaximum(bad, 1.5); }).find("parameter"), std::string::npos);
  EXPECT_NE(errorOf([&] { markFixedFraction(bad, -0.1); }).find("parameter"), std::string::npos);
  EXPECT_EQ(markedFlags(Cells{0, 2}, 4), (std::vector<char>{1, 0, 1, 0}));
  EXPECT_THROW(markedFlags(Cells{4}, 4), obs::Error);
}

TEST(Marking, StrategiesByName) {
  const auto all = MarkingStrategy::available();
  ASSERT_EQ(all.size(), 4u);
  EXPECT_EQ(all[0].name, "doerfler");
  EXPECT_EQ(all[3].name, "mean");
  const MarkingStrategy mean("mean");
  EXPECT_EQ(mean.name(), "mean");
  EXPECT_DOUBLE_EQ(mean.parameter(), 1.1);
  const std::vector<double> eta{1, 2, 3, 4, 0};
  EXPECT_EQ(mean.mark(eta), markMeanValue(eta, 1.1));
  EXPECT_EQ(MarkingStrategy("doerfler", 0.6).mark(eta), markDoerfler(eta, 0.6));
  EXPECT_EQ(MarkingStrategy("maximum").mark(eta), markMaximum(eta, 0.5));
  EXPECT_EQ(MarkingStrategy("fraction").mark(eta), (Cells{3}));  // 0.2 * 5 = 1
  const std::string e = errorOf([] { MarkingStrategy("bulk"); });
  EXPECT_EQ(e, "unknown marking strategy 'bulk' (known: doerfler, fraction, maximum, mean)");
  EXPECT_NE(errorOf([] { MarkingStrategy("doerfler", 1.5); }).find("marking 'doerfler'"),
            std::string::npos);
}

}  // namespace
