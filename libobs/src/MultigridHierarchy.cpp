#include "obs/obs/MultigridHierarchy.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <optional>
#include <utility>
#include <span>
#include <string>

#include "obs/mesh/Error.hpp"
#include "obs/obs/DistributedGrid.hpp"

namespace obs {
namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// The transpose of a scalar CSR matrix (columns ascending within each row).
mesh::CsrMatrix transpose(const mesh::CsrMatrix& P) {
  mesh::CsrMatrix T;
  T.rows = P.cols;
  T.cols = P.rows;
  T.rowStart.assign(T.rows + 1, 0);
  for (Index c : P.columns) ++T.rowStart[c + 1];
  for (Index i = 0; i < T.rows; ++i) T.rowStart[i + 1] += T.rowStart[i];
  T.columns.resize(P.columns.size());
  T.values.resize(P.values.size());
  std::vector<Index> next(T.rowStart.begin(), T.rowStart.end() - 1);
  for (Index r = 0; r < P.rows; ++r)
    for (Index k = P.rowStart[r]; k < P.rowStart[r + 1]; ++k) {
      const Index pos = next[P.columns[k]]++;
      T.columns[pos] = r;
      T.values[pos] = P.values[k];
    }
  return T;
}

/// The transpose of the first `rows` rows of P (the owned fine rows of a distributed level).
mesh::CsrMatrix transposeRows(const mesh::CsrMatrix& P, Index rows) {
  mesh::CsrMatrix head;
  head.rows = rows;
  head.cols = P.cols;
  head.rowStart.assign(P.rowStart.begin(), P.rowStart.begin() + rows + 1);
  head.columns.assign(P.columns.begin(), P.columns.begin() + P.rowStart[rows]);
  head.values.assign(P.values.begin(), P.values.begin() + P.rowStart[rows]);
  mesh::CsrMatrix T = transpose(head);
  T.cols = P.rows;
  return T;
}

/// Block pattern of P' F P (P scalar n_f x n_c, Pt its transpose), in chunks of 1,024 coarse rows
/// on threads() threads, joined in row order. For each chunk the column sets of the rows of F P
/// that its rows need are formed once (as the values in galerkinRows below); a coarse row is the
/// union of those of its fine support, sorted. The pattern is unique, so it does not depend on the
/// thread count.
template <int d>
BlockSparseMatrix<d> galerkinPattern(const BlockSparseMatrix<d>& F, const mesh::CsrMatrix& P,
                                     const mesh::CsrMatrix& Pt) {
  const Index nc = P.cols;
  constexpr Index kChunk = 1024;
  const Index chunks = (nc + kChunk - 1) / kChunk;
  std::vector<std::vector<Index>> chunkColumns(static_cast<std::size_t>(chunks));
  std::vector<Index> rowStart(static_cast<std::size_t>(nc) + 1, 0);  // row lengths first, at I + 1
  const int nt = nc >= kParallelMinRows ? threads() : 1;
#ifdef _OPENMP
#pragma omp parallel num_threads(nt)
#endif
  {
    std::vector<Index> fineRow(static_cast<std::size_t>(F.rows()), -1), mark(static_cast<std::size_t>(nc), -1);
    std::vector<Index> formed, start, fpColumns, row;  // the chunk's rows of F P, then one coarse row
#ifdef _OPENMP
#pragma omp for schedule(dynamic, 1)
#endif
    for (Index chunk = 0; chunk < chunks; ++chunk) {
      const Index first = chunk * kChunk, last = std::min(nc, (chunk + 1) * kChunk);
      formed.clear();
      start.assign(1, 0);
      fpColumns.clear();
      for (Index I = first; I < last; ++I)
        for (Index a = Pt.rowStart[I]; a < Pt.rowStart[I + 1]; ++a) {
          const Index p = Pt.columns[a];
          if (fineRow[p] >= 0) continue;
          fineRow[p] = static_cast<Index>(formed.size());
          formed.push_back(p);
          const auto begin = fpColumns.size();
          for (Index k = F.rowBegin(p); k < F.rowEnd(p); ++k) {
            const Index q = F.column(k);
            for (Index b = P.rowStart[q]; b < P.rowStart[q + 1]; ++b)
              if (mark[P.columns[b]] != -2) {
                mark[P.columns[b]] = -2;
                fpColumns.push_back(P.columns[b]);
              }
          }
          for (auto s = begin; s < fpColumns.size(); ++s) mark[fpColumns[s]] = -1;
          start.push_back(static_cast<Index>(fpColumns.size()));
        }
      std::vector<Index>& columns = chunkColumns[static_cast<std::size_t>(chunk)];
      for (Index I = first; I < last; ++I) {
        row.clear();
        for (Index a = Pt.rowStart[I]; a < Pt.rowStart[I + 1]; ++a) {
          const Index f = fineRow[Pt.columns[a]];
          for (Index s = start[f]; s < start[f + 1]; ++s)
            if (mark[fpColumns[s]] != I) {
              mark[fpColumns[s]] = I;
              row.push_back(fpColumns[s]);
            }
        }
        if (mark[I] != I) row.push_back(I);  // always a diagonal
        std::sort(row.begin(), row.end());
        columns.insert(columns.end(), row.begin(), row.end());
        rowStart[I + 1] = static_cast<Index>(row.size());
      }
      for (Index J : columns) mark[J] = -1;  // the marks of this chunk's rows
      for (Index p : formed) fineRow[p] = -1;
    }
  }
  for (Index I = 0; I < nc; ++I) rowStart[I + 1] += rowStart[I];
  // the chunks' columns joined on the threads (each writes, and first touches, its part)
  typename BlockSparseMatrix<d>::IndexArray columns(static_cast<std::size_t>(rowStart[nc]));
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
#endif
  for (Index chunk = 0; chunk < chunks; ++chunk) {
    std::vector<Index>& c = chunkColumns[static_cast<std::size_t>(chunk)];
    std::copy(c.begin(), c.end(), columns.begin() + rowStart[chunk * kChunk]);
    std::vector<Index>().swap(c);
  }
  // zero blocks, stored once (shared), not one per entry: the Galerkin products fill them
  return BlockSparseMatrix<d>::fromRowRanges({std::move(rowStart), std::move(columns)},
                                            [](Index, Index, Eigen::Matrix<double, d, d>*) {});
}

/// Recomputes the rows `rows` (sorted) of C = P' B P with B_pq = E_p F_pq E_q' (E_p = I where
/// slot[p] < 0; no transforms if slot is null), into the precomputed pattern of C. With addSlot,
/// F_pp + K_p replaces F_pp where addSlot[p] >= 0 (K_p = addBlocks[addSlot[p]]).
///
/// The rows are taken in chunks of kGalerkinChunk. For each chunk the rows of B P needed by its
/// coarse rows are formed once, (B P)_pJ = sum_q B_pq P_qJ (the blocks of fine row p in their
/// order, each to its coarse parents), and then C(I, J) = sum_p P_pI (B P)_pJ over the fine support
/// of I in ascending p. A fine row shared by rows of two chunks is formed twice; the work per coarse
/// row is that of its fine rows (about 91 block updates each for trilinear hexahedra) plus the sum
/// (about 27 x 16), instead of every fine row times its parents (about 27 x 27 x 3.4).
///
/// Every entry is the same sum in the same order whatever the chunk, the thread that takes it and
/// whether all rows or some are recomputed: the operators do not depend on the thread count, and a
/// local update gives the bits of a full product.
template <int d>
void galerkinRows(const BlockSparseMatrix<d>& F, const mesh::CsrMatrix& P, const mesh::CsrMatrix& Pt,
                  const std::vector<Index>* slot, const std::vector<Eigen::Matrix<double, d, d>>* E,
                  std::span<const Index> rows, BlockSparseMatrix<d>& C,
                  Eigen::Matrix<double, d, d>* target = nullptr, Index targetBase = 0,
                  const std::vector<Index>* addSlot = nullptr,
                  const std::vector<Eigen::Matrix<double, d, d>>* addBlocks = nullptr) {
  using Mat = Eigen::Matrix<double, d, d>;
  constexpr Index kGalerkinChunk = 256;
  const auto n = static_cast<Index>(rows.size());
  const Index chunks = (n + kGalerkinChunk - 1) / kGalerkinChunk;
  // with a target (a range of BlockSparseMatrix::fillByRowRanges, already on a thread of its own)
  // the rows go to target[k - targetBase] on this thread, and C gives only its pattern
  const int nt = target || n < kParallelMinRows ? 1 : threads();
  // A shared C (a local update) keeps its storage: the rows of a chunk are computed apart and
  // written by one thread at a time through a BlockWriter. A plain C is written in place.
  const bool shared = !target && C.shared();
  std::optional<typename BlockSparseMatrix<d>::BlockWriter> writer;
  if (shared) writer.emplace(C);
  Mat* plain = target ? target : shared ? nullptr : &C.blockAt(0);
  const Index plainBase = target ? targetBase : 0;
#ifdef _OPENMP
#pragma omp parallel num_threads(nt)
#endif
  {
    // fineRow[p]: index of fine row p's (B P) row in this chunk, or -1; mark: coarse column -> slot
    std::vector<Index> fineRow(static_cast<std::size_t>(F.rows()), -1), mark(static_cast<std::size_t>(C.rows()), -1);
    std::vector<Index> formed, start, columns;  // the chunk's (B P) rows: fine row, row starts, columns
    std::vector<Mat> values, rowsOut;           // rowsOut: the chunk's coarse rows (shared C)
    std::vector<Index> positions;
#ifdef _OPENMP
#pragma omp for schedule(dynamic, 1)
#endif
    for (Index chunk = 0; chunk < chunks; ++chunk) {
      const Index first = chunk * kGalerkinChunk, last = std::min(n, first + kGalerkinChunk);
      formed.clear();
      start.assign(1, 0);
      columns.clear();
      values.clear();
      for (Index i = first; i < last; ++i)
        for (Index a = Pt.rowStart[rows[i]]; a < Pt.rowStart[rows[i] + 1]; ++a) {
          const Index p = Pt.columns[a];
          const Index sp = slot ? (*slot)[p] : -1;
          if (fineRow[p] >= 0 || (sp >= 0 && (*E)[sp].isZero(0))) continue;  // formed, or all truncated
          fineRow[p] = static_cast<Index>(formed.size());
          formed.push_back(p);
          const auto begin = static_cast<Index>(columns.size());
          for (Index k = F.rowBegin(p); k < F.rowEnd(p); ++k) {
            const Index q = F.column(k);
            const Index sq = slot ? (*slot)[q] : -1;
            Mat B = F.blockAt(k);
            if (q == p && addSlot && (*addSlot)[p] >= 0) B += (*addBlocks)[(*addSlot)[p]];  // F + K
            if (sp >= 0) B = (*E)[sp] * B;
            if (sq >= 0) B = B * (*E)[sq].transpose();
            for (Index b = P.rowStart[q]; b < P.rowStart[q + 1]; ++b) {
              const Index J = P.columns[b];
              if (mark[J] < 0) {
                mark[J] = static_cast<Index>(columns.size());
                columns.push_back(J);
                values.push_back(P.values[b] * B);
              } else {
                values[mark[J]] += P.values[b] * B;
              }
            }
          }
          for (auto s = begin; s < static_cast<Index>(columns.size()); ++s) mark[columns[s]] = -1;
          start.push_back(static_cast<Index>(columns.size()));
        }
      // the coarse rows: into C's blocks (plain), or into rowsOut at the same offsets (shared)
      if (shared) {
        positions.clear();
        for (Index i = first; i < last; ++i)
          for (Index k = C.rowBegin(rows[i]); k < C.rowEnd(rows[i]); ++k) positions.push_back(k);
        rowsOut.resize(positions.size());
      }
      Index offset = 0;
      for (Index i = first; i < last; ++i) {
        const Index I = rows[i];
        // out[j]: the block at position rowBegin(I) + j of C
        Mat* out = shared ? rowsOut.data() + offset : plain + (C.rowBegin(I) - plainBase);
        for (Index k = C.rowBegin(I); k < C.rowEnd(I); ++k) {
          mark[C.column(k)] = k - C.rowBegin(I);
          out[k - C.rowBegin(I)].setZero();
        }
        for (Index a = Pt.rowStart[I]; a < Pt.rowStart[I + 1]; ++a) {
          const Index f = fineRow[Pt.columns[a]];
          if (f < 0) continue;  // all components of the fine vertex truncated
          const double w = Pt.values[a];
          for (Index s = start[f]; s < start[f + 1]; ++s) out[mark[columns[s]]] += w * values[s];
        }
        for (Index k = C.rowBegin(I); k < C.rowEnd(I); ++k) mark[C.column(k)] = -1;
        offset += C.rowEnd(I) - C.rowBegin(I);
      }
      if (shared) {
#ifdef _OPENMP
#pragma omp critical(obs_galerkin_writer)
#endif
        for (std::size_t u = 0; u < positions.size(); ++u) writer->set(positions[u], rowsOut[u]);
      }
      for (Index p : formed) fineRow[p] = -1;
    }
  }
}

/// Components of a coarse level without untruncated fine support (docs/theory.md#multigrid-dead-components):
/// their row and column of the Galerkin product vanish. `dead` holds one bit per component (as the
/// fine truncation bits). The rows `rows` were recomputed: their bits are determined anew, the bits
/// of the other rows stand. Every dead diagonal entry of the level is then set to the largest live
/// one (`scale`), so that the diagonal blocks stay invertible for the smoothers and the coarse
/// solver; the patch is not stiffness: the next coarser product and the transfers treat dead
/// components as truncated. `rows` must be sorted. Returns the vertices whose bits changed
/// (`flipped`) and those outside `rows` whose patched entry changed (`repatched`, the largest live
/// diagonal entry having moved).
struct DeadUpdate {
  std::vector<Index> flipped, repatched;
};

template <int d>
DeadUpdate markDeadComponents(BlockSparseMatrix<d>& C, std::span<const Index> rows, std::vector<std::uint8_t>& dead) {
  std::vector<std::uint8_t> before(rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    before[i] = dead[rows[i]];
    dead[rows[i]] = 0;
  }
  const BlockSparseMatrix<d>& read = C;  // reads keep shared blocks shared
  double scale = 0;
  for (Index I = 0; I < C.rows(); ++I) {
    const auto& D = read.blockAt(C.diagonal(I));
    for (int c = 0; c < d; ++c)
      if (!(dead[I] & (1u << c))) scale = std::max(scale, D(c, c));
  }
  const double patch = scale > 0 ? scale : 1.0;
  DeadUpdate out;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const Index I = rows[i];
    const auto& D = read.blockAt(C.diagonal(I));
    std::uint8_t b = 0;
    for (int c = 0; c < d; ++c)
      if (D(c, c) <= 1e-12 * scale) b |= static_cast<std::uint8_t>(1u << c);
    dead[I] = b;
    if (b != before[i]) out.flipped.push_back(I);
  }
  std::optional<typename BlockSparseMatrix<d>::BlockWriter> writer;  // made on the first patch written
  for (Index I = 0; I < C.rows(); ++I)
    if (dead[I]) {
      const Index k = C.diagonal(I);
      Eigen::Matrix<double, d, d> D = read.blockAt(k);
      bool moved = false;
      for (int c = 0; c < d; ++c)
        if ((dead[I] & (1u << c)) && D(c, c) != patch) {
          D(c, c) = patch;
          moved = true;
        }
      if (moved) {
        if (!writer) writer.emplace(C);
        writer->set(k, D);
      }
      if (moved && !std::binary_search(rows.begin(), rows.end(), I)) out.repatched.push_back(I);
    }
  return out;
}

