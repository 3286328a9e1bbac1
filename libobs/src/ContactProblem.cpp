#include "obs/obs/ContactProblem.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>
#include <span>
#include <utility>
#include <sstream>

#include "obs/mesh/Error.hpp"

namespace obs {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// The largest normal component |n_{p,a}| of a prescribed component a at a mortar slave vertex
/// (ContactProblem::transform): a symmetry line through a curved slave surface, whose last face
/// tilts the averaged normal by half its angle (0.1: 11 degrees of face angle).
constexpr double kMaxPrescribedNormal = 0.1;

/// Orthogonal m x m matrix with first column y (unit): the Householder construction of
/// householderRotation() in m dimensions.
Eigen::MatrixXd householder(const Eigen::VectorXd& y) {
  const Eigen::Index m = y.size();
  const bool flip = y[0] > 0;
  Eigen::VectorXd v = flip ? Eigen::VectorXd(y) : Eigen::VectorXd(-y);
  v[0] += 1;
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(m, m) - (2 / v.squaredNorm()) * v * v.transpose();
  if (flip) H.col(0) = -H.col(0);
  return H;
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

// --- RotatedProblem ----------------------------------------------------------------------------

template <int d>
void RotatedProblem<d>::project(Eigen::VectorXd& w) const {
  for (Index p = 0; p < numVertices(); ++p) w[p * d] = std::min(w[p * d], upper[p]);
}

template <int d>
Index RotatedProblem<d>::countActive(const Eigen::VectorXd& w) const {
  Index n = 0;
  for (Index p = 0; p < numVertices(); ++p) n += bounded(p) && w[p * d] >= upper[p];
  return n;
}

// --- ContactProblem ----------------------------------------------------------------------------

template <int d>
ContactProblem<d>::ContactProblem(const mesh::Mesh& mesh, const Material& material,
                                  const BoundaryConditions& bc, const ContactSet& contact)
    : contact_(contact) {
  material.validate();
  if (mesh.dimension() != d)
    throw Error("contact problem: the mesh has dimension " + std::to_string(mesh.dimension()) +
                ", the problem " + std::to_string(d));
  b_ = assembleLoad<d>(mesh, bc);
  dirichlet_ = collectDirichlet(mesh, bc.dirichlet);
  setup(assembleStiffness<d>(mesh, material));
}

template <int d>
ContactProblem<d>::ContactProblem(BlockSparseMatrix<d> stiffness, Eigen::VectorXd load,
                                  DirichletValues dirichlet, const ContactSet& contact)
    : b_(std::move(load)), dirichlet_(std::move(dirichlet)), contact_(contact) {
  setup(std::move(stiffness));
}

template <int d>
ContactProblem<d>::ContactProblem(BlockSparseMatrix<d> stiffness, Eigen::VectorXd load, DirichletValues dirichlet,
                                  const ContactSet& contact, mesh::CsrMatrix basis)
    : basis_(std::move(basis)), b_(std::move(load)), dirichlet_(std::move(dirichlet)), contact_(contact) {
  setup(std::move(stiffness));
}

template <int d>
ContactProblem<d>::ContactProblem(BlockSparseMatrix<d> stiffness, Eigen::VectorXd load, DirichletValues dirichlet,
                                  const ContactSet& contact, mesh::CsrMatrix basis, Transformed)
    : basis_(std::move(basis)), b_(std::move(load)), dirichlet_(std::move(dirichlet)), contact_(contact) {
  setup(std::move(stiffness), true);
}

namespace {

/// x_p with the components of `skip[p]` (bit a: component a) zeroed; x_p itself without skips.
template <int d>
Eigen::Matrix<double, d, 1> transformedPart(const Eigen::VectorXd& x, Index p, const std::vector<std::uint8_t>& skip) {
  Eigen::Matrix<double, d, 1> v = x.template segment<d>(static_cast<Eigen::Index>(p) * d);
  if (!skip.empty() && skip[p])
    for (int a = 0; a < d; ++a)
      if (skip[p] & (1u << a)) v[a] = 0;
  return v;
}

/// y = (I +- C') x for a scalar C acting on every component (d components per vertex) but the
/// components of row p that skip[p] exempts (see ContactProblem::basisSkip()); sign = +-1 (sign * v
/// is exact, so -1 gives the bits of subtracting).
template <int d>
Eigen::VectorXd applyTransposedBasis(const mesh::CsrMatrix& C, const std::vector<std::uint8_t>& skip,
                                     const Eigen::VectorXd& x, double sign = 1.0) {
  Eigen::VectorXd y = x;
  for (Index p = 0; p < C.rows; ++p) {
    if (C.rowStart[p + 1] == C.rowStart[p]) continue;
    const Eigen::Matrix<double, d, 1> xp = transformedPart<d>(x, p, skip);
    for (Index k = C.rowStart[p]; k < C.rowStart[p + 1]; ++k)
      y.template segment<d>(static_cast<Eigen::Index>(C.columns[k]) * d) += sign * (C.values[k] * xp);
  }
  return y;
}

/// Sparse block rows accumulated with a marker (columns sorted on output).
template <int d>
struct RowAccumulator {
  using Block = Eigen::Matrix<double, d, d>;
  std::vector<Index> position, cols;
  std::vector<Block> blocks;
  explicit RowAccumulator(Index n) : position(n, -1) {}
  void add(Index j, const Block& B) {
    if (position[j] < 0) {
      position[j] = static_cast<Index>(cols.size());
      cols.push_back(j);
      blocks.push_back(B);
    } else {
      blocks[position[j]] += B;
    }
  }
  /// Appends the row to `rows` and clears.
  void flush(std::vector<Index>& rowStart, std::vector<Index>& columns, std::vector<Block>& values) {
    std::vector<Index> order(cols.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<Index>(i);
    std::sort(order.begin(), order.end(), [&](Index a, Index b) { return cols[a] < cols[b]; });
    for (Index i : order) {
      columns.push_back(cols[i]);
      values.push_back(blocks[i]);
    }
    rowStart.push_back(static_cast<Index>(columns.size()));
    for (Index j : cols) position[j] = -1;
    cols.clear();
    blocks.clear();
  }
};

/// A few block rows of a matrix, stored apart: row `slot` is [start[slot], start[slot + 1]).
template <int d>
struct SideRows {
  std::vector<Index> start{0}, cols;
  std::vector<Eigen::Matrix<double, d, d>> blocks;
};

/// The slave rows of C (a non-empty row) and its master columns.
struct TransformationRoles {
  std::vector<char> slave, master;
  TransformationRoles(const mesh::CsrMatrix& C, Index n) : slave(n, 0), master(n, 0) {
    for (Index r = 0; r < n; ++r)
      if (C.rowStart[r + 1] > C.rowStart[r]) slave[r] = 1;
    for (Index c : C.columns) master[c] = 1;
  }
};

/// C' as lists: for column p of C, the rows r with C_rp != 0 and the values, in ascending r.
struct TransposedBasis {
  std::vector<Index> start, rows;
  std::vector<double> values;
  TransposedBasis(const mesh::CsrMatrix& C, Index n) : start(n + 1, 0), rows(C.columns.size()), values(C.columns.size()) {
    for (Index c : C.columns) ++start[c + 1];
    for (Index i = 0; i < n; ++i) start[i + 1] += start[i];
    std::vector<Index> next(start.begin(), start.end() - 1);
    for (Index r = 0; r < n; ++r)
      for (Index m = C.rowStart[r]; m < C.rowStart[r + 1]; ++m) {
        rows[next[C.columns[m]]] = r;
        values[next[C.columns[m]]++] = C.values[m];
      }
  }
};

/// T'AT with T = I + C (C scalar, acting on every component), in A. Only the rows next to
/// transformed (slave) vertices and the rows of master vertices change: these are computed apart (a
/// few rows near the interfaces). If A's pattern already holds T'AT's (A assembled on
/// ContactProblem::transformedPattern(), zero blocks where A itself has none), they are written
/// into A in place, and the operator is never stored twice; otherwise a new matrix of T'AT's pattern
/// is written in one pass that copies every other row of A. Repeated blocks stay shared either way
/// (docs/performance.md#multi-body-assembly).
template <int d>
void transformOperator(BlockSparseMatrix<d>& A, const mesh::CsrMatrix& C, const std::vector<std::uint8_t>& skip) {
  using Block = Eigen::Matrix<double, d, d>;
  // T = I + C (x) F with F_s = diag(components of row s the transformation acts on): identity
  // unless skip[s] exempts components (then the columns / rows of those are left out)
  const auto exempt = [&](Index s) { return !skip.empty() && skip[s] != 0; };
  const auto F = [&](Index s) {
    Block f = Block::Identity();
    for (int a = 0; a < d; ++a)
      if (skip[s] & (1u << a)) f(a, a) = 0;
    return f;
  };
  const Index n = A.rows();
  const BlockSparseMatrix<d>& Ac = A;  // read access that keeps shared blocks shared
  const TransformationRoles roles(C, n);
  RowAccumulator<d> acc(n);
  // B = A T on the touched rows (those with a slave column; every slave row is one, through its
  // diagonal): B_r = A_r + sum_s A_rs C_s. Any other row of B is A_r.
  std::vector<Index> bSlot(n, -1);
  SideRows<d> B;
  for (Index r = 0; r < n; ++r) {
    bool touched = false;
    for (Index k = Ac.rowBegin(r); k < Ac.rowEnd(r) && !touched; ++k) touched = roles.slave[Ac.column(k)] != 0;
    if (!touched) continue;
    for (Index k = Ac.rowBegin(r); k < Ac.rowEnd(r); ++k) {
      const Index s = Ac.column(k);
      acc.add(s, Ac.blockAt(k));
      if (C.rowStart[s + 1] == C.rowStart[s]) continue;
      const Block As = exempt(s) ? Block(Ac.blockAt(k) * F(s)) : Block(Ac.blockAt(k));
      for (Index m = C.rowStart[s]; m < C.rowStart[s + 1]; ++m) acc.add(C.columns[m], C.values[m] * As);
    }
    bSlot[r] = static_cast<Index>(B.start.size()) - 1;
    acc.flush(B.start, B.cols, B.blocks);
  }
  // T'B on the master rows: row p = B_p + sum_r C_rp F_r B_r (r is a slave row, so B_r is stored).
  // The rows of T'B that differ from A: the master rows (here) and the touched ones (B_p).
  const TransposedBasis Ct(C, n);
  std::vector<Index> slot(n, -1);  // into R, or -1: row p of the result is row p of B
  SideRows<d> R;
  const auto forRowOfB = [&](Index r, auto&& f) {
    if (bSlot[r] >= 0) {
      for (Index k = B.start[bSlot[r]]; k < B.start[bSlot[r] + 1]; ++k) f(B.cols[k], B.blocks[k]);
    } else {
      for (Index k = Ac.rowBegin(r); k < Ac.rowEnd(r); ++k) f(Ac.column(k), Ac.blockAt(k));
    }
  };
  for (Index p = 0; p < n; ++p) {
    if (!roles.master[p]) continue;
    forRowOfB(p, [&](Index j, const Block& v) { acc.add(j, v); });
    for (Index m = Ct.start[p]; m < Ct.start[p + 1]; ++m) {
      const Index r = Ct.rows[m];
      const double c = Ct.values[m];
      if (exempt(r)) {
        const Block Fr = F(r);
        forRowOfB(r, [&](Index j, const Block& v) { acc.add(j, c * Block(Fr * v)); });
      } else {
        forRowOfB(r, [&](Index j, const Block& v) { acc.add(j, c * v); });
      }
    }
    slot[p] = static_cast<Index>(R.start.size()) - 1;
    acc.flush(R.start, R.cols, R.blocks);
  }
  // the changed rows: their columns and first block
  const auto changedRow = [&](Index p) -> std::pair<std::span<const Index>, const Block*> {
    if (slot[p] >= 0) {
      const Index b = R.start[slot[p]], e = R.start[slot[p] + 1];
      return {std::span<const Index>(R.cols.data() + b, static_cast<std::size_t>(e - b)), R.blocks.data() + b};
    }
    const Index b = B.start[bSlot[p]], e = B.start[bSlot[p] + 1];
    return {std::span<const Index>(B.cols.data() + b, static_cast<std::size_t>(e - b)), B.blocks.data() + b};
  };
  bool inPlace = true;
  for (Index p = 0; p < n && inPlace; ++p) {
    if (slot[p] < 0 && bSlot[p] < 0) continue;
    const auto cols = changedRow(p).first;
    inPlace = static_cast<Index>(cols.size()) == Ac.rowEnd(p) - Ac.rowBegin(p) &&
              std::equal(cols.begin(), cols.end(), Ac.columns().begin() + Ac.rowBegin(p));
  }
  if (inPlace) {
    A.modifyBlocks([&](Index p, Index k, Block& value) {
      if (slot[p] < 0 && bSlot[p] < 0) return false;
      value = changedRow(p).second[k - Ac.rowBegin(p)];
      return true;
    });
    return;
  }
  // a new matrix: T'AT's pattern, then its blocks in one pass over the rows
  const auto rowOf = [&](Index p, auto&& f) {
    if (slot[p] < 0 && bSlot[p] < 0) {
      for (Index k = Ac.rowBegin(p); k < Ac.rowEnd(p); ++k) f(Ac.column(k), Ac.blockAt(k));
      return;
    }
    const auto [cols, blocks] = changedRow(p);
    for (std::size_t i = 0; i < cols.size(); ++i) f(cols[i], blocks[i]);
  };
  typename BlockSparseMatrix<d>::Pattern pattern;
  pattern.rowStart.resize(static_cast<std::size_t>(n) + 1);
  pattern.rowStart[0] = 0;
  for (Index p = 0; p < n; ++p) {
    const Index length = slot[p] < 0 && bSlot[p] < 0 ? Ac.rowEnd(p) - Ac.rowBegin(p)
                                                     : static_cast<Index>(changedRow(p).first.size());
    pattern.rowStart[p + 1] = pattern.rowStart[p] + length;
  }
  pattern.columns.resize(static_cast<std::size_t>(pattern.rowStart[n]));
  forRanges(n, [&](Index begin, Index end) {
    for (Index p = begin; p < end; ++p) {
      Index k = pattern.rowStart[p];
      rowOf(p, [&](Index j, const Block&) { pattern.columns[k++] = j; });
    }
  });
  const std::vector<Index> rowStart = pattern.rowStart;
  A = BlockSparseMatrix<d>::fromRowRanges(std::move(pattern), [&](Index first, Index last, Block* blocks) {
    const Index base = rowStart[first];
    for (Index p = first; p < last; ++p) {
      Index k = rowStart[p] - base;
      rowOf(p, [&](Index, const Block& v) { blocks[k++] = v; });
    }
  });
}

}  // namespace

template <int d>
void ContactProblem<d>::transform(BlockSparseMatrix<d>& A, bool applied) {
  const Index n = A.rows();
  const mesh::CsrMatrix& C = basis_;
  if (C.rows != n || C.cols != n || C.rowStart.size() != static_cast<std::size_t>(n) + 1)
    throw Error("contact problem: basis transformation of size " + std::to_string(C.rows) + " x " +
                std::to_string(C.cols) + " for " + std::to_string(n) + " vertices");
  // Dirichlet components at transformed (slave) vertices: as for one body, a prescribed component
  // orthogonal to the constraint direction is allowed (a roller side meeting the contact surface).
  // The transformation then leaves that component alone (u_{p,a} = x_{p,a}, so the value is a
  // Dirichlet value of x as well), which does not change the constraint n_p.(D u_p - sum M u_q)
  // when n_{p,a} is zero. A symmetry or roller line through a curved slave surface meets it at a
  // vertex with one slave face, whose averaged normal leans by half that face's angle: there
  // |n_{p,a}| <= kMaxPrescribedNormal is accepted too, and the constraint acts along the normal
  // projected onto the free components, as for one body (setup()); the term n_{p,a} (C x)_{p,a} of
  // the master side is dropped from it (docs/theory.md#dual-mortar). A larger component would tie
  // x_{p,a} to the master unknowns and is an error.
  std::vector<Index> constraintOf(static_cast<std::size_t>(n), -1);
  for (Index k = 0; k < contact_.size(); ++k) constraintOf[contact_.vertex(k)] = k;
  skip_.clear();
  for (Index p = 0; p < n; ++p) {
    if (C.rowStart[p + 1] == C.rowStart[p]) continue;
    for (int a = 0; a < d; ++a) {
      if (!dirichlet_.constrained[static_cast<std::size_t>(p) * d + a]) continue;
      const Index k = constraintOf[p];
      const double na = k >= 0 ? contact_.direction(k)[a] : 1.0;
      if (!(std::abs(na) <= kMaxPrescribedNormal)) {
        std::ostringstream os;
        os << "contact problem: vertex " << p << " is a mortar slave node whose prescribed component "
           << "xyz"[a] << " is not orthogonal to its contact normal (normal component " << na << ", more than "
           << kMaxPrescribedNormal
           << "); prescribe only components orthogonal to the contact surface there (rollers), or move the "
              "Dirichlet data to the master side or away from the contact interface";
        throw Error(os.str());
      }
      if (skip_.empty()) skip_.assign(static_cast<std::size_t>(n), 0);
      skip_[p] |= static_cast<std::uint8_t>(1u << a);
    }
    for (Index k = C.rowStart[p]; k < C.rowStart[p + 1]; ++k) {
      const Index q = C.columns[k];
      if (q < 0 || q >= n || C.rowStart[q + 1] != C.rowStart[q] || !std::isfinite(C.values[k]))
        throw Error("contact problem: invalid basis transformation (C^2 != 0, an index out of range or a "
                    "non-finite entry in row " + std::to_string(p) + ")");
    }
  }
  if (applied) return;
  transformOperator(A, C, skip_);
  b_ = applyTransposedBasis<d>(C, skip_, b_);
}

template <int d>
typename BlockSparseMatrix<d>::Pattern ContactProblem<d>::transformedPattern(typename BlockSparseMatrix<d>::Pattern pattern,
                                                                           const mesh::CsrMatrix& C) {
  const Index n = static_cast<Index>(pattern.rowStart.size()) - 1;
  if (C.rows == 0) return pattern;
  if (C.rows != n || C.cols != n || C.rowStart.size() != static_cast<std::size_t>(n) + 1)
    throw Error("contact problem: basis transformation of size " + std::to_string(C.rows) + " x " +
                std::to_string(C.cols) + " for a pattern of " + std::to_string(n) + " rows");
  const auto& rs = pattern.rowStart;
  const auto& cs = pattern.columns;
  const TransformationRoles roles(C, n);
  // the columns transformOperator() produces, symbolically: B_r = cols(A_r) + the C columns of its
  // slave columns on touched rows; T'B_p = cols(B_p) + cols(B_r) over C_rp != 0 on master rows
  std::vector<Index> bSlot(n, -1), slot(n, -1);
  std::vector<Index> bStart{0}, bCols, start{0}, cols;
  std::vector<char> seen(static_cast<std::size_t>(n), 0);
  std::vector<Index> row;
  const auto flush = [&](std::vector<Index>& starts, std::vector<Index>& out) {
    std::sort(row.begin(), row.end());
    out.insert(out.end(), row.begin(), row.end());
    starts.push_back(static_cast<Index>(out.size()));
    for (Index j : row) seen[j] = 0;
    row.clear();
  };
  const auto add = [&](Index j) {
    if (!seen[j]) {
      seen[j] = 1;
      row.push_back(j);
    }
  };
  for (Index r = 0; r < n; ++r) {
    bool touched = false;
    for (Index k = rs[r]; k < rs[r + 1] && !touched; ++k) touched = roles.slave[cs[k]] != 0;
    if (!touched) continue;
    for (Index k = rs[r]; k < rs[r + 1]; ++k) {
      add(cs[k]);
      for (Index m = C.rowStart[cs[k]]; m < C.rowStart[cs[k] + 1]; ++m) add(C.columns[m]);
    }
    bSlot[r] = static_cast<Index>(bStart.size()) - 1;
    flush(bStart, bCols);
  }
  const auto forRowOfB = [&](Index r, auto&& f) {
    if (bSlot[r] >= 0)
      for (Index k = bStart[bSlot[r]]; k < bStart[bSlot[r] + 1]; ++k) f(bCols[k]);
    else
      for (Index k = rs[r]; k < rs[r + 1]; ++k) f(cs[k]);
  };
  const TransposedBasis Ct(C, n);
  for (Index p = 0; p < n; ++p) {
    if (!roles.master[p]) continue;
    forRowOfB(p, add);
    for (Index m = Ct.start[p]; m < Ct.start[p + 1]; ++m) forRowOfB(Ct.rows[m], add);
    slot[p] = static_cast<Index>(start.size()) - 1;
    flush(start, cols);
  }
  typename BlockSparseMatrix<d>::Pattern out;
  out.rowStart.resize(static_cast<std::size_t>(n) + 1);
  out.rowStart[0] = 0;
  const auto length = [&](Index p) {
    return slot[p] >= 0 ? start[slot[p] + 1] - start[slot[p]]
           : bSlot[p] >= 0 ? bStart[bSlot[p] + 1] - bStart[bSlot[p]]
                           : rs[p + 1] - rs[p];
  };
  for (Index p = 0; p < n; ++p) out.rowStart[p + 1] = out.rowStart[p] + length(p);
  out.columns.resize(static_cast<std::size_t>(out.rowStart[n]));
  forRanges(n, [&](Index begin, Index end) {
    for (Index p = begin; p < end; ++p) {
      Index k = out.rowStart[p];
      if (slot[p] >= 0)
        for (Index i = start[slot[p]]; i < start[slot[p] + 1]; ++i) out.columns[k++] = cols[i];
      else
        forRowOfB(p, [&](Index j) { out.columns[k++] = j; });
    }
  });
  return out;
}

template <int d>
Eigen::VectorXd ContactProblem<d>::toDisplacement(const Eigen::VectorXd& x) const {
  return applyBasis(x, 1.0);
}

template <int d>
Eigen::VectorXd ContactProblem<d>::fromDisplacement(const Eigen::VectorXd& u) const {
  return applyBasis(u, -1.0);  // (I + C)^{-1} = I - C, as C^2 = 0
}

template <int d>
Eigen::VectorXd ContactProblem<d>::applyBasis(const Eigen::VectorXd& x, double sign) const {
  // entry by entry into u_p (sign * v is exact for sign = +-1): the bits of the plain product
  // without skipped components
  Eigen::VectorXd u = x;
  const mesh::CsrMatrix& C = basis_;
  for (Index p = 0; p < C.rows; ++p) {
    if (C.rowStart[p + 1] == C.rowStart[p]) continue;
    const std::uint8_t skip = skip_.empty() ? 0 : skip_[p];
    auto up = u.template segment<d>(static_cast<Eigen::Index>(p) * d);
    for (Index k = C.rowStart[p]; k < C.rowStart[p + 1]; ++k) {
      Eigen::Matrix<double, d, 1> v = C.values[k] * x.template segment<d>(static_cast<Eigen::Index>(C.columns[k]) * d);
      if (skip)
        for (int a = 0; a < d; ++a)
          if (skip & (1u << a)) v[a] = 0;
      up += sign * v;
    }
  }
  return u;
}

template <int d>
Eigen::VectorXd ContactProblem<d>::applyInverseTransposedBasis(const Eigen::VectorXd& y) const {
  return applyTransposedBasis<d>(basis_, skip_, y, -1.0);  // (I + C)^{-T} = I - C'
}

template <int d>
void ContactProblem<d>::setup(BlockSparseMatrix<d> A, bool applied) {
  const Index n = A.rows();
  if (b_.size() != static_cast<Eigen::Index>(n) * d ||
      dirichlet_.constrained.size() != static_cast<std::size_t>(n) * d ||
      dirichlet_.values.size() != static_cast<Eigen::Index>(n) * d)
    throw Error("contact problem: matrix, load and Dirichlet data have inconsistent sizes");
  if (contact_.dimension() != d || contact_.numMeshVertices() != n)
    throw Error("contact problem: the contact set " + contact_.boundaryLabel() +
                " was built for another mesh (dimension " + std::to_string(contact_.dimension()) + ", " +
                std::to_string(contact_.numMeshVertices()) + " vertices; the problem has dimension " +
                std::to_string(d) + ", " + std::to_string(n) + " vertices)");
  if (transformed()) transform(A, applied);
  {
    static std::atomic<std::uint64_t> counter{0};
    operatorId_ = ++counter;
    Eigen::VectorXd g = Eigen::VectorXd::Zero(b_.size());
    bool any = false;
    for (std::size_t i = 0; i < dirichlet_.constrained.size(); ++i)
      if (dirichlet_.constrained[i]) {
        g[static_cast<Eigen::Index>(i)] = dirichlet_.values[static_cast<Eigen::Index>(i)];
        any = any || g[static_cast<Eigen::Index>(i)] != 0;
      }
    dirichletLift_ = any ? Eigen::VectorXd(A * g) : Eigen::VectorXd::Zero(b_.size());
  }
  applyDirichlet(A, b_, dirichlet_);
  rotated_.assign(contact_.size(), 0);

  constraints_.resize(contact_.size());
  for (Index k = 0; k < contact_.size(); ++k) {
    Constraint& c = constraints_[k];
    c.vertex = contact_.vertex(k);
    const Vec nu = contact_.direction(k).template head<d>();
    const double g = contact_.gap(k);
    c.direction = nu;
    c.gap = g;
    c.scale = 1;
    c.rotation = Mat::Identity();
    if (g == kInf) continue;  // unconstrained node: identity rotation keeps the Dirichlet rows intact

    // split the components into free (F) and prescribed (D)
    std::vector<int> F, D;
    double shift = 0;
    for (int a = 0; a < d; ++a) {
      const std::size_t i = static_cast<std::size_t>(c.vertex) * d + a;
      if (dirichlet_.constrained[i]) {
        D.push_back(a);
        shift += nu[a] * dirichlet_.values[static_cast<Eigen::Index>(i)];
      } else {
        F.push_back(a);
      }
    }
    rotated_[k] = 1;
    c.shift = shift;
    if (D.empty()) {
      c.rotation = householderRotation(contact_.direction(k)).template topLeftCorner<d, d>();
    } else {
      Vec nuF = nu;
      for (int a : D) nuF[a] = 0;
      const double norm = nuF.norm();
      if (norm <= 1e-12) {
        // the constrained component is prescribed: check the data, then drop the constraint
        if (shift > g + 1e-12 * std::max({1.0, std::abs(g), std::abs(shift)})) {
          std::ostringstream at;
          const Point& x = contact_.position(k);
          at << "(" << x[0] << ", " << x[1] << (d == 3 ? ", " + num(x[2]) : std::string()) << ")";
          throw Error("contact boundary " + contact_.boundaryLabel() + ", vertex " + std::to_string(c.vertex) +
                      " at " + at.str() + ": the Dirichlet values give nu.u = " + num(shift) + " > gap " +
                      num(g) + " (the prescribed displacement violates the contact constraint)");
        }
        c.gap = kInf;
        rotated_[k] = 2;  // constraint decided by the Dirichlet data (identity rotation)
        continue;
      }
      c.direction = nuF / norm;
      c.gap = (g - shift) / norm;
      c.scale = norm;
      // columns: direction, the rest of an orthonormal basis of the free subspace, prescribed axes
      Eigen::VectorXd y(F.size());
      for (std::size_t i = 0; i < F.size(); ++i) y[static_cast<Eigen::Index>(i)] = c.direction[F[i]];
      const Eigen::MatrixXd H = householder(y);
      c.rotation.setZero();
      for (std::size_t j = 0; j < F.size(); ++j)
        for (std::size_t i = 0; i < F.size(); ++i)
          c.rotation(F[i], static_cast<Eigen::Index>(j)) = H(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      for (std::size_t j = 0; j < D.size(); ++j) c.rotation(D[j], static_cast<Eigen::Index>(F.size() + j)) = 1;
    }
  }
  rotateOperator(A);
  isolatePrescribed(A);
  A.shareRepeatedBlocks();  // the same values; fewer bytes per sweep on grids of repeated cells
  A_ = std::make_shared<const BlockSparseMatrix<d>>(std::move(A));
}

template <int d>
void ContactProblem<d>::isolatePrescribed(BlockSparseMatrix<d>& A) const {
  // A vertex whose every component is prescribed has an identity row and column in A~ (applyDirichlet,
  // its rotation is the identity): its off-diagonal blocks are zero. When such vertices hold half of
  // the blocks or more (a body prescribed everywhere: a meshed rigid master), the blocks leave the
  // pattern, and every product, sweep and coarse operator skips them. Otherwise (clamped faces) the
  // pattern stays, and with it the bits of every result: a smaller pattern changes the coarse
  // operators' patterns, hence CHOLMOD's ordering and the last bits of the solution.
  const Index n = A.rows();
  std::vector<char> fixed(static_cast<std::size_t>(n), 0);
  Index count = 0;
  for (Index p = 0; p < n; ++p) {
    bool all = true;
    for (int a = 0; a < d && all; ++a) all = dirichlet_.constrained[static_cast<std::size_t>(p) * d + a] != 0;
    fixed[static_cast<std::size_t>(p)] = all;
    count += all;
  }
  if (count == 0) return;
  // the blocks in rows or columns of fixed vertices are at most twice those in their rows (the
  // pattern is symmetric): a pass over the whole pattern only when half of the blocks may go
  Index bound = 0;
  for (Index p = 0; p < n; ++p)
    if (fixed[static_cast<std::size_t>(p)]) bound += 2 * (A.rowEnd(p) - A.rowBegin(p));
  if (2 * bound < A.nonZeroBlocks()) return;
  if (2 * A.isolatedBlocks(fixed) < A.nonZeroBlocks()) return;
  A.isolate(fixed);
}

template <int d>
void ContactProblem<d>::rotateOperator(BlockSparseMatrix<d>& A) {
  // A~ = Q'AQ in place (the one copy of the operator the problem keeps), and the prescribed
  // components in rotated numbering: the columns of Q_p that are prescribed axes
  const Index n = A.rows();
  std::vector<const Mat*> Q(static_cast<std::size_t>(n), nullptr);
  for (const Constraint& c : constraints_) Q[c.vertex] = &c.rotation;
  prescribedRotated_.assign(dirichlet_.constrained.size(), 0);
  // rows on threads (BlockSparseMatrix::modifyBlocks, which keeps shared blocks shared); only the
  // blocks of rotated rows or columns change
  A.modifyBlocks([&](Index p, Index k, Mat& B) {
    const Index q = A.column(k);
    if (!Q[p] && !Q[q]) return false;
    if (Q[p]) B = Q[p]->transpose() * B;
    if (Q[q]) B = B * (*Q[q]);
    return true;
  });
  for (Index p = 0; p < n; ++p)
    for (int a = 0; a < d; ++a) {
      const std::size_t i = static_cast<std::size_t>(p) * d + a;
      if (!dirichlet_.constrained[i]) continue;
      if (!Q[p]) {
        prescribedRotated_[i] = 1;
        continue;
      }
      for (int j = 0; j < d; ++j)
        if (std::abs((*Q[p])(a, j)) == 1.0) prescribedRotated_[static_cast<std::size_t>(p) * d + j] = 1;
    }
}

template <int d>
void ContactProblem<d>::multiply(const Eigen::VectorXd& u, Eigen::VectorXd& Au) const {
  A_->multiply(toRotated(u), Au);
  for (const Constraint& c : constraints_) {
    auto s = Au.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d);
    const Vec v = c.rotation * s;
    s = v;
  }
}

template <int d>
double ContactProblem<d>::energy(const Eigen::VectorXd& u) const {
  const double e = 0.5 * A_->energy(toRotated(u)) - b_.dot(u);
  return frictional() ? e + frictionEnergy(u) : e;
}

template <int d>
void ContactProblem<d>::setFriction(std::vector<double> slipBounds, Eigen::VectorXd origin) {
  if (!slipBounds.empty() && slipBounds.size() != constraints_.size())
    throw Error("contact problem: setFriction with " + std::to_string(slipBounds.size()) +
                " slip bounds, the contact boundary " + contact_.boundaryLabel() + " has " +
                std::to_string(constraints_.size()) + " nodes");
  if (origin.size() != 0 && origin.size() != static_cast<Eigen::Index>(numDofs()))
    throw Error("contact problem: setFriction with an origin of " + std::to_string(origin.size()) +
                " entries, the problem has " + std::to_string(numDofs()) + " unknowns");
  bool any = false;
  for (std::size_t k = 0; k < slipBounds.size(); ++k) {
    const double s = slipBounds[k];
    if (!(s >= 0) || !std::isfinite(s))
      throw Error("contact problem: slip bound " + num(s) + " at contact node " + std::to_string(k) +
                  " (must be finite and >= 0)");
    any = any || (s > 0 && constraints_[k].bounded());
  }
  if (origin.size() != 0 && !origin.allFinite())
    throw Error("contact problem: setFriction: the origin contains NaN or Inf");
  // A prescribed component of a mortar slave vertex is left out of the transformation (basisSkip()):
  // it is an absolute displacement, and the friction term sees only the free, relative components.
  // That is the relative slip only if the master moves no more in that component, i.e. if every
  // master vertex of the slave's row of C has it prescribed too (a symmetry plane through both
  // bodies). Otherwise the master could slide along it unopposed: refuse.
  if (any && !skip_.empty())
    for (std::size_t k = 0; k < slipBounds.size(); ++k) {
      if (!(slipBounds[k] > 0) || !constraints_[k].bounded()) continue;
      const Index p = constraints_[k].vertex;
      for (int a = 0; a < d; ++a) {
        if (!(skip_[static_cast<std::size_t>(p)] & (1u << a))) continue;
        for (Index j = basis_.rowStart[p]; j < basis_.rowStart[p + 1]; ++j)
          if (!dirichlet_.constrained[static_cast<std::size_t>(basis_.columns[j]) * d + a])
            throw Error("contact problem: friction at mortar slave vertex " + std::to_string(p) + " (contact node " +
                        std::to_string(k) + " of " + contact_.boundaryLabel() + "): its " + "xyz"[a] +
                        " component is prescribed, but master vertex " + std::to_string(basis_.columns[j]) +
                        " moves freely in " + "xyz"[a] + ", so the relative slip in " + "xyz"[a] +
                        " would escape friction; prescribe it on both surfaces (a symmetry plane) or move the "
                        "Dirichlet data off the slave side of the contact interface");
      }
    }
  slip_ = any ? std::move(slipBounds) : std::vector<double>{};
  origin_ = any ? std::move(origin) : Eigen::VectorXd{};
}

template <int d>
typename ContactProblem<d>::Vec ContactProblem<d>::tangentialSlip(Index k, const Eigen::VectorXd& x) const {
  const Constraint& c = constraints_[k];
  if (!c.bounded()) return Vec::Zero();
  const auto i = static_cast<Eigen::Index>(c.vertex) * d;
  Vec t = x.template segment<d>(i);
  if (origin_.size() > 0) t -= origin_.template segment<d>(i);
  t = c.rotation.transpose() * t;
  t[0] = 0;
  for (int a = 1; a < d; ++a)
    if (prescribedRotated_[static_cast<std::size_t>(i + a)]) t[a] = 0;
  return t;
}

template <int d>
double ContactProblem<d>::frictionEnergy(const Eigen::VectorXd& x) const {
  double e = 0;
  for (std::size_t k = 0; k < slip_.size(); ++k)
    if (slip_[k] > 0) e += slip_[k] * tangentialSlip(static_cast<Index>(k), x).norm();
  return e;
}

template <int d>
Eigen::VectorXd ContactProblem<d>::gradient(const Eigen::VectorXd& u) const {
  Eigen::VectorXd g;
  multiply(u, g);
  return g - b_;
}

template <int d>
double ContactProblem<d>::energyNorm(const Eigen::VectorXd& x) const {
  return std::sqrt(std::max(0.0, A_->energy(toRotated(x))));
}

template <int d>
double ContactProblem<d>::maxViolation(const Eigen::VectorXd& u) const {
  double v = 0;
  for (const Constraint& c : constraints_)
    if (c.bounded())
      v = std::max(v, c.direction.dot(u.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d)) - c.gap);
  return v;
}

template <int d>
void ContactProblem<d>::projectToFeasible(Eigen::VectorXd& u) const {
  if (u.size() != static_cast<Eigen::Index>(numDofs())) u = Eigen::VectorXd::Zero(numDofs());
  for (std::size_t i = 0; i < dirichlet_.constrained.size(); ++i)
    if (dirichlet_.constrained[i]) u[static_cast<Eigen::Index>(i)] = dirichlet_.values[static_cast<Eigen::Index>(i)];
  for (const Constraint& c : constraints_) {
    if (!c.bounded()) continue;
    auto up = u.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d);
    const double excess = c.direction.dot(up) - c.gap;
    if (excess > 0) {
      up -= excess * c.direction;
      // round-off may leave the node a few ulps outside; put the normal component exactly on the bound
      Vec w = c.rotation.transpose() * up;
      w[0] = std::min(w[0], c.gap);
      up = c.rotation * w;
    }
  }
}

template <int d>
Eigen::VectorXd ContactProblem<d>::multipliers(const Eigen::VectorXd& u) const {
  // only the rows of the constrained vertices of r = b - A u (each summed as in A * u)
  Eigen::VectorXd mu = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(constraints_.size()));
  const BlockSparseMatrix<d>& A = *A_;
  const Eigen::VectorXd w = toRotated(u);
  for (std::size_t k = 0; k < constraints_.size(); ++k) {
    const Constraint& c = constraints_[k];
    if (!c.bounded()) continue;
    // (A u)_p = Q_p (A~ w)_p with w = Q'u
    Vec s = Vec::Zero();
    for (Index m = A.rowBegin(c.vertex); m < A.rowEnd(c.vertex); ++m)
      s.noalias() += A.blockAt(m) * w.template segment<d>(static_cast<Eigen::Index>(A.column(m)) * d);
    const Vec r = b_.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d) - c.rotation * s;
    mu[static_cast<Eigen::Index>(k)] = c.direction.dot(r);
  }
  return mu;
}

