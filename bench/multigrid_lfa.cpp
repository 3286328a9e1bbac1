// Local Fourier analysis (LFA) of the two-grid method of obs' linear multigrid on the infinite uniform
// grid (issue 12: the limit the tetrahedral rates of bench/multigrid_rates approach). The grid is the
// box mesh continued periodically: for tetrahedra the Freudenthal (Kuhn) triangulation, six
// tetrahedra around the main diagonal of every cube, whose red refinement with Bey's diagonal is the
// same triangulation at half the size; for hexahedra the Q1 grid. The fine stencil is read off the
// assembled stiffness at an interior vertex of the 4 x 4 x 4 box (one 3 x 3 block per neighbour
// offset): elasticity (E = 1, nu as given) or the scalar Laplacian on each component (as in
// multigrid_rates). The two-grid error propagator per low frequency theta in [-pi/2, pi/2)^3 acts on
// the 8 harmonics theta + pi alpha, alpha in {0,1}^3:
//     M(theta) = S_b^nu (I - P A_c^{-1} P^H A) S_f^nu,   A_c = P^H A P,
// with A = diag of the stencil symbols, P the symbol of the prolongation (P1 interpolation on the
// Freudenthal grid: the fine vertex 2x + s, s in {0,1}^3, is the midpoint of the coarse edge from x to
// x + s, so its value is the mean of the two; Q1: trilinear interpolation), and S_f, S_b the symbols
// of forward and backward lexicographic point-block Gauss-Seidel (lexicographic in z, y, x). The
// two-grid factor is the largest spectral radius of M(theta) over an n^3 grid of frequencies (cell
// centres, so theta = 0 with its singular coarse symbol is never hit).
//
// Writes the markdown block "multigrid_lfa" (MarkdownBlock.hpp) of OUTPUT.md, or standard output.
//
//   build/bench/multigrid_lfa docs/performance.md
// Options: --samples n (frequencies per direction, default 32), --nu POISSON (default 0.25),
// --smoothing NU (may repeat; default 1 and 3).
#include <Eigen/Dense>

#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "MarkdownBlock.hpp"
#include "obs/mesh/BoxMesh.hpp"
#include "obs/obs/ElasticityAssembly.hpp"
#include "obs/obs/Parallel.hpp"

namespace {

using namespace obs;
using Complex = std::complex<double>;
using Block = Eigen::Matrix3d;
using CBlock = Eigen::Matrix<Complex, 3, 3>;
using Big = Eigen::Matrix<Complex, 24, 24>;

/// Stencil: neighbour offset (in grid steps) -> 3 x 3 block.
using Stencil = std::map<std::array<int, 3>, Block>;

Stencil stencil(mesh::CellType type, bool laplace, double nu) {
  const int n = 4;
  const mesh::Mesh m = mesh::boxMesh(type, n);
  const Material material{1.0, laplace ? 0.0 : nu};
  const BlockSparseMatrix<3> A = assembleStiffness<3>(m, material);
  Index centre = -1;
  for (Index v = 0; v < m.numVertices(); ++v)
    if ((m.vertex(v) - Point(0.5, 0.5, 0.5)).norm() < 1e-12) centre = v;
  Stencil s;
  for (Index k = A.rowBegin(centre); k < A.rowEnd(centre); ++k) {
    const Point o = (m.vertex(A.column(k)) - m.vertex(centre)) * n;
    const std::array<int, 3> off = {static_cast<int>(std::lround(o[0])), static_cast<int>(std::lround(o[1])),
                                    static_cast<int>(std::lround(o[2]))};
    Block B = A.blockAt(k);
    if (laplace) B = (B.trace() / (4 * material.mu())) * Block::Identity();
    s[off] = B;
  }
  return s;
}

/// Lexicographic position of an offset relative to the centre in the sweep order (z, then y, then x).
int compare(const std::array<int, 3>& o) {
  for (int c = 2; c >= 0; --c)
    if (o[c] != 0) return o[c] < 0 ? -1 : 1;
  return 0;
}

struct Result {
  double rho = 0;
  std::array<double, 3> theta{};
};

Result twoGridFactor(const Stencil& st, bool freudenthal, int nu, int samples) {
  std::array<std::array<int, 3>, 8> S;
  for (int a = 0; a < 8; ++a) S[a] = {a & 1, (a >> 1) & 1, (a >> 2) & 1};
  Result out;
  for (int i = 0; i < samples; ++i)
    for (int j = 0; j < samples; ++j)
      for (int k = 0; k < samples; ++k) {
        const std::array<double, 3> th = {-M_PI / 2 + M_PI * (i + 0.5) / samples,
                                          -M_PI / 2 + M_PI * (j + 0.5) / samples,
                                          -M_PI / 2 + M_PI * (k + 0.5) / samples};
        Big A = Big::Zero(), F = Big::Zero(), B = Big::Zero();
        Eigen::Matrix<Complex, 24, 3> P = Eigen::Matrix<Complex, 24, 3>::Zero();
        for (int a = 0; a < 8; ++a) {
          const std::array<double, 3> phi = {th[0] + M_PI * S[a][0], th[1] + M_PI * S[a][1], th[2] + M_PI * S[a][2]};
          CBlock D = CBlock::Zero(), Lo = CBlock::Zero(), Up = CBlock::Zero();
          for (const auto& [o, blk] : st) {
            const Complex e = std::exp(Complex(0, phi[0] * o[0] + phi[1] * o[1] + phi[2] * o[2]));
            const int c = compare(o);
            (c < 0 ? Lo : c > 0 ? Up : D) += e * blk.cast<Complex>();
          }
          A.block<3, 3>(3 * a, 3 * a) = D + Lo + Up;
          F.block<3, 3>(3 * a, 3 * a) = -(D + Lo).inverse() * Up;
          B.block<3, 3>(3 * a, 3 * a) = -(D + Up).inverse() * Lo;
          // prolongation symbol: the fine value at parity s is g(s) e^{i theta y}
          Complex p = 0;
          for (const auto& s : S) {
            const double sign = ((S[a][0] * s[0] + S[a][1] * s[1] + S[a][2] * s[2]) % 2) ? -1.0 : 1.0;
            double g = 1;
            if (freudenthal) {
              g = std::cos(th[0] * s[0] + th[1] * s[1] + th[2] * s[2]);
            } else {
              for (int c = 0; c < 3; ++c)
                if (s[c]) g *= std::cos(th[c]);
            }
            p += sign * g / 8.0;
          }
          P.block<3, 3>(3 * a, 0) = p * CBlock::Identity();
        }
        const CBlock Ac = P.adjoint() * A * P;
        const Big K = Big::Identity() - P * Ac.inverse() * P.adjoint() * A;
        Big M = K;
        for (int r = 0; r < nu; ++r) M = B * M * F;
        const double rho = M.eigenvalues().cwiseAbs().maxCoeff();
        if (rho > out.rho) out = {rho, th};
      }
  return out;
}

std::string fmt(double v, int digits) { return obs::bench::fixed(v, digits); }

}  // namespace