/// The transforms E_p = T_p of a coarse level's dead components, in the slot form of the fine level.
template <int d>
void deadTransforms(const std::vector<std::uint8_t>& dead, std::vector<Index>& slot,
                    std::vector<Eigen::Matrix<double, d, d>>& E) {
  slot.assign(dead.size(), -1);
  E.clear();
  for (std::size_t p = 0; p < dead.size(); ++p)
    if (dead[p]) {
      Eigen::Matrix<double, d, d> T = Eigen::Matrix<double, d, d>::Identity();
      for (int c = 0; c < d; ++c)
        if (dead[p] & (1u << c)) T.col(c).setZero();
      slot[p] = static_cast<Index>(E.size());
      E.push_back(T);
    }
}

}  // namespace

template <int d>
std::vector<VertexRotation<d>> problemRotations(const ContactProblem<d>& problem) {
  std::vector<VertexRotation<d>> out;
  for (const auto& c : problem.constraints())
    if (!c.rotation.isIdentity(0)) out.push_back({c.vertex, c.rotation});
  return out;
}

namespace {

/// Block-diagonal concatenation of scalar CSR matrices.
mesh::CsrMatrix blockDiagonal(const std::vector<mesh::CsrMatrix>& parts) {
  mesh::CsrMatrix out;
  out.rows = out.cols = 0;
  out.rowStart = {0};
  for (const auto& P : parts) {
    for (Index r = 0; r < P.rows; ++r) {
      for (Index k = P.rowStart[r]; k < P.rowStart[r + 1]; ++k) {
        out.columns.push_back(out.cols + P.columns[k]);
        out.values.push_back(P.values[k]);
      }
      out.rowStart.push_back(static_cast<Index>(out.columns.size()));
    }
    out.rows += P.rows;
    out.cols += P.cols;
  }
  return out;
}

/// The first `rows` rows of (I - C) P (the fine basis transformation in the last prolongation),
/// row by row with a sparse accumulator, columns ascending; the rows of P at C's columns must be
/// there. The result has P's sizes and `rows` rows stored.
mesh::CsrMatrix minusBasisTimes(const mesh::CsrMatrix& P, const mesh::CsrMatrix& C, Index rows) {
  mesh::CsrMatrix Q;
  Q.rows = P.rows;
  Q.cols = P.cols;
  std::vector<Index> position(static_cast<std::size_t>(P.cols), -1), cols;
  std::vector<double> vals;
  for (Index p = 0; p < rows; ++p) {
    cols.clear();
    vals.clear();
    const auto add = [&](Index J, double v) {
      if (position[J] < 0) {
        position[J] = static_cast<Index>(cols.size());
        cols.push_back(J);
        vals.push_back(v);
      } else {
        vals[position[J]] += v;
      }
    };
    for (Index k = P.rowStart[p]; k < P.rowStart[p + 1]; ++k) add(P.columns[k], P.values[k]);
    for (Index m = C.rowStart[p]; m < C.rowStart[p + 1]; ++m) {
      const Index q = C.columns[m];
      for (Index k = P.rowStart[q]; k < P.rowStart[q + 1]; ++k) add(P.columns[k], -C.values[m] * P.values[k]);
    }
    std::vector<Index> order(cols.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<Index>(i);
    std::sort(order.begin(), order.end(), [&](Index a, Index b) { return cols[a] < cols[b]; });
    for (Index i : order) {
      Q.columns.push_back(cols[i]);
      Q.values.push_back(vals[i]);
    }
    Q.rowStart.push_back(static_cast<Index>(Q.columns.size()));
    for (Index J : cols) position[J] = -1;
  }
  return Q;
}

mesh::CsrMatrix identity(Index n) {
  mesh::CsrMatrix I;
  I.rows = I.cols = n;
  I.rowStart.resize(n + 1);
  I.columns.resize(n);
  I.values.assign(n, 1.0);
  for (Index i = 0; i <= n; ++i) I.rowStart[i] = i;
  for (Index i = 0; i < n; ++i) I.columns[i] = i;
  return I;
}

/// Zeroes the components of v marked in `bits` (a coarse level's dead components).
template <int d>
void truncateDead(std::uint8_t bits, Eigen::Matrix<double, d, 1>& v) {
  if (bits)
    for (int c = 0; c < d; ++c)
      if (bits & (1u << c)) v[c] = 0;
}

}  // namespace

template <int d>
MultigridHierarchy<d>::MultigridHierarchy(const mesh::Grid& grid)
    : MultigridHierarchy(std::vector<const mesh::Grid*>{&grid}) {}

template <int d>
MultigridHierarchy<d>::MultigridHierarchy(const std::vector<const mesh::Grid*>& grids) {
  buildSerial(grids);
}

template <int d>
void MultigridHierarchy<d>::buildSerial(const std::vector<const mesh::Grid*>& grids) {
  if (grids.empty()) throw Error("multigrid hierarchy: no grid");
  int L = 0;
  for (const mesh::Grid* g : grids) {
    if (!g) throw Error("multigrid hierarchy: null grid");
    if (g->dimension() != d)
      throw Error("multigrid hierarchy: the grid has dimension " + std::to_string(g->dimension()) + ", the solver " +
                  std::to_string(d));
    L = std::max(L, g->maxLevel());
  }
  // per grid: the view of stacked level l is its level l - (L - L_g), or its coarsest view
  struct State {
    const mesh::Grid* grid;
    int levels;
    mesh::GridView view;
  };
  std::vector<State> state;
  for (const mesh::Grid* g : grids) {
    const int Lg = g->maxLevel();
    state.push_back({g, Lg, Lg > 0 ? g->levelView(0) : g->leafView()});
  }
  Index n0 = 0;
  for (const auto& st : state) n0 += static_cast<Index>(st.view.vertices.size());
  vertices_.push_back(n0);
  for (int l = 0; l < L; ++l) {
    std::vector<mesh::CsrMatrix> parts;
    Index n = 0;
    for (auto& st : state) {
      const int lg = l + 1 - (L - st.levels);  // grid level of stacked level l + 1
      if (lg <= 0) {
        parts.push_back(identity(static_cast<Index>(st.view.vertices.size())));
      } else {
        mesh::GridView fine = lg == st.levels ? st.grid->leafView() : st.grid->levelView(lg);
        parts.push_back(mesh::transferMatrix(*st.grid, st.view, fine));
        st.view = std::move(fine);
      }
      n += parts.back().rows;
    }
    prolongations_.push_back(parts.size() == 1 ? std::move(parts.front()) : blockDiagonal(parts));
    transposed_.push_back(transpose(prolongations_.back()));
    vertices_.push_back(n);
  }
  newBasis_.assign(static_cast<std::size_t>(L) + 1, {});
  for (int l = 1; l < L; ++l) {
    const mesh::CsrMatrix& P = prolongations_[l - 1];
    const mesh::CsrMatrix& Pt = transposed_[l - 1];
    auto& mark = newBasis_[l];
    mark.assign(static_cast<std::size_t>(P.rows), 1);
    for (Index p = 0; p < P.rows; ++p) {
      const Index k = P.rowStart[p];
      if (P.rowStart[p + 1] - k != 1 || P.values[k] != 1.0) continue;
      const Index c = P.columns[k];
      if (Pt.rowStart[c + 1] - Pt.rowStart[c] == 1) mark[p] = 0;
    }
  }
}

template <int d>
Index MultigridHierarchy<d>::Level::local(Index g) const {
  if (owned > 0 && g >= global[0] && g < global[0] + owned) return g - global[0];
  const auto it = ghostLocal.find(g);
  return it == ghostLocal.end() ? -1 : it->second;
}

template <int d>
int MultigridHierarchy<d>::Level::ownerOf(Index g) const {
  return static_cast<int>(std::upper_bound(offsets.begin(), offsets.end(), g) - offsets.begin()) - 1;
}

template <int d>
MultigridHierarchy<d>::MultigridHierarchy(const DistributedGrid& dg)
    : MultigridHierarchy(std::vector<const DistributedGrid*>{&dg}) {}

template <int d>
MultigridHierarchy<d>::MultigridHierarchy(const std::vector<const DistributedGrid*>& grids,
                                          const std::vector<Index>& fineExtras) {
  if (grids.empty() || !grids.front()) throw Error("multigrid hierarchy: no distributed grid");
  if (grids.front()->communicator().size() == 1) {
    // a communicator of one: the serial hierarchy of the grids (docs/architecture.md#one-path);
    // one rank owns every vertex, so any extra ghost is one it owns
    if (!fineExtras.empty())
      throw Error("multigrid hierarchy: an extra ghost " + std::to_string(fineExtras.front()) +
                  " out of range or owned here");
    std::vector<const mesh::Grid*> serial;
    for (const DistributedGrid* dg : grids) {
      if (!dg) throw Error("multigrid hierarchy: a distributed grid is null");
      if (dg->communicator().size() != 1)
        throw Error("multigrid hierarchy: the distributed grids are on different numbers of ranks");
      serial.push_back(&dg->grid());
    }
    buildSerial(serial);
    return;
  }
  comm_.emplace(grids.front()->communicator());
  const Communicator& comm = *comm_;
  const int me = comm.rank(), ranks = comm.size();
  const auto nb = static_cast<int>(grids.size());
  int L = 0;
  for (const DistributedGrid* dg : grids) {  // the same data on every rank: every rank throws
    if (!dg) throw Error("multigrid hierarchy: a distributed grid is null");
    if (dg->grid().dimension() != d)
      throw Error("multigrid hierarchy: the grid has dimension " + std::to_string(dg->grid().dimension()) +
                  ", the solver " + std::to_string(d));
    if (dg->communicator().size() != ranks)
      throw Error("multigrid hierarchy: the distributed grids are on different numbers of ranks");
    if (dg->partition().level < 1 && dg->maxLevel() < 1)
      throw Error("multigrid hierarchy: a distributed grid partitioned on level 0 needs at least one refinement (the "
                  "fine level is not the coarse problem)");
    L = std::max(L, dg->maxLevel());
  }
  // A body's part of a stacked level: its view (grid level l - (L - L_b), or its coarsest), held
  // vertices in local order (owned first) with their global indices and owners in the body's
  // numbering, and the first global index of each rank. A replicated view inside a distributed
  // stacked level is held whole by every rank and owned in consecutive slices (rank r owns
  // n r / R .. n (r + 1) / R - 1), so that every vertex of the level has one owner.
  struct Part {
    int gridLevel = 0;
    bool distributed = false;
    mesh::GridView view;
    Index owned = 0;
    std::vector<Index> held, global;
    std::vector<int> owner;
    std::vector<Index> offsets;
    std::optional<HaloExchange> halo;
    std::vector<Index> localOf;  ///< view vertex -> stacked local index (-1: not held)
  };
  const bool anyExtras = comm.max(fineExtras.empty() ? 0.0 : 1.0) > 0;
  std::vector<std::vector<Part>> parts(static_cast<std::size_t>(L) + 1, std::vector<Part>(static_cast<std::size_t>(nb)));
  levels_.resize(static_cast<std::size_t>(L) + 1);
  for (int l = 0; l <= L; ++l) {
    bool anyDistributed = false;
    for (int b = 0; b < nb; ++b) {
      const DistributedGrid& dg = *grids[b];
      const int Lb = dg.maxLevel();
      Part& pt = parts[l][b];
      pt.gridLevel = std::max(0, l - (L - Lb));
      pt.distributed = pt.gridLevel >= dg.partition().level;
      anyDistributed = anyDistributed || pt.distributed;
    }
    Level& lv = levels_[l];
    Index viewBase = 0;
    for (int b = 0; b < nb; ++b) {
      const mesh::Grid& grid = grids[b]->grid();
      Part& pt = parts[l][b];
      const int lb = pt.gridLevel;
      if (pt.distributed) {
        DistributedView dv = grids[b]->view(lb == grids[b]->maxLevel() ? -1 : lb);
        pt.view = std::move(dv.view);
        pt.owned = dv.halo.numOwned();
        pt.held = dv.halo.viewVertices();
        for (Index v : pt.held) {
          pt.global.push_back(dv.numbering.global[v]);
          pt.owner.push_back(dv.numbering.owner[v]);
        }
        pt.offsets = dv.numbering.offsets;
        pt.halo.emplace(std::move(dv.halo));
      } else {
        pt.view = lb == grid.maxLevel() ? grid.leafView() : grid.levelView(lb);
        const auto n = static_cast<Index>(pt.view.vertices.size());
        if (anyDistributed) {  // owned in slices
          for (int r = 0; r <= ranks; ++r) pt.offsets.push_back(static_cast<Index>(static_cast<long long>(n) * r / ranks));
          pt.owned = pt.offsets[me + 1] - pt.offsets[me];
          for (Index v = pt.offsets[me]; v < pt.offsets[me + 1]; ++v) pt.held.push_back(v);
          for (Index v = 0; v < n; ++v)
            if (v < pt.offsets[me] || v >= pt.offsets[me + 1]) pt.held.push_back(v);
          for (Index v : pt.held) {
            pt.global.push_back(v);
            pt.owner.push_back(static_cast<int>(std::upper_bound(pt.offsets.begin(), pt.offsets.end(), v) -
                                                pt.offsets.begin()) - 1);
          }
        } else {
          pt.owned = n;
          for (Index v = 0; v < n; ++v) pt.held.push_back(v);
        }
      }
      pt.localOf.assign(pt.view.vertices.size(), -1);
    }
    if (!anyDistributed) {  // replicated: the bodies' views one after the other
      for (int b = 0; b < nb; ++b) {
        Part& pt = parts[l][b];
        for (Index v : pt.held) {
          pt.localOf[v] = static_cast<Index>(lv.viewVertex.size());
          lv.viewVertex.push_back(viewBase + v);
        }
        viewBase += static_cast<Index>(pt.view.vertices.size());
      }
      lv.owned = static_cast<Index>(lv.viewVertex.size());
      lv.base = lv.rows = lv.owned;
      vertices_.push_back(lv.owned);
      continue;
    }
    // the stacked numbering: rank r's owned vertices of body 0, 1, ... from its offset
    std::vector<std::vector<Index>> count(static_cast<std::size_t>(nb));
    lv.offsets.assign(static_cast<std::size_t>(ranks) + 1, 0);
    for (int b = 0; b < nb; ++b)
      for (int r = 0; r < ranks; ++r) count[b].push_back(parts[l][b].offsets[r + 1] - parts[l][b].offsets[r]);
    for (int r = 0; r < ranks; ++r) {
      lv.offsets[r + 1] = lv.offsets[r];
      for (int b = 0; b < nb; ++b) lv.offsets[r + 1] += count[b][r];
    }
    const auto stacked = [&](int b, Index g, int o) {
      Index s = lv.offsets[o] + g - parts[l][b].offsets[o];
      for (int c = 0; c < b; ++c) s += count[c][o];
      return s;
    };
    std::vector<Index> viewBases;
    for (int b = 0; b < nb; ++b) {
      viewBases.push_back(viewBase);
      viewBase += static_cast<Index>(parts[l][b].view.vertices.size());
    }
    for (int pass = 0; pass < 2; ++pass)  // owned vertices of every body, then ghosts
      for (int b = 0; b < nb; ++b) {
        Part& pt = parts[l][b];
        const auto first = pass == 0 ? Index{0} : pt.owned, last = pass == 0 ? pt.owned : static_cast<Index>(pt.held.size());
        for (Index i = first; i < last; ++i) {
          pt.localOf[pt.held[i]] = static_cast<Index>(lv.global.size());
          lv.global.push_back(stacked(b, pt.global[i], pt.owner[i]));
          lv.owner.push_back(pt.owner[i]);
          lv.viewVertex.push_back(viewBases[b] + pt.held[i]);
        }
        if (pass == 0) lv.owned += pt.owned;
      }
    comm.collective([&] {  // (a bad extra ghost list on one rank stops every rank)
      if (l == L)
        for (Index g : fineExtras) {  // the fine level's extra ghosts (DistributedMultiBody)
          const int o = g < 0 || g >= lv.offsets.back() ? -1 : lv.ownerOf(g);
          if (o < 0 || o == me)
            throw Error("multigrid hierarchy: an extra ghost " + std::to_string(g) + " out of range or owned here");
          lv.global.push_back(g);
          lv.owner.push_back(o);
          lv.viewVertex.push_back(-1);
        }
      for (Index i = lv.owned; i < static_cast<Index>(lv.global.size()); ++i)
        if (!lv.ghostLocal.emplace(lv.global[i], i).second)
          throw Error("multigrid hierarchy: vertex " + std::to_string(lv.global[i]) + " held twice");
    });
    if (nb == 1 && !anyExtras) {  // one body: its view's halo
      lv.halo = std::make_shared<const HaloExchange>(std::move(*parts[l][0].halo));
    } else {
      std::vector<Index> ghostGlobal(lv.global.begin() + lv.owned, lv.global.end());
      std::vector<int> ghostOwner(lv.owner.begin() + lv.owned, lv.owner.end());
      lv.halo = std::make_shared<const HaloExchange>(lv.owned, lv.offsets[me], ghostGlobal, ghostOwner, comm);
    }
    lv.base = static_cast<Index>(lv.global.size());
    lv.rows = static_cast<Index>(lv.global.size()) - (l == L ? static_cast<Index>(fineExtras.size()) : 0);
    vertices_.push_back(lv.base);
  }
  // prolongations in the levels' numberings: the rows of the held fine vertices of the bodies
  // (their coarse parents are held: a fine cell next to an owned one lies in a coarse cell next to
  // an owned one); the rows of extra ghosts come from their owners (widen())
  newBasis_.assign(static_cast<std::size_t>(L) + 1, {});
  comm.collective([&] {  // local work: a failure on one rank reaches all
    for (int l = 0; l < L; ++l) {
      mesh::CsrMatrix P;
      P.rows = levels_[l + 1].rows;  // the fine level's extra ghosts: rows from their owners
      P.cols = vertices_[l];
      std::vector<std::vector<std::pair<Index, double>>> rows(static_cast<std::size_t>(P.rows));
      for (int b = 0; b < nb; ++b) {
        const Part& coarse = parts[l][b];
        const Part& fine = parts[l + 1][b];
        const bool same = fine.gridLevel == coarse.gridLevel;  // a body below its coarsest level
        const mesh::CsrMatrix T =
            same ? mesh::CsrMatrix() : mesh::transferMatrix(grids[b]->grid(), coarse.view, fine.view);
        for (Index v : fine.held) {
          auto& row = rows[static_cast<std::size_t>(fine.localOf[v])];
          const auto add = [&](Index cv, double w) {
            const Index c = coarse.localOf[cv];
            if (c < 0)
              throw Error("multigrid hierarchy: a coarse parent of a held vertex of level " + std::to_string(l + 1) +
                          " is not held");
            row.emplace_back(c, w);
          };
          if (same) add(v, 1.0);
          else
            for (Index k = T.rowStart[v]; k < T.rowStart[v + 1]; ++k) add(T.columns[k], T.values[k]);
        }
      }
      for (const auto& row : rows) {
        for (const auto& [c, w] : row) {
          P.columns.push_back(c);
          P.values.push_back(w);
        }
        P.rowStart.push_back(static_cast<Index>(P.columns.size()));
      }
      const mesh::CsrMatrix full = transpose(P);
      if (l > 0) {  // new basis functions (MultigridHierarchy::newBasis), from the held rows
        const mesh::CsrMatrix& Pc = prolongations_[l - 1];
        const mesh::CsrMatrix Ptc = transpose(Pc);
        auto& mark = newBasis_[l];
        mark.assign(static_cast<std::size_t>(Pc.rows), 1);
        for (Index p = 0; p < Pc.rows; ++p) {
          const Index k = Pc.rowStart[p];
          if (Pc.rowStart[p + 1] - k != 1 || Pc.values[k] != 1.0) continue;
          if (Ptc.rowStart[Pc.columns[k] + 1] - Ptc.rowStart[Pc.columns[k]] == 1) mark[p] = 0;
        }
      }
      transposed_.push_back(distributedLevel(l + 1) ? transposeRows(P, levels_[l + 1].owned) : full);
      prolongations_.push_back(std::move(P));
    }
  });
  baseLevels_ = levels_;
  baseProlongations_ = prolongations_;
  widening_ = anyExtras;
}

template <int d>
const std::vector<Index>& MultigridHierarchy<d>::viewVertices(int l) const {
  static const std::vector<Index> none;
  return distributed() ? levels_[l].viewVertex : none;
}

template <int d>
const std::vector<Index>& MultigridHierarchy<d>::globalVertices(int l) const {
  static const std::vector<Index> none;
  return distributedLevel(l) ? levels_[l].global : none;
}

template <int d>
Index MultigridHierarchy<d>::addExtra(int l, Index g) {
  Level& lv = levels_[l];
  const auto i = static_cast<Index>(lv.global.size());
  lv.global.push_back(g);
  lv.owner.push_back(lv.ownerOf(g));
  lv.viewVertex.push_back(-1);
  lv.ghostLocal.emplace(g, i);
  vertices_[l] = i + 1;
  return i;
}

template <int d>
void MultigridHierarchy<d>::restoreBase() {
  levels_ = baseLevels_;
  prolongations_ = baseProlongations_;
  for (int l = 0; l <= maxLevel(); ++l) vertices_[l] = levels_[l].base;
}

template <int d>
void MultigridHierarchy<d>::fetchRows(int l, Index first) {
  // the rows of P_l of the held vertices first, first + 1, ... of level l + 1 from their owners,
  // in global coarse indices; the coarse columns not held become extra ghosts of level l
  const Communicator& comm = *comm_;
  const Level& fine = levels_[l + 1];
  mesh::CsrMatrix& P = prolongations_[l];
  const auto ranks = static_cast<std::size_t>(comm.size());
  std::vector<std::vector<double>> ask(ranks), reply(ranks);
  std::vector<std::vector<Index>> askedLocal(ranks);
  for (Index p = first; p < vertices_[l + 1]; ++p) {
    ask[fine.owner[p]].push_back(static_cast<double>(fine.global[p]));
    askedLocal[fine.owner[p]].push_back(p);
  }
  const auto asked = comm.exchange(ask);
  bool owned = true;
  for (std::size_t r = 0; r < ranks; ++r)
    for (double g : asked[r]) {
      const Index p = fine.local(static_cast<Index>(g));
      owned = owned && p >= 0 && p < fine.owned && p < P.rows;
      if (!owned) break;
      reply[r].push_back(static_cast<double>(P.rowStart[p + 1] - P.rowStart[p]));
      for (Index k = P.rowStart[p]; k < P.rowStart[p + 1]; ++k) {
        reply[r].push_back(static_cast<double>(globalOf(l, P.columns[k])));
        reply[r].push_back(P.values[k]);
      }
    }
  comm.collective([&] {
    if (!owned) throw Error("multigrid hierarchy: a prolongation row of level " + std::to_string(l + 1) + " asked of a rank that does not own it");
  });
  const auto got = comm.exchange(reply);
  std::vector<std::vector<std::pair<Index, double>>> rows(static_cast<std::size_t>(vertices_[l + 1] - first));
  for (std::size_t r = 0; r < ranks; ++r) {
    std::size_t k = 0;
    for (Index p : askedLocal[r]) {
      const auto n = static_cast<std::size_t>(got[r][k++]);
      auto& row = rows[static_cast<std::size_t>(p - first)];
      for (std::size_t e = 0; e < n; ++e, k += 2) {
        const auto g = static_cast<Index>(got[r][k]);
        Index c = localOf(l, g);
        if (c < 0) c = addExtra(l, g);  // (a replicated level holds every vertex)
        row.emplace_back(c, got[r][k + 1]);
      }
    }
  }
  P.rowStart.resize(static_cast<std::size_t>(first) + 1);
  P.columns.resize(static_cast<std::size_t>(P.rowStart.back()));
  P.values.resize(P.columns.size());
  for (const auto& row : rows) {
    for (const auto& [c, w] : row) {
      P.columns.push_back(c);
      P.values.push_back(w);
    }
    P.rowStart.push_back(static_cast<Index>(P.columns.size()));
  }
  P.rows = vertices_[l + 1];
  P.cols = vertices_[l];
}

template <int d>
void MultigridHierarchy<d>::widen(int l) {
  if (!distributedLevel(l + 1)) return;  // a replicated fine level: every row is held
  const int L = maxLevel();
  fetchRows(l, levels_[l + 1].rows);  // the extra ghosts of level l + 1
  if (l == L - 1 && basis_.rows > 0) {
    // (I - C) P on the owned rows (the rows of every column of C are held now), then the rows of
    // the ghosts from their owners
    const Index owned = levels_[L].owned;
    prolongations_[l] = minusBasisTimes(prolongations_[l], basis_, owned);
    fetchRows(l, owned);
  }
  transposed_[l] = transposeRows(prolongations_[l], levels_[l + 1].owned);
}

template <int d>
void MultigridHierarchy<d>::finishLevel(int l) {
  prolongations_[l].cols = vertices_[l];
  if (distributedLevel(l + 1)) transposed_[l] = transposeRows(prolongations_[l], levels_[l + 1].owned);
  if (!distributedLevel(l)) return;
  Level& lv = levels_[l];
  const bool grown = comm_->max(vertices_[l] > lv.base ? 1.0 : 0.0) > 0;
  if (!grown) return;
  const Communicator& comm = *comm_;
  const std::vector<Index> ghostGlobal(lv.global.begin() + lv.owned, lv.global.end());
  const std::vector<int> ghostOwner(lv.owner.begin() + lv.owned, lv.owner.end());
  lv.halo = std::make_shared<const HaloExchange>(lv.owned, lv.offsets[comm.rank()], ghostGlobal, ghostOwner, comm);
}

template <int d>
void MultigridHierarchy<d>::joinPattern(int l) {
  const Communicator& comm = *comm_;
  BlockSparseMatrix<d>& C = coarse_[l];
  const int ranks = comm.size();
  std::vector<std::vector<double>> send(static_cast<std::size_t>(ranks));
  std::vector<std::vector<Index>> extra(static_cast<std::size_t>(C.rows()));
  if (distributedLevel(l)) {  // ghost rows' columns to their owners, in global indices
    const Level& lv = levels_[l];
    for (Index I = lv.owned; I < C.rows(); ++I) {
      std::vector<double>& out = send[lv.owner[I]];
      out.push_back(static_cast<double>(lv.global[I]));
      out.push_back(static_cast<double>(C.rowEnd(I) - C.rowBegin(I)));
      for (Index k = C.rowBegin(I); k < C.rowEnd(I); ++k) out.push_back(static_cast<double>(lv.global[C.column(k)]));
    }
    const std::vector<std::vector<double>> got = comm.exchange(send);
    bool held = true;
    for (const auto& in : got)
      for (std::size_t a = 0; a < in.size();) {
        const Index I = levels_[l].local(static_cast<Index>(in[a]));
        const auto n = static_cast<std::size_t>(in[a + 1]);
        for (std::size_t k = 0; k < n; ++k) {
          const auto g = static_cast<Index>(in[a + 2 + k]);
          Index J = levels_[l].local(g);
          if (J < 0 && widening_) {  // a coupling beyond the owner's ghosts: an extra ghost
            J = addExtra(l, g);
            extra.resize(static_cast<std::size_t>(vertices_[l]));
          }
          held = held && I >= 0 && I < lv.owned && J >= 0;
          if (held) extra[I].push_back(J);
        }
        a += 2 + n;
      }
    comm.collective([&] {
      if (!held)
        throw Error("multigrid hierarchy: a coarse entry of level " + std::to_string(l) +
                    " is not held by its row's owner");
    });
  } else {  // a replicated level: every rank's pattern to every rank
    std::vector<double> mine;
    for (Index I = 0; I < C.rows(); ++I) {
      mine.push_back(static_cast<double>(C.rowEnd(I) - C.rowBegin(I)));
      for (Index k = C.rowBegin(I); k < C.rowEnd(I); ++k) mine.push_back(static_cast<double>(C.column(k)));
    }
    std::fill(send.begin(), send.end(), mine);
    const std::vector<std::vector<double>> got = comm.exchange(send);
    for (const auto& in : got) {
      std::size_t a = 0;
      for (Index I = 0; I < C.rows(); ++I) {
        const auto n = static_cast<std::size_t>(in[a]);
        for (std::size_t k = 0; k < n; ++k) extra[I].push_back(static_cast<Index>(in[a + 1 + k]));
        a += 1 + n;
      }
    }
  }
  std::vector<Index> rowStart{0}, columns;
  for (Index I = 0; I < static_cast<Index>(extra.size()); ++I) {
    std::vector<Index>& row = extra[I];
    if (I < C.rows())
      for (Index k = C.rowBegin(I); k < C.rowEnd(I); ++k) row.push_back(C.column(k));
    else
      row.push_back(I);  // an extra ghost's row: its diagonal (made an identity row by sumShares)
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
    columns.insert(columns.end(), row.begin(), row.end());
    rowStart.push_back(static_cast<Index>(columns.size()));
  }
  C = BlockSparseMatrix<d>(std::move(rowStart), columns);
}

template <int d>
std::vector<Index> MultigridHierarchy<d>::sumShares(int l, const std::vector<Index>* rows) {
  const Communicator& comm = *comm_;
  BlockSparseMatrix<d>& C = coarse_[l];
  // a local update keeps shared blocks shared: its few changed entries go through a BlockWriter
  if (!rows) C.unshareBlocks();
  std::optional<typename BlockSparseMatrix<d>::BlockWriter> writer;
  if (C.shared()) writer.emplace(C);
  const BlockSparseMatrix<d>& read = C;
  const auto write = [&](Index k, const Mat& B) {  // B a copy: a writer may move the stored blocks
    if (writer) writer->set(k, B);
    else C.blockAt(k) = B;
  };
  std::vector<Index> all(static_cast<std::size_t>(C.rows()));
  for (Index I = 0; I < C.rows(); ++I) all[I] = I;
  if (!distributedLevel(l)) {  // replicated: the same pattern on every rank, the blocks summed
    std::vector<double> values(static_cast<std::size_t>(C.nonZeroBlocks()) * d * d);
    for (Index k = 0; k < C.nonZeroBlocks(); ++k) std::copy_n(C.blockAt(k).data(), d * d, values.begin() + k * d * d);
    comm.sum(values);
    for (Index k = 0; k < C.nonZeroBlocks(); ++k) std::copy_n(values.begin() + k * d * d, d * d, C.blockAt(k).data());
    markDeadComponents(C, all, dead_[l]);
    return {};
  }
  // the ghost rows' shares added to their owners' rows (patterns joined by joinPattern)
  const Level& lv = levels_[l];
  std::vector<char> inRows;  // a local update: the recomputed rows
  if (rows) {
    inRows.assign(static_cast<std::size_t>(C.rows()), 0);
    for (Index I : *rows) inRows[static_cast<std::size_t>(I)] = 1;
  }
  const auto recomputed = [&](Index I) { return !rows || inRows[static_cast<std::size_t>(I)] != 0; };
  std::vector<std::vector<double>> send(static_cast<std::size_t>(comm.size()));
  for (Index I = lv.owned; I < C.rows(); ++I) {
    if (!recomputed(I)) continue;
    std::vector<double>& out = send[lv.owner[I]];
    out.push_back(static_cast<double>(lv.global[I]));
    out.push_back(static_cast<double>(C.rowEnd(I) - C.rowBegin(I)));
    for (Index k = C.rowBegin(I); k < C.rowEnd(I); ++k) {
      out.push_back(static_cast<double>(lv.global[C.column(k)]));
      const Mat& B = read.blockAt(k);
      out.insert(out.end(), B.data(), B.data() + d * d);
    }
  }
  const std::vector<std::vector<double>> got = comm.exchange(send);
  for (const auto& in : got)
    for (std::size_t a = 0; a < in.size();) {
      const Index I = lv.local(static_cast<Index>(in[a]));
      const auto n = static_cast<std::size_t>(in[a + 1]);
      a += 2;
      for (std::size_t k = 0; k < n; ++k, a += 1 + d * d) {
        const Index pos = C.find(I, lv.local(static_cast<Index>(in[a])));
        write(pos, Mat(read.blockAt(pos) + Eigen::Map<const Mat>(in.data() + a + 1)));
      }
    }
  // dead components from the owned rows: the largest live diagonal entry over all ranks (a local
  // update: the rows it did not recompute keep their dead components, patched, out of the maximum)
  double scale = 0;
  for (Index I = 0; I < lv.owned; ++I) {
    const Mat& D = read.blockAt(C.diagonal(I));
    for (int c = 0; c < d; ++c)
      if (recomputed(I) || !(dead_[l][I] & (1u << c))) scale = std::max(scale, D(c, c));
  }
  scale = comm.max(scale);
  const double patch = scale > 0 ? scale : 1.0;
  Eigen::VectorXd bits = Eigen::VectorXd::Zero(C.rows());
  std::vector<Index> repatched;
  for (Index I = 0; I < lv.owned; ++I) {
    const Index k = C.diagonal(I);
    Mat D = read.blockAt(k);
    unsigned b = 0;
    bool moved = false;
    if (recomputed(I)) {
      for (int c = 0; c < d; ++c)
        if (D(c, c) <= 1e-12 * scale) {
          b |= 1u << c;
          D(c, c) = patch;
          moved = true;
        }
    } else {  // kept: its dead components take the new patch value
      b = dead_[l][I];
      for (int c = 0; c < d; ++c)
        if ((b & (1u << c)) && D(c, c) != patch) {
          D(c, c) = patch;
          moved = true;
        }
      if (moved) repatched.push_back(I);
    }
    if (moved) write(k, D);
    bits[I] = b;
  }
  lv.halo->update(bits);
  for (Index I = 0; I < C.rows(); ++I) dead_[l][I] = static_cast<std::uint8_t>(bits[I]);
  // the ghost rows held this rank's share only: identity rows, so that every diagonal block is
  // regular for the smoothers (which sweep the owned rows only)
  for (Index I = lv.owned; I < C.rows(); ++I) {
    if (!recomputed(I)) continue;  // still the identity row of the last update
    for (Index k = C.rowBegin(I); k < C.rowEnd(I); ++k) write(k, C.column(k) == I ? Mat(Mat::Identity()) : Mat(Mat::Zero()));
  }
  return repatched;
}

template <int d>
bool MultigridHierarchy<d>::updateDistributedRows(int l, const std::vector<Index>& changed, const std::vector<Index>* slot,
                                                  const std::vector<Mat>* E, std::vector<Index>& rows) {
  const Level& lv = levels_[l];
  BlockSparseMatrix<d>& C = coarse_[l];
  const mesh::CsrMatrix& P = prolongations_[l];
  const bool top = l + 1 == maxLevel();
  const BlockSparseMatrix<d>& F = top ? *fine_ : coarse_[l + 1];
  // the entries that change are (I, J) with I or J in the supports R of the changed held vertices:
  // the rows of R and of its neighbours (as serially). A rank's pattern of a ghost row need not hold
  // every neighbour, but the rank that owns a changed vertex r has all of them in its rows of r's
  // support (its share there comes from the owned row r and every fine neighbour of r), and the
  // marks go to the owners and back: every rank holding a row to recompute recomputes its share of
  // it, so that the owners sum fresh shares. (The changed vertices' truncation bits are the same on
  // every rank that holds them.)
  Eigen::VectorXd mark = Eigen::VectorXd::Zero(C.rows());
  for (Index p : changed)
    for (Index k = P.rowStart[p]; k < P.rowStart[p + 1]; ++k) {
      const Index I = P.columns[k];
      for (Index a = C.rowBegin(I); a < C.rowEnd(I); ++a) mark[C.column(a)] = 1;  // I itself included
    }
  lv.halo->accumulate(mark);
  lv.halo->update(mark);
  rows.clear();
  double owned = 0;
  for (Index I = 0; I < C.rows(); ++I)
    if (mark[I] != 0) {
      rows.push_back(I);
      if (I < lv.owned) ++owned;
    }
  std::vector<double> counts{owned, static_cast<double>(lv.owned)};
  comm_->sum(counts);
  if (!(4 * counts[0] < counts[1])) return false;  // a full product is cheaper
  galerkinRows<d>(F, P, transposed_[l], slot, E, rows, C, nullptr, 0, top ? &diagonalSlot_ : nullptr, &diagonalBlocks_);
  const std::vector<Index> repatched = sumShares(l, &rows);
  if (C.shared() && 2 * C.storedBlocks() > C.nonZeroBlocks()) {  // the blocks no entry uses any more
    C.unshareBlocks();
    C.shareRepeatedBlocks();
  }
  updatedRows_[l] = rows;
  updatedRows_[l].insert(updatedRows_[l].end(), repatched.begin(), repatched.end());
  fullUpdate_[l] = 0;
  rowsRecomputed_ += static_cast<long long>(rows.size());
  return true;
}

template <int d>
void MultigridHierarchy<d>::setFineBasis(const mesh::CsrMatrix& C) {
  const int L = maxLevel();
  const Index n = numVertices(L);
  const auto check = [&] {
    if (C.rows != 0 && (C.rows != n || C.cols != n))
      throw Error("multigrid hierarchy: fine basis transformation of size " + std::to_string(C.rows) + " x " +
                  std::to_string(C.cols) + " for " + std::to_string(n) + " fine vertices");
  };
  if (distributed()) {  // formed by widen() in the next setFineOperator()
    comm_->collective(check);
    const bool any = comm_->max(C.rows > 0 ? 1.0 : 0.0) > 0;
    comm_->collective([&] {
      if (any && L == 0) throw Error("multigrid hierarchy: a fine basis transformation needs a refined grid");
    });
    basis_ = any ? C : mesh::CsrMatrix();
    if (any && basis_.rows == 0) {  // no transformation on this rank: C = 0
      basis_.rows = basis_.cols = n;
      basis_.rowStart.assign(static_cast<std::size_t>(n) + 1, 0);
    }
    widening_ = any || comm_->max(levels_[L].base > levels_[L].rows ? 1.0 : 0.0) > 0;
    return;
  }
  check();
  if (L == 0) return;  // no prolongation into the fine level
  if (plainTop_.rows == 0 && (C.rows == 0 || C.columns.empty())) return;  // nothing set, nothing to set
  if (plainTop_.rows > 0) prolongations_[L - 1] = plainTop_;  // undo an earlier transformation
  plainTop_ = mesh::CsrMatrix();
  if (C.rows == 0 || C.columns.empty()) {
    transposed_[L - 1] = transpose(prolongations_[L - 1]);
    return;
  }
  plainTop_ = prolongations_[L - 1];
  prolongations_[L - 1] = minusBasisTimes(plainTop_, C, plainTop_.rows);
  transposed_[L - 1] = transpose(prolongations_[L - 1]);
}

template <int d>
void MultigridHierarchy<d>::setFineOperator(const BlockSparseMatrix<d>& A, std::vector<VertexRotation<d>> rotations,
                                            const std::vector<char>& mask) {
  const int L = maxLevel();
  const Index n = numVertices(L);
  if (A.rows() != n)
    throw Error("multigrid hierarchy: the fine operator has " + std::to_string(A.rows()) +
                " block rows, the leaf view of the grid " + std::to_string(n) +
                " vertices (is the problem assembled on grid.leafView().mesh?)");
  fine_ = &A;
  rotation_.clear();
  rotationSlot_.assign(n, -1);
  for (const auto& r : rotations) {
    if (r.vertex < 0 || r.vertex >= n) throw Error("multigrid hierarchy: rotation of a vertex out of range");
    rotationSlot_[r.vertex] = static_cast<Index>(rotation_.size());
    rotation_.push_back(r.rotation);
  }
  bits_.assign(n, 0);
  if (!mask.empty()) setBits(mask);
  changed_.clear();
  diagonalSlot_.assign(n, -1);
  diagonalVertices_.clear();
  diagonalBlocks_.clear();
  pendingVertices_.clear();
  pendingBlocks_.clear();
  pending_ = false;
  updates_ = 0;
  updateTransforms();

  const auto t0 = Clock::now();
  coarse_.assign(std::max(L, 1), BlockSparseMatrix<d>());
  if (widening_) restoreBase();
  for (int l = L - 1; l >= 0; --l) {
    if (widening_) widen(l);
    coarse_[l] = galerkinPattern(l == L - 1 ? A : coarse_[l + 1], prolongations_[l], transposed_[l]);
    if (distributedLevel(l) || distributedLevel(l + 1)) joinPattern(l);
    if (widening_) finishLevel(l);
  }
  dead_.assign(L, {});
  for (int l = 0; l < L; ++l) dead_[l].assign(numVertices(l), 0);
  galerkinSeconds_ += since(t0);
  computeCoarse(false);
}

template <int d>
Index MultigridHierarchy<d>::truncate(const std::vector<char>& mask) {
  if (!fine_) throw Error("multigrid hierarchy: truncate() before setFineOperator()");
  const Index changes = setBits(mask);
  if (pending_) {  // the diagonal term: the vertices whose block appears, disappears or changes
    pending_ = false;
    std::vector<char> seen(bits_.size(), 0);
    for (Index p : changed_) seen[static_cast<std::size_t>(p)] = 1;
    const auto touch = [&](Index p) {
      if (!seen[static_cast<std::size_t>(p)]) {
        seen[static_cast<std::size_t>(p)] = 1;
        changed_.push_back(p);
      }
    };
    std::vector<Index> slot(bits_.size(), -1);
    for (std::size_t i = 0; i < pendingVertices_.size(); ++i) {
      const Index p = pendingVertices_[i];
      slot[static_cast<std::size_t>(p)] = static_cast<Index>(i);
      const Index old = diagonalSlot_[static_cast<std::size_t>(p)];
      if (old < 0 || diagonalBlocks_[static_cast<std::size_t>(old)] != pendingBlocks_[i]) touch(p);
    }
    for (Index p : diagonalVertices_)
      if (slot[static_cast<std::size_t>(p)] < 0) touch(p);
    diagonalSlot_.swap(slot);
    diagonalVertices_.swap(pendingVertices_);
    diagonalBlocks_.swap(pendingBlocks_);
    pendingVertices_.clear();
    pendingBlocks_.clear();
  }
  // distributed: the coarse levels are recomputed on every rank if the mask changed on any
  changedAnywhere_ = distributed() ? comm_->max(changed_.empty() ? 0.0 : 1.0) > 0 : !changed_.empty();
  if (changedAnywhere_) {
    updateTransforms();
    computeCoarse(true);
  }
  return changes;
}

template <int d>
void MultigridHierarchy<d>::setFineDiagonal(std::vector<Index> vertices, std::vector<Mat> blocks) {
  if (!fine_) throw Error("multigrid hierarchy: setFineDiagonal() before setFineOperator()");
  if (vertices.size() != blocks.size())
    throw Error("multigrid hierarchy: setFineDiagonal with " + std::to_string(vertices.size()) + " vertices and " +
                std::to_string(blocks.size()) + " blocks");
  std::vector<char> seen(bits_.size(), 0);
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const Index p = vertices[i];
    if (p < 0 || p >= static_cast<Index>(bits_.size()))
      throw Error("multigrid hierarchy: setFineDiagonal: vertex " + std::to_string(p) + " out of range");
    if (seen[static_cast<std::size_t>(p)]++)
      throw Error("multigrid hierarchy: setFineDiagonal: vertex " + std::to_string(p) + " given twice");
    if (!blocks[i].allFinite())
      throw Error("multigrid hierarchy: setFineDiagonal: the block of vertex " + std::to_string(p) + " is not finite");
  }
  pendingVertices_ = std::move(vertices);
  pendingBlocks_ = std::move(blocks);
  pending_ = true;
}