template <int d>
void ContactProblem<d>::setLoad(const Eigen::VectorXd& load) {
  if (load.size() != b_.size())
    throw Error("contact problem: setLoad with " + std::to_string(load.size()) + " entries, the problem has " +
                std::to_string(b_.size()) + " unknowns");
  setLoad(transformed() ? applyTransposedBasis<d>(basis_, skip_, load) : load, Transformed{});
}

template <int d>
void ContactProblem<d>::setLoad(const Eigen::VectorXd& load, Transformed) {
  if (load.size() != b_.size())
    throw Error("contact problem: setLoad with " + std::to_string(load.size()) + " entries, the problem has " +
                std::to_string(b_.size()) + " unknowns");
  b_ = load - dirichletLift_;
  for (std::size_t i = 0; i < dirichlet_.constrained.size(); ++i)
    if (dirichlet_.constrained[i]) b_[static_cast<Eigen::Index>(i)] = dirichlet_.values[static_cast<Eigen::Index>(i)];
}

template <int d>
void ContactProblem<d>::setGaps(const std::vector<double>& gaps) {
  if (gaps.size() != constraints_.size())
    throw Error("contact problem: setGaps with " + std::to_string(gaps.size()) + " gaps, the contact boundary " +
                contact_.boundaryLabel() + " has " + std::to_string(constraints_.size()) + " nodes");
  for (std::size_t k = 0; k < gaps.size(); ++k) {
    const double g = gaps[k];
    Constraint& c = constraints_[k];
    if (std::isnan(g) || g == -kInf)
      throw Error("contact problem: setGaps: gap " + num(g) + " at contact node " + std::to_string(k) + " (vertex " +
                  std::to_string(c.vertex) + ")");
    if (g == kInf) {
      c.gap = kInf;
      continue;
    }
    if (rotated_[k] == 0)
      throw Error("contact problem: setGaps: finite gap at contact node " + std::to_string(k) + " (vertex " +
                  std::to_string(c.vertex) + "), which had no constraint (infinite gap) at construction");
    if (rotated_[k] == 2) {  // normal component prescribed: the data decide
      if (c.shift > g + 1e-12 * std::max({1.0, std::abs(g), std::abs(c.shift)}))
        throw Error("contact boundary " + contact_.boundaryLabel() + ", vertex " + std::to_string(c.vertex) +
                    ": the Dirichlet values give nu.u = " + num(c.shift) + " > gap " + num(g) +
                    " (the prescribed displacement violates the contact constraint)");
      continue;
    }
    c.gap = (g - c.shift) / c.scale;
  }
}