int main(int argc, char** argv) {
  std::string page;
  int samples = 32;
  double nu = 0.25;
  std::vector<int> smoothing;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const bool more = i + 1 < argc;
      if (a == "--samples" && more) samples = std::stoi(argv[++i]);
      else if (a == "--nu" && more) nu = std::stod(argv[++i]);
      else if (a == "--smoothing" && more) smoothing.push_back(std::stoi(argv[++i]));
      else if (a.rfind("--", 0) != 0 && page.empty()) page = a;
      else throw std::invalid_argument("unknown argument " + a);
    }
    if (samples < 2) throw std::invalid_argument("--samples must be >= 2");
  } catch (const std::exception& e) {
    std::cerr << "multigrid_lfa: " << e.what() << "\n";
    return 2;
  }
  if (smoothing.empty()) smoothing = {1, 3};
  obs::setThreads(1);
  std::ostringstream md;
  md << "Local Fourier analysis of the two-grid method (infinite uniform grid, Galerkin coarse operator, "
     << "symmetric lexicographic point-block Gauss-Seidel with nu sweeps before and after), " << samples
     << "^3 frequencies; elasticity E = 1, nu = " << nu << ". In brackets the worst low frequency theta h.\n\n"
     << "| grid | problem | stencil points | nu | two-grid factor | worst theta |\n|---|---|---|---|---|---|\n";
  for (const auto type : {mesh::CellType::Tetrahedron, mesh::CellType::Hexahedron})
    for (const bool laplace : {false, true}) {
      const Stencil st = stencil(type, laplace, nu);
      int points = 0;
      for (const auto& [o, blk] : st)
        if (blk.cwiseAbs().maxCoeff() > 1e-12 * st.at({0, 0, 0}).cwiseAbs().maxCoeff()) ++points;
      for (const int s : smoothing) {
        const Result r = twoGridFactor(st, type == mesh::CellType::Tetrahedron, s, samples);
        const std::string grid = type == mesh::CellType::Tetrahedron ? "Freudenthal P1" : "Q1";
        md << "| " << grid << " | " << (laplace ? "Laplace" : "elasticity") << " | " << points << " | " << s << " | "
           << fmt(r.rho, 3) << " | (" << fmt(r.theta[0], 2) << ", " << fmt(r.theta[1], 2) << ", "
           << fmt(r.theta[2], 2) << ") |\n";
        std::cerr << grid << " " << (laplace ? "Laplace" : "elasticity") << " nu " << s << ": " << r.rho << std::endl;
      }
    }
  return obs::bench::emitMarkdownBlock(page, "multigrid_lfa", md.str());
}