template <int d>
void MultigridHierarchy<d>::addFineDiagonal(const Eigen::VectorXd& x, Eigen::VectorXd& out) const {
  for (std::size_t i = 0; i < diagonalVertices_.size(); ++i) {
    const auto at = static_cast<Eigen::Index>(diagonalVertices_[i]) * d;
    out.template segment<d>(at) += diagonalBlocks_[i] * x.template segment<d>(at);
  }
}

template <int d>
Index MultigridHierarchy<d>::setBits(const std::vector<char>& mask) {
  const Index n = numVertices(maxLevel());
  if (mask.size() != static_cast<std::size_t>(n) * d)
    throw Error("multigrid hierarchy: truncation mask of size " + std::to_string(mask.size()) + " for " +
                std::to_string(static_cast<std::size_t>(n) * d) + " fine components");
  changed_.clear();
  Index changes = 0;
  for (Index p = 0; p < n; ++p) {
    std::uint8_t b = 0;
    for (int c = 0; c < d; ++c)
      if (mask[static_cast<std::size_t>(p) * d + c]) b |= static_cast<std::uint8_t>(1u << c);
    if (b != bits_[p]) {
      changes += std::popcount(static_cast<unsigned>(b ^ bits_[p]));
      bits_[p] = b;
      changed_.push_back(p);
    }
  }
  return changes;
}