template <int d>
Eigen::VectorXd ContactProblem<d>::toRotated(const Eigen::VectorXd& u) const {
  Eigen::VectorXd w = u;
  for (const Constraint& c : constraints_) {
    const auto i = static_cast<Eigen::Index>(c.vertex) * d;
    w.template segment<d>(i) = c.rotation.transpose() * u.template segment<d>(i);
  }
  return w;
}

template <int d>
Eigen::VectorXd ContactProblem<d>::fromRotated(const Eigen::VectorXd& w) const {
  Eigen::VectorXd u = w;
  for (const Constraint& c : constraints_) {
    const auto i = static_cast<Eigen::Index>(c.vertex) * d;
    u.template segment<d>(i) = c.rotation * w.template segment<d>(i);
  }
  return u;
}

template <int d>
RotatedProblem<d> ContactProblem<d>::rotated() const {
  RotatedProblem<d> r;
  r.matrixPtr = A_;
  r.rhs = toRotated(b_);
  r.upper.assign(numVertices(), kInf);
  for (const Constraint& c : constraints_)
    if (c.bounded()) r.upper[c.vertex] = c.gap;
  r.prescribed = prescribedRotated_;
  r.diagonalLowerBound = lowerBound_;
  rotateFriction(r);
  return r;
}

template <int d>
void ContactProblem<d>::rotateFriction(RotatedProblem<d>& r) const {
  r.frictionVertices.clear();
  r.slip.clear();
  r.origin.resize(0);
  for (std::size_t k = 0; k < slip_.size(); ++k) {
    const Constraint& c = constraints_[k];
    if (!(slip_[k] > 0) || !c.bounded()) continue;
    bool tangential = false;  // a free tangential component (else the term is zero)
    for (int a = 1; a < d; ++a)
      tangential = tangential || !prescribedRotated_[static_cast<std::size_t>(c.vertex) * d + a];
    if (!tangential) continue;
    r.frictionVertices.push_back(c.vertex);
    r.slip.push_back(slip_[k]);
  }
  if (r.frictional() && origin_.size() > 0) r.origin = toRotated(origin_);
}

