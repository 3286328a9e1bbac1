#include "obs/obs/MassRedistribution.hpp"

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs {

RedistributedMass redistributeMass(const ScalarSparseMatrix& M, const std::vector<mesh::Point>& vertices,
                                   int dimension, const std::vector<char>& massless,
                                   const MassRedistributionOptions& options, Index owned, const Communicator* comm) {
  const Eigen::Index n = M.rows();
  // the rows this rank sums (all without comm), and the reductions over the ranks
  const Eigen::Index rows = comm ? owned : n;
  if (comm && (owned < 0 || owned > n))
    throw Error("mass redistribution: " + std::to_string(owned) + " owned rows of " + std::to_string(n));
  const auto sum = [&](std::vector<double>& x) {
    if (comm) comm->sum(x);
  };
  const auto maximum = [&](double x) { return comm ? comm->max(x) : x; };
  if (M.cols() != n || static_cast<Eigen::Index>(vertices.size()) != n ||
      static_cast<Eigen::Index>(massless.size()) != n)
    throw Error("mass redistribution: matrix (" + std::to_string(M.rows()) + " x " + std::to_string(M.cols()) +
                "), " + std::to_string(vertices.size()) + " vertices and " + std::to_string(massless.size()) +
                " flags do not match");
  if (dimension != 2 && dimension != 3)
    throw Error("mass redistribution: dimension " + std::to_string(dimension) + " (2 or 3 expected)");
  if (options.moments < 0 || options.moments > 2)
    throw Error("mass redistribution: moments = " + std::to_string(options.moments) +
                " (0: none kept, 1: mass and centre of gravity, 2: also the second moments)");
  if (options.moments == 0) {
    // no moment kept: M with the rows and columns of the massless vertices zeroed and nothing moved
    // to the other vertices (the control experiment of the thesis' Sec. 5.2.6)
    RedistributedMass out;
    out.massless = massless;
    out.matrix = M;
    std::vector<double> totals{0.0, 0.0};  // moved mass, kept entries (owned rows)
    for (Eigen::Index i = 0; i < n; ++i)
      for (ScalarSparseMatrix::InnerIterator it(out.matrix, i); it; ++it)
        if (massless[i] || massless[it.col()]) {
          if (i < rows) totals[0] += it.value();
          it.valueRef() = 0;
        } else if (i < rows) {
          totals[1] += 1;
        }
    sum(totals);
    out.movedMass = totals[0];
    if (totals[1] == 0) throw Error("mass redistribution: no matrix entry couples two vertices that keep mass");
    return out;
  }
  // constraints: 1 (total mass), d first moments, d(d+1)/2 second moments (moments = 2)
  const bool second = options.moments == 2;
  const int m = 1 + dimension + (second ? dimension * (dimension + 1) / 2 : 0);

  // centre and radius of the kept vertices: the constraint weights use the coordinates
  // y = (x - xbar) / L, an equivalent set of constraints (linear combinations of the ones in x) with
  // weights of order one
  Eigen::Vector3d xbar = Eigen::Vector3d::Zero();
  Eigen::Index kept = 0;
  {
    std::vector<double> s(4, 0.0);  // sum of the kept (owned) positions, their number
    for (Eigen::Index i = 0; i < rows; ++i)
      if (!massless[i]) {
        for (int a = 0; a < 3; ++a) s[a] += vertices[i][a];
        s[3] += 1;
      }
    sum(s);
    xbar = Eigen::Vector3d(s[0], s[1], s[2]);
    kept = static_cast<Eigen::Index>(s[3]);
  }
  if (kept == 0) throw Error("mass redistribution: every vertex is massless (no vertex keeps mass)");
  xbar /= static_cast<double>(kept);
  double L = 0;
  for (Eigen::Index i = 0; i < rows; ++i) L = std::max(L, (vertices[i] - xbar).norm());
  L = maximum(L);
  if (!(L > 0) || !std::isfinite(L))
    throw Error("mass redistribution: the vertices span no volume (radius " + std::to_string(L) + ")");

  // W^k_ij: 1; (y_i,a + y_j,a)/2; (y_i,a y_j,b + y_j,a y_i,b)/2 for a <= b (symmetric in i, j)
  auto weights = [&](Eigen::Index i, Eigen::Index j) {
    Eigen::VectorXd w(m);
    const Eigen::Vector3d yi = (vertices[i] - xbar) / L, yj = (vertices[j] - xbar) / L;
    int k = 0;
    w[k++] = 1;
    for (int a = 0; a < dimension; ++a) w[k++] = 0.5 * (yi[a] + yj[a]);
    if (second)
      for (int a = 0; a < dimension; ++a)
        for (int b = a; b < dimension; ++b) w[k++] = 0.5 * (yi[a] * yj[b] + yj[a] * yi[b]);
    return w;
  };

  // targets c = C(M), the Gram matrix G_kl = sum_K |M_ij| W^k W^l and the restricted matrix M0
  RedistributedMass out;
  out.massless = massless;
  out.matrix = M;
  Eigen::VectorXd target = Eigen::VectorXd::Zero(m);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(m, m);
  double keptEntries = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    for (ScalarSparseMatrix::InnerIterator it(out.matrix, i); it; ++it) {
      const Eigen::Index j = it.col();
      const bool counted = i < rows;
      const Eigen::VectorXd w = weights(i, j);
      if (counted) target += it.value() * w;
      if (massless[i] || massless[j]) {
        if (counted) out.movedMass += it.value();
        it.valueRef() = 0;
      } else if (counted) {
        G += std::abs(it.value()) * w * w.transpose();
        ++keptEntries;
      }
    }
  if (comm) {  // target, G, moved mass, kept entries summed over the ranks
    std::vector<double> s(target.data(), target.data() + m);
    s.insert(s.end(), G.data(), G.data() + m * m);
    s.push_back(out.movedMass);
    s.push_back(keptEntries);
    sum(s);
    target = Eigen::Map<const Eigen::VectorXd>(s.data(), m);
    G = Eigen::Map<const Eigen::MatrixXd>(s.data() + m, m, m);
    out.movedMass = s[static_cast<std::size_t>(m + m * m)];
    keptEntries = s[static_cast<std::size_t>(m + m * m + 1)];
  }
  if (keptEntries == 0) throw Error("mass redistribution: no matrix entry couples two vertices that keep mass");
  // G is singular iff the kept entries cannot carry the constraints independently (e.g. all vertices
  // that keep mass on one line in 2D, on one plane in 3D): no such M~ exists in general
  const Eigen::LDLT<Eigen::MatrixXd> Gfac(G);
  {
    const Eigen::VectorXd D = Gfac.vectorD();
    if (Gfac.info() != Eigen::Success || !(D.minCoeff() > 1e-12 * D.cwiseAbs().maxCoeff()))
      throw Error("mass redistribution: the " + std::to_string(kept) + " vertices that keep mass do not determine "
                  + std::string(second ? "the total mass, the first and the second moments" : "the total mass and the first moments") +
                  " (e.g. they lie on one line or plane); "
                  "refine the mesh or choose a smaller contact boundary");
  }
  const ScalarSparseMatrix M0 = out.matrix;
  const double scale = std::max(std::abs(target[0]), 1e-300);
  const double theta = options.minimumScale;
  if (!(theta < 1))
    throw Error("mass redistribution: minimumScale " + std::to_string(theta) +
                " (theta < 1 expected; -infinity for no bound)");

  // M~(lambda) = M0 max(theta, 1 + lambda'W) written into out.matrix; returns C(M~), the dual value
  // g(lambda) (file comment of the header) and the Gram matrix of the entries above the bound
  struct Evaluation {
    Eigen::VectorXd constraints;
    Eigen::MatrixXd gram;
    double dual = 0;
    Eigen::Index bounded = 0;
    double minimumFactor = std::numeric_limits<double>::infinity();
  };
  auto evaluate = [&](const Eigen::VectorXd& lambda) {
    Evaluation e;
    e.constraints = Eigen::VectorXd::Zero(m);
    e.gram = Eigen::MatrixXd::Zero(m, m);
    for (Eigen::Index i = 0; i < n; ++i) {
      if (massless[i]) continue;
      const bool counted = i < rows;  // the other rows are rescaled but summed by their owners
      for (ScalarSparseMatrix::InnerIterator it(out.matrix, i), it0(M0, i); it; ++it, ++it0) {
        const Eigen::Index j = it.col();
        if (massless[j]) continue;
        const Eigen::VectorXd w = weights(i, j);
        const double mij = it0.value(), q = lambda.dot(w);
        if (1 + q > theta || mij == 0) {
          it.valueRef() = mij + std::abs(mij) * q;
          if (counted) e.gram += std::abs(mij) * w * w.transpose();
        } else {
          it.valueRef() = theta * mij;
          if (counted) ++e.bounded;
        }
        if (!counted) continue;
        if (mij != 0) e.minimumFactor = std::min(e.minimumFactor, it.value() / mij);
        e.constraints += it.value() * w;
        if (mij != 0) e.dual += (it.value() - mij) * (it.value() - mij) / (2 * std::abs(mij)) - it.value() * q;
      }
    }
    if (comm) {  // one reduction per evaluation: constraints, Gram matrix, dual, bounded count
      std::vector<double> s(e.constraints.data(), e.constraints.data() + m);
      s.insert(s.end(), e.gram.data(), e.gram.data() + m * m);
      s.push_back(e.dual);
      s.push_back(static_cast<double>(e.bounded));
      sum(s);
      e.constraints = Eigen::Map<const Eigen::VectorXd>(s.data(), m);
      e.gram = Eigen::Map<const Eigen::MatrixXd>(s.data() + m, m, m);
      e.dual = s[static_cast<std::size_t>(m + m * m)];
      e.bounded = static_cast<Eigen::Index>(s[static_cast<std::size_t>(m + m * m + 1)]);
      e.minimumFactor = -comm->max(-e.minimumFactor);
    }
    e.dual += lambda.dot(target);
    return e;
  };

  // Newton on the dual: lambda <- lambda + t G_A^{-1} (c - C(M~(lambda))), t = 1 unless an entry is at
  // the bound (then halved until g increases)
  Eigen::VectorXd lambda = Eigen::VectorXd::Zero(m);
  Evaluation cur = evaluate(lambda);
  double previous = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= options.maxIterations; ++k) {
    const Eigen::VectorXd gradient = target - cur.constraints;
    out.residual = gradient.norm() / scale;
    out.iterations = k;
    if (out.residual <= options.tolerance) break;
    // round-off floor of the sums over many entries: stop when a sweep no longer halves a residual
    // that is already at round-off level
    if (k >= 1 && out.residual <= 1e-11 && out.residual > 0.5 * previous) break;
    if (k == options.maxIterations) {
      std::ostringstream msg;
      msg << "mass redistribution: the Uzawa iteration did not reach the tolerance " << options.tolerance << " in "
          << options.maxIterations << " iterations (relative constraint residual " << out.residual << ")";
      if (cur.bounded > 0)
        msg << "; " << cur.bounded << " entries are at the bound M~_ij = " << theta
            << " M_ij: probably no redistributed mass matrix with these bounds keeps the total mass and the first "
            << (second ? "and second moments" : "moments")
            << " with the mass left off the contact boundary (too few cell layers behind it); "
               "refine the mesh near the contact boundary or use a scheme without mass redistribution";
      throw Error(msg.str());
    }
    previous = out.residual;
    // G_A (the kept entries above the bound); if they alone cannot carry the constraints, G (an ascent
    // direction as well)
    Eigen::VectorXd step;
    if (cur.bounded == 0) {
      step = Gfac.solve(gradient);
    } else {
      const Eigen::LDLT<Eigen::MatrixXd> Afac(cur.gram);
      const Eigen::VectorXd D = Afac.vectorD();
      const bool regular = Afac.info() == Eigen::Success && D.minCoeff() > 1e-12 * D.cwiseAbs().maxCoeff();
      step = regular ? Eigen::VectorXd(Afac.solve(gradient)) : Eigen::VectorXd(Gfac.solve(gradient));
    }
    double t = 1;
    Evaluation trial = evaluate(lambda + step);
    const double slope = gradient.dot(step);  // > 0: G_A, G positive definite
    while (cur.bounded + trial.bounded > 0 && trial.dual < cur.dual + 1e-4 * t * slope && t > 1e-10) {
      t *= 0.5;
      trial = evaluate(lambda + t * step);
    }
    lambda += t * step;
    cur = std::move(trial);
  }
  // out.matrix holds M~(lambda) of the last evaluation, i.e. of the final lambda
  out.boundedEntries = cur.bounded;
  out.minimumFactor = cur.minimumFactor;
  out.multipliers = lambda;
  return out;
}