template <int d>
Index MultigridHierarchy<d>::truncatedComponents() const {
  Index n = 0;
  for (std::uint8_t b : bits_) n += std::popcount(static_cast<unsigned>(b));
  return n;
}

template <int d>
void MultigridHierarchy<d>::updateTransforms() {
  const Index n = static_cast<Index>(bits_.size());
  transform_.clear();
  transformSlot_.assign(n, -1);
  for (Index p = 0; p < n; ++p) {
    if (rotationSlot_[p] < 0 && bits_[p] == 0) continue;
    Mat E = rotationSlot_[p] >= 0 ? rotation_[rotationSlot_[p]] : Mat::Identity();
    for (int c = 0; c < d; ++c)
      if (bits_[p] & (1u << c)) E.col(c).setZero();  // E_p = Q_p T_p
    transformSlot_[p] = static_cast<Index>(transform_.size());
    transform_.push_back(E);
  }
}

template <int d>
void MultigridHierarchy<d>::computeCoarse(bool local) {
  const auto t0 = Clock::now();
  const int L = maxLevel();
  ++updates_;
  updatedRows_.assign(std::max(L, 1), {});
  fullUpdate_.assign(std::max(L, 1), 1);
  if (L == 0) {
    // explicit A~_T: truncated rows and columns -> identity
    BlockSparseMatrix<d>& C = coarse_[0];
    C = *fine_;
    for (Index p = 0; p < C.rows(); ++p)
      for (Index k = C.rowBegin(p); k < C.rowEnd(p); ++k) {
        const Index q = C.column(k);
        auto& B = C.blockAt(k);
        if (p == q && diagonalSlot_[p] >= 0) B += diagonalBlocks_[diagonalSlot_[p]];
        for (int c = 0; c < d; ++c) {
          if (bits_[p] & (1u << c)) B.row(c).setZero();
          if (bits_[q] & (1u << c)) B.col(c).setZero();
          if (p == q && (bits_[p] & (1u << c))) B(c, c) = 1;
        }
      }
  }
  // Local update: the entries of A_l that change are those (I, J) with I or J in
  // R_l = { I : P_pI != 0 for a changed vertex p of level l + 1 }; they lie in the rows of R_l and
  // of its neighbours, and R_l is the changed set for level l - 1.
  std::vector<Index> changed = changed_, touched, rows, all, recomputedRows;
  std::vector<char> mark;
  std::vector<Index> deadSlot;
  std::vector<Mat> deadE;
  for (int l = L - 1; l >= 0; --l) {
    BlockSparseMatrix<d>& C = coarse_[l];
    const bool top = l == L - 1;
    const mesh::CsrMatrix& P = prolongations_[l];
    const BlockSparseMatrix<d>& F = top ? *fine_ : coarse_[l + 1];
    // below the top: the components of level l + 1 without fine support are truncated (T_p)
    if (!top) deadTransforms<d>(dead_[l + 1], deadSlot, deadE);
    const std::vector<Index>* slot = top ? &transformSlot_ : &deadSlot;
    const std::vector<Mat>* E = top ? &transform_ : &deadE;
    bool partial = local && !distributed();  // a distributed hierarchy: below
    // a distributed hierarchy updates its distributed levels locally (the rows next to the changed
    // vertices, on every rank that holds them); the rows it recomputed are the changed set of the
    // next level down. Replicated levels are recomputed whole.
    if (local && distributedLevel(l) && updateDistributedRows(l, changed, slot, E, recomputedRows)) {
      changed.swap(recomputedRows);
      continue;
    }
    if (partial) {
      mark.assign(C.rows(), 0);
      touched.clear();
      for (Index p : changed)
        for (Index k = P.rowStart[p]; k < P.rowStart[p + 1]; ++k)
          if (!mark[P.columns[k]]) {
            mark[P.columns[k]] = 1;
            touched.push_back(P.columns[k]);
          }
      rows = touched;
      for (Index I : touched)
        for (Index k = C.rowBegin(I); k < C.rowEnd(I); ++k)
          if (!mark[C.column(k)]) {
            mark[C.column(k)] = 1;
            rows.push_back(C.column(k));
          }
      partial = 4 * rows.size() < static_cast<std::size_t>(C.rows());  // else a full product is cheaper
    }
    if (partial) {
      std::sort(rows.begin(), rows.end());
      galerkinRows<d>(F, P, transposed_[l], slot, E, rows, C, nullptr, 0, top ? &diagonalSlot_ : nullptr,
                   &diagonalBlocks_);
      // the vertices whose dead bits changed (within `touched` but for round-off at the threshold)
      // change the next product as well
      const DeadUpdate u = markDeadComponents(C, rows, dead_[l]);
      if (C.shared() && 2 * C.storedBlocks() > C.nonZeroBlocks()) {  // the blocks no entry uses any more
        C.unshareBlocks();
        C.shareRepeatedBlocks();
      }
      for (Index I : u.flipped)
        if (std::find(touched.begin(), touched.end(), I) == touched.end()) touched.push_back(I);
      updatedRows_[l] = rows;
      updatedRows_[l].insert(updatedRows_[l].end(), u.repatched.begin(), u.repatched.end());
      fullUpdate_[l] = 0;
      changed.swap(touched);
      rowsRecomputed_ += static_cast<long long>(rows.size());
    } else {
      all.resize(C.rows());
      for (Index I = 0; I < C.rows(); ++I) all[I] = I;
      // every block anew, range of rows by range of rows, the repeated blocks shared as they come
      // (BlockSparseMatrix::fillByRowRanges): one block per entry is not stored on the way
      C.fillByRowRanges([&](Index first, Index last, Mat* out) {
        galerkinRows<d>(F, P, transposed_[l], slot, E, std::span<const Index>(all).subspan(first, last - first), C, out,
                     C.rowBegin(first), top ? &diagonalSlot_ : nullptr, &diagonalBlocks_);
      });
      if (distributedLevel(l) || distributedLevel(l + 1)) sumShares(l);  // the ranks' shares summed
      else markDeadComponents(C, all, dead_[l]);
      C.shareRepeatedBlocks();
      rowsRecomputed_ += C.rows();
      local = false;  // all entries of this level may have changed
    }
  }
  galerkinSeconds_ += since(t0);
}