template <int d>
bool RotatedProblem<d>::hasErrorBound() const {
  if (diagonalLowerBound.empty() || frictional()) return false;
  for (Index p = 0; p < numVertices(); ++p) {
    bool free = false;
    for (int a = 0; a < d; ++a) free = free || !prescribed[static_cast<std::size_t>(p) * d + a];
    if (free && !(diagonalLowerBound[static_cast<std::size_t>(p)] > 0)) return false;
  }
  return true;
}

template <int d>
double RotatedProblem<d>::errorBound(const Eigen::VectorXd& w, const Eigen::VectorXd& Aw) const {
  if (!hasErrorBound()) return std::numeric_limits<double>::quiet_NaN();
  double gain = 0;
  for (Eigen::Index i = 0; i < w.size(); ++i) {
    if (prescribed[static_cast<std::size_t>(i)]) continue;
    const auto p = static_cast<std::size_t>(i / d);
    const double room = i % d == 0 ? upper[p] - w[i] : kInf;
    gain += componentGain(rhs[i] - Aw[i], diagonalLowerBound[p], room);
  }
  return std::sqrt(2 * gain);
}

template <int d>
void ContactProblem<d>::setDiagonalLowerBound(std::vector<double> bound) {
  if (transformed())
    throw Error("contact problem: a diagonal lower bound cannot be declared for a problem with a basis "
                "transformation (its operator T'AT has none in general)");
  if (static_cast<Index>(bound.size()) != numVertices())
    throw Error("contact problem: the diagonal lower bound has " + std::to_string(bound.size()) +
                " entries, the problem " + std::to_string(numVertices()) + " vertices");
  for (std::size_t p = 0; p < bound.size(); ++p)
    if (!(bound[p] >= 0) || !std::isfinite(bound[p]))
      throw Error("contact problem: the diagonal lower bound at vertex " + std::to_string(p) + " is " +
                  std::to_string(bound[p]) + " (must be finite and >= 0)");
  lowerBound_ = std::move(bound);
}

