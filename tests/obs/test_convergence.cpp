// Convergence with a manufactured solution (PlaneWaveSolution) on smoothly distorted meshes of
// every cell type, with Dirichlet data on half of the boundary and exact tractions on the rest
// (obs::solveManufactured): the H1 error must decrease like h and the L2 error like h^2.
// bench/convergence writes the same study as the table in docs/verification.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "obs/obs/Verification.hpp"

using namespace obs;
using mesh::CellType;

namespace {

class ConvergenceTest : public ::testing::TestWithParam<CellType> {};

TEST_P(ConvergenceTest, RatesOneInH1AndTwoInL2) {
  const CellType t = GetParam();
  const bool is2D = mesh::dimension(t) == 2;
  // Kuhn tetrahedra are the slowest to reach the asymptotic range (measured L2 rates 1.56, 1.82,
  // 1.94 from n = 4 to 32): they are checked on finer meshes.
  const std::vector<int> sizes = is2D                         ? std::vector<int>{8, 16, 32, 64}
                                 : t == CellType::Tetrahedron ? std::vector<int>{8, 16, 32}
                                                              : std::vector<int>{4, 8, 16};
  std::vector<ManufacturedRun> runs;
  for (int n : sizes) runs.push_back(solveManufactured(t, n));
  for (std::size_t k = 1; k < runs.size(); ++k) {
    const double rh = std::log(runs[k].h / runs[k - 1].h);
    const double rateL2 = std::log(runs[k].relativeL2 / runs[k - 1].relativeL2) / rh;
    const double rateH1 = std::log(runs[k].relativeH1 / runs[k - 1].relativeH1) / rh;
    std::printf("%s n=%d: rate L2 %.3f H1 %.3f\n", std::string(mesh::name(t)).c_str(),
                runs[k].cellsPerDirection, rateL2, rateH1);
    // every level reduces the error substantially; the last step must be asymptotic
    EXPECT_GT(rateH1, 0.9);
    EXPECT_GT(rateL2, 1.5);
    if (k + 1 == runs.size()) {
      EXPECT_NEAR(rateH1, 1.0, 0.1) << mesh::name(t);
      EXPECT_NEAR(rateL2, 2.0, 0.15) << mesh::name(t);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, ConvergenceTest, ::testing::ValuesIn(mesh::kVolumeCellTypes),
                         [](const auto& info) { return std::string(mesh::name(info.param)); });

}  // namespace