template <int d>
void MultigridHierarchy<d>::restrict(int l, const Eigen::VectorXd& fine, Eigen::VectorXd& coarse) const {
  using Vec = Eigen::Matrix<double, d, 1>;
  const mesh::CsrMatrix& P = prolongations_[l];
  const bool top = l + 1 == maxLevel();
  const auto transformed = [&](Index p) {
    Vec r = fine.template segment<d>(static_cast<Eigen::Index>(p) * d);
    if (top && transformSlot_[p] >= 0) r = transform_[transformSlot_[p]] * r;
    if (!top) truncateDead(dead_[l + 1][p], r);
    return r;
  };
  coarse.setZero(static_cast<Eigen::Index>(P.cols) * d);
  const int nt = P.rows >= kParallelMinRows ? threads() : 1;
  // distributed: this rank's share from its owned fine rows, summed over the ranks
  const auto sum = [&] {
    if (distributedLevel(l)) levels_[l].halo->accumulate(coarse, d);
    else if (distributedLevel(l + 1)) {
      std::vector<double> v(coarse.data(), coarse.data() + coarse.size());
      comm_->sum(v);
      std::copy(v.begin(), v.end(), coarse.data());
    }
  };
  if (nt == 1) {  // scatter P' r row by fine row
    const Index rows = ownedVertices(l + 1);
    for (Index p = 0; p < rows; ++p) {
      const Vec r = transformed(p);
      for (Index k = P.rowStart[p]; k < P.rowStart[p + 1]; ++k)
        coarse.template segment<d>(static_cast<Eigen::Index>(P.columns[k]) * d) += P.values[k] * r;
    }
    sum();
    return;
  }
  // on threads: the transformed defect, then each coarse row gathers through P' (its fine columns
  // ascending: the same sums in the same order as the scatter, so the same bits)
  restrictBuffer_.resize(fine.size());
#pragma omp parallel num_threads(nt)
  {
#pragma omp for schedule(dynamic, kRowChunk)
    for (Index p = 0; p < P.rows; ++p)
      restrictBuffer_.template segment<d>(static_cast<Eigen::Index>(p) * d) = transformed(p);
    const mesh::CsrMatrix& Pt = transposed_[l];
#pragma omp for schedule(dynamic, kRowChunk)
    for (Index c = 0; c < Pt.rows; ++c) {
      Vec s = Vec::Zero();
      for (Index k = Pt.rowStart[c]; k < Pt.rowStart[c + 1]; ++k)
        s += Pt.values[k] * restrictBuffer_.template segment<d>(static_cast<Eigen::Index>(Pt.columns[k]) * d);
      coarse.template segment<d>(static_cast<Eigen::Index>(c) * d) = s;
    }
  }
  sum();
}