// --- outputs -----------------------------------------------------------------------------------

namespace {

/// computeContactOutputs with its scales U, F given (Au = A u).
template <int d>
ContactOutputs contactOutputs(const ContactProblem<d>& problem, const Eigen::VectorXd& u, const Eigen::VectorXd& Au,
                              double relativeTolerance, double U, double F) {
  const ContactSet& cs = problem.contactSet();
  const Index n = cs.size();
  ContactOutputs out;
  out.inContact.assign(n, 0);
  out.multiplier.assign(n, 0.0);
  out.pressure.assign(n, 0.0);
  out.tangential.assign(n, Point::Zero());
  out.slip.assign(n, 0.0);
  out.state.assign(n, 0);
  using Vec = Eigen::Matrix<double, d, 1>;
  const Eigen::VectorXd mu = problem.multipliers(u);
  for (Index k = 0; k < n; ++k) {
    const auto& c = problem.constraint(k);
    const Point& nu = cs.direction(k);
    const double un = nu.template head<d>().dot(u.template segment<d>(static_cast<Eigen::Index>(c.vertex) * d));
    // closed, and carrying a force: two bodies touching without load are not in contact
    out.inContact[k] = std::isfinite(cs.gap(k)) && cs.gap(k) - un <= relativeTolerance * U &&
                       mu[k] > relativeTolerance * F;
    out.contactNodes += out.inContact[k];
    out.multiplier[k] = mu[k] / c.scale;
    // (a ghost of a distributed run without a held face has no mass here: its owner has the pressure)
    out.pressure[k] = cs.boundaryMass(k) > 0 ? out.multiplier[k] / cs.boundaryMass(k) : 0.0;
    out.force += out.multiplier[k] * nu;
    if (!c.bounded()) continue;
    // the tangential force in the rotated frame: (b - A u)_p without the normal and prescribed parts
    const auto i = static_cast<Eigen::Index>(c.vertex) * d;
    Vec q = c.rotation.transpose() * Vec(problem.rhs().template segment<d>(i) - Au.template segment<d>(i));
    q[0] = 0;
    for (int a = 1; a < d; ++a)
      if (problem.prescribedRotated()[static_cast<std::size_t>(i + a)]) q[a] = 0;
    const Vec fT = c.rotation * q;
    out.tangential[k].template head<d>() = fT;
    out.tangentialForce.template head<d>() += fT;
    out.slip[k] = problem.tangentialSlip(k, u).norm();
    if (out.inContact[k]) {
      const bool stick = out.slip[k] <= relativeTolerance * U;
      out.state[k] = stick ? 1 : 2;
      ++(stick ? out.stickNodes : out.slipNodes);
    }
  }
  for (const ContactSet::Face& f : cs.faces()) {
    if (std::all_of(f.nodes.begin(), f.nodes.end(), [&](Index k) { return out.inContact[k] != 0; }))
      out.contactArea += f.measure;
    if (std::all_of(f.nodes.begin(), f.nodes.end(), [&](Index k) { return out.state[k] == 1; }))
      out.stickArea += f.measure;
  }
  out.contactRadius = d == 3 ? std::sqrt(out.contactArea / std::numbers::pi) : out.contactArea / 2;
  return out;
}

}  // namespace