DefinitenessCheck checkPositiveDefinite(const ScalarSparseMatrix& M, const std::vector<char>& mask) {
  if (M.rows() != M.cols() || static_cast<Eigen::Index>(mask.size()) != M.rows())
    throw Error("checkPositiveDefinite: matrix (" + std::to_string(M.rows()) + " x " + std::to_string(M.cols()) +
                ") and " + std::to_string(mask.size()) + " mask flags do not match");
  std::vector<Eigen::Index> index(static_cast<std::size_t>(M.rows()), -1);
  Eigen::Index n = 0;
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    if (!mask[static_cast<std::size_t>(i)]) index[static_cast<std::size_t>(i)] = n++;
  if (n == 0) throw Error("checkPositiveDefinite: every row is masked");
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(M.nonZeros()));
  double maxDiagonal = 0;
  for (Eigen::Index i = 0; i < M.outerSize(); ++i) {
    const Eigen::Index a = index[static_cast<std::size_t>(i)];
    if (a < 0) continue;
    for (ScalarSparseMatrix::InnerIterator it(M, i); it; ++it) {
      const Eigen::Index b = index[static_cast<std::size_t>(it.col())];
      if (b < 0) continue;
      t.emplace_back(a, b, it.value());
      if (a == b) maxDiagonal = std::max(maxDiagonal, std::abs(it.value()));
    }
  }
  Eigen::SparseMatrix<double> R(n, n);
  R.setFromTriplets(t.begin(), t.end());
  DefinitenessCheck out;
  out.size = n;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt(R);
  if (ldlt.info() != Eigen::Success) {  // zero pivot
    out.nonPositivePivots = 1;
    return out;
  }
  const double floor = 1e-12 * maxDiagonal;
  const Eigen::VectorXd D = ldlt.vectorD();
  for (Eigen::Index k = 0; k < D.size(); ++k) out.nonPositivePivots += !(D[k] > floor);
  out.positiveDefinite = out.nonPositivePivots == 0;
  return out;
}

double smallestEigenvalue(const ScalarSparseMatrix& M, const std::vector<char>& mask) {
  std::vector<Eigen::Index> index(static_cast<std::size_t>(M.rows()), -1);
  Eigen::Index n = 0;
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    if (!mask[static_cast<std::size_t>(i)]) index[static_cast<std::size_t>(i)] = n++;
  if (n > 4000) throw Error("smallestEigenvalue: " + std::to_string(n) + " rows (dense, at most 4000)");
  if (n == 0) throw Error("smallestEigenvalue: every row is masked");
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 0; i < M.outerSize(); ++i)
    for (ScalarSparseMatrix::InnerIterator it(M, i); it; ++it) {
      const Eigen::Index a = index[static_cast<std::size_t>(i)], b = index[static_cast<std::size_t>(it.col())];
      if (a >= 0 && b >= 0) D(a, b) = it.value();
    }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(D, Eigen::EigenvaluesOnly);
  return es.eigenvalues().minCoeff();
}

}  // namespace obs