template <int d>
void MultigridHierarchy<d>::prolongateAdd(int l, const Eigen::VectorXd& coarse, Eigen::VectorXd& fine) const {
  using Vec = Eigen::Matrix<double, d, 1>;
  const mesh::CsrMatrix& P = prolongations_[l];
  const bool top = l + 1 == maxLevel();
  const int nt = P.rows >= kParallelMinRows ? threads() : 1;
#pragma omp parallel for schedule(dynamic, kRowChunk) num_threads(nt) if (nt > 1)
  for (Index p = 0; p < P.rows; ++p) {
    Vec s = Vec::Zero();
    for (Index k = P.rowStart[p]; k < P.rowStart[p + 1]; ++k)
      s += P.values[k] * coarse.template segment<d>(static_cast<Eigen::Index>(P.columns[k]) * d);
    if (top && transformSlot_[p] >= 0) s = transform_[transformSlot_[p]].transpose() * s;
    if (!top) truncateDead(dead_[l + 1][p], s);
    fine.template segment<d>(static_cast<Eigen::Index>(p) * d) += s;
  }
}

template <int d>
std::size_t MultigridHierarchy<d>::memoryBytes() const {
  std::size_t b = 0;
  for (const auto* list : {&prolongations_, &transposed_, &baseProlongations_})
    for (const auto& P : *list)
      b += P.rowStart.capacity() * sizeof(Index) + P.columns.capacity() * sizeof(Index) +
           P.values.capacity() * sizeof(double);
  for (const auto& C : coarse_) b += C.memoryBytes();
  b += (rotation_.capacity() + transform_.capacity()) * sizeof(Mat) +
       (rotationSlot_.capacity() + transformSlot_.capacity()) * sizeof(Index) + bits_.capacity();
  for (const auto& bits : dead_) b += bits.capacity();
  return b;
}

template std::vector<VertexRotation<2>> problemRotations(const ContactProblem<2>&);
template std::vector<VertexRotation<3>> problemRotations(const ContactProblem<3>&);
template class MultigridHierarchy<2>;
template class MultigridHierarchy<3>;

}  // namespace obs