template <int d>
ContactOutputs computeContactOutputs(const ContactProblem<d>& problem, const Eigen::VectorXd& u,
                                     double relativeTolerance) {
  const ContactSet& cs = problem.contactSet();
  if (u.size() != static_cast<Eigen::Index>(problem.numDofs()))
    throw Error("contact outputs: displacement vector of wrong size");
  double U = u.lpNorm<Eigen::Infinity>();
  for (Index k = 0; k < cs.size(); ++k)
    if (std::isfinite(cs.gap(k))) U = std::max(U, std::abs(cs.gap(k)));
  if (!(U > 0)) U = 1;
  // force scale F = max(|b_i|, |(A u)_i|) over the free components, as for the KKT residuals
  Eigen::VectorXd Au;
  problem.multiply(u, Au);
  double F = 0;
  const auto& prescribed = problem.dirichlet().constrained;
  for (Eigen::Index i = 0; i < Au.size(); ++i)
    if (!prescribed[static_cast<std::size_t>(i)]) F = std::max({F, std::abs(problem.rhs()[i]), std::abs(Au[i])});
  return contactOutputs(problem, u, Au, relativeTolerance, U, F);
}

template <int d>
ContactOutputs computeContactOutputs(const ContactProblem<d>& problem, const Eigen::VectorXd& u, double relativeTolerance,
                                     double displacementScale, double forceScale) {
  if (u.size() != static_cast<Eigen::Index>(problem.numDofs()))
    throw Error("contact outputs: displacement vector of wrong size");
  Eigen::VectorXd Au;
  problem.multiply(u, Au);
  return contactOutputs(problem, u, Au, relativeTolerance, displacementScale, forceScale);
}


template struct RotatedProblem<2>;
template struct RotatedProblem<3>;
template class ContactProblem<2>;
template class ContactProblem<3>;
template ContactOutputs computeContactOutputs<2>(const ContactProblem<2>&, const Eigen::VectorXd&, double);
template ContactOutputs computeContactOutputs<3>(const ContactProblem<3>&, const Eigen::VectorXd&, double);
template ContactOutputs computeContactOutputs<2>(const ContactProblem<2>&, const Eigen::VectorXd&, double, double, double);
template ContactOutputs computeContactOutputs<3>(const ContactProblem<3>&, const Eigen::VectorXd&, double, double, double);

}  // namespace obs
