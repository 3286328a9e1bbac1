#include "obs/obs/DistributedMultiBody.hpp"

#include <algorithm>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <functional>
#include <utility>

#include "obs/mesh/Error.hpp"

namespace obs {

template <int d>
DistributedMultiBody<d>::DistributedMultiBody(std::vector<DistributedBody<d>> bodies, const DistributedMortar& mortar,
                                              int slaveBody, int masterBody)
    : bodies_(std::move(bodies)), slave_(slaveBody), master_(masterBody) {
  if (bodies_.empty() || !bodies_[0].view) throw Error("distributed multi-body problem: no bodies");
  const Communicator& comm = bodies_[0].view->halo.communicator();
  const int me = comm.rank(), ranks = comm.size();
  const int nb = numBodies();
  comm.collective([&] {
    for (int b = 0; b < nb; ++b) {
      const DistributedBody<d>& body = bodies_[static_cast<std::size_t>(b)];
      if (!body.view || !body.system) throw Error("distributed multi-body problem: body " + std::to_string(b) + " is not given");
      if (body.system->numVertices() != body.view->halo.numLocal() ||
          body.system->load.size() != static_cast<Eigen::Index>(body.view->halo.numLocal()) * d)
        throw Error("distributed multi-body problem: the system of body " + std::to_string(b) +
                    " is not assembled on its view's local mesh");
    }
    if (slaveBody < 0 || slaveBody >= nb || masterBody < 0 || masterBody >= nb || slaveBody == masterBody)
      throw Error("distributed multi-body problem: slave body " + std::to_string(slaveBody) + " and master body " +
                  std::to_string(masterBody) + " of " + std::to_string(nb));
  });

  // --- the stacked numbering: per rank its owned vertices of every body, body by body ---
  ownedCounts_.assign(static_cast<std::size_t>(nb), std::vector<Index>(static_cast<std::size_t>(ranks)));
  rankOffset_.assign(static_cast<std::size_t>(ranks) + 1, 0);
  std::vector<Index> serialOffset(static_cast<std::size_t>(nb) + 1, 0);  // the mortar's stacking
  for (int b = 0; b < nb; ++b) {
    const std::vector<Index>& off = bodies_[static_cast<std::size_t>(b)].view->numbering.offsets;
    for (int r = 0; r < ranks; ++r) ownedCounts_[b][r] = off[r + 1] - off[r];
    serialOffset[b + 1] = serialOffset[b] + off.back();
  }
  for (int r = 0; r < ranks; ++r) {
    rankOffset_[r + 1] = rankOffset_[r];
    for (int b = 0; b < nb; ++b) rankOffset_[r + 1] += ownedCounts_[b][r];
  }
  ownedStart_.resize(static_cast<std::size_t>(nb));
  ghostStart_.resize(static_cast<std::size_t>(nb));
  Index next = 0;
  for (int b = 0; b < nb; ++b) {
    ownedStart_[b] = next;
    next += bodies_[b].view->halo.numOwned();
  }
  owned_ = next;
  for (int b = 0; b < nb; ++b) {
    ghostStart_[b] = next;
    next += bodies_[b].view->halo.numLocal() - bodies_[b].view->halo.numOwned();
  }
  firstExtra_ = next;
  global_.resize(static_cast<std::size_t>(next));
  for (int b = 0; b < nb; ++b) {
    const DistributedView& view = *bodies_[b].view;
    for (Index v = 0; v < view.halo.numLocal(); ++v) {
      const Index l = local(b, v);
      global_[l] = stackedGlobal(b, view.numbering.global[view.halo.viewVertices()[v]]);
      if (l >= owned_) ghostLocal_[global_[l]] = l;
    }
  }
  const auto fromSerial = [&](Index s) {
    const auto b = static_cast<int>(std::upper_bound(serialOffset.begin(), serialOffset.end(), s) - serialOffset.begin()) - 1;
    if (b < 0 || b >= nb) throw Error("distributed multi-body problem: a mortar column out of range");
    return stackedGlobal(b, s - serialOffset[b]);
  };

  // --- rows of C = D^{-1} M at the held slave vertices (stacked global columns) ---
  std::vector<std::vector<std::pair<Index, double>>>& crow = crow_;
  crow.assign(static_cast<std::size_t>(firstExtra_), {});
  comm.collective([&] {
    for (const auto& row : mortar.rows()) {
      auto& out = crow[static_cast<std::size_t>(local(slaveBody, row.local))];
      for (const auto& e : row.entries) out.emplace_back(fromSerial(e.vertex), e.value / row.D);
    }
  });
  {  // a ghost slave vertex's row from its owner (request, reply)
    const DistributedView& sv = *bodies_[slaveBody].view;
    std::vector<std::vector<double>> ask(static_cast<std::size_t>(ranks));
    std::vector<std::vector<Index>> askedLocal(static_cast<std::size_t>(ranks));
    for (Index v = sv.halo.numOwned(); v < sv.halo.numLocal(); ++v) {
      const Index l = local(slaveBody, v);
      const int o = owner(global_[l]);
      ask[o].push_back(static_cast<double>(global_[l]));
      askedLocal[o].push_back(l);
    }
    const auto asked = comm.exchange(ask);
    std::vector<std::vector<double>> reply(static_cast<std::size_t>(ranks));
    for (int r = 0; r < ranks; ++r)
      for (double g : asked[r]) {
        const Index l = static_cast<Index>(g) - rankOffset_[me];
        const auto& row = crow[static_cast<std::size_t>(l)];
        reply[r].push_back(static_cast<double>(row.size()));
        for (const auto& [q, c] : row) {
          reply[r].push_back(static_cast<double>(q));
          reply[r].push_back(c);
        }
      }
    const auto got = comm.exchange(reply);
    for (int r = 0; r < ranks; ++r) {
      std::size_t k = 0;
      for (Index l : askedLocal[r]) {
        const auto count = static_cast<std::size_t>(got[r][k++]);
        auto& row = crow[static_cast<std::size_t>(l)];
        for (std::size_t e = 0; e < count; ++e, k += 2) row.emplace_back(static_cast<Index>(got[r][k]), got[r][k + 1]);
      }
    }
  }
  // the transformation leaves the Dirichlet components of slave vertices alone (basisSkip())
  skip_.assign(static_cast<std::size_t>(firstExtra_), 0);
  for (int b = 0; b < nb; ++b)
    for (Index v = 0; v < bodies_[b].view->halo.numLocal(); ++v) {
      const Index l = local(b, v);
      if (crow_[l].empty()) continue;
      for (int a = 0; a < d; ++a)
        if (bodies_[b].system->dirichlet.constrained[static_cast<std::size_t>(v) * d + a]) skip_[l] |= static_cast<std::uint8_t>(1u << a);
    }

  // --- the local rows of C; vertices the rank does not hold become extra ghosts: the columns of C
  // first, then those of the owned rows of T'AT ---
  const std::function<Index(Index)> localOf = [this, me](Index g) {
    if (g >= rankOffset_[me] && g < rankOffset_[me + 1]) return g - rankOffset_[me];
    const auto it = ghostLocal_.find(g);
    if (it != ghostLocal_.end()) return it->second;
    const auto l = static_cast<Index>(global_.size());
    global_.push_back(g);
    ghostLocal_.emplace(g, l);
    return l;
  };
  std::vector<std::vector<std::pair<Index, double>>> lrow(static_cast<std::size_t>(firstExtra_));
  for (Index l = 0; l < firstExtra_; ++l) {
    for (const auto& [q, c] : crow_[l]) lrow[l].emplace_back(localOf(q), c);
    std::sort(lrow[l].begin(), lrow[l].end());
  }
  std::vector<Source> sources;
  for (int b = 0; b < nb; ++b) sources.push_back({&bodies_[b].system->stiffness, &bodies_[b].system->load, b});
  BlockSparseMatrix<d> M;
  Eigen::VectorXd load;
  transform(sources, localOf, M, load, &receivedTerms_);
  const auto n = static_cast<Index>(global_.size());
  mesh::CsrMatrix C;  // local rows at the held slave vertices
  C.rows = C.cols = n;
  C.rowStart.assign(static_cast<std::size_t>(n) + 1, 0);
  for (Index l = 0; l < firstExtra_; ++l) C.rowStart[l + 1] = static_cast<Index>(lrow[l].size());
  for (Index l = 0; l < n; ++l) C.rowStart[l + 1] += C.rowStart[l];
  for (Index l = 0; l < firstExtra_; ++l)
    for (const auto& [q, c] : lrow[l]) {
      C.columns.push_back(q);
      C.values.push_back(c);
    }
  lrow.clear();

  // --- the halo, and the vertex data of the ghosts from their owners ---
  std::vector<Index> ghostGlobal(global_.begin() + owned_, global_.end());
  std::vector<int> ghostOwner(ghostGlobal.size());
  for (std::size_t j = 0; j < ghostGlobal.size(); ++j) ghostOwner[j] = owner(ghostGlobal[j]);
  halo_ = std::make_unique<HaloExchange>(owned_, rankOffset_[me], ghostGlobal, ghostOwner, comm);
  // per vertex: Dirichlet flags and values, constrained?, normal, gap / D, D, position
  constexpr int W = 3 * d + 6;
  Eigen::VectorXd data = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n) * W);
  for (int b = 0; b < nb; ++b) {
    const DistributedView& view = *bodies_[b].view;
    const DirichletValues& dir = bodies_[b].system->dirichlet;
    for (Index v = 0; v < view.halo.numOwned(); ++v) {
      double* x = data.data() + static_cast<std::ptrdiff_t>(local(b, v)) * W;
      for (int a = 0; a < d; ++a) {
        x[a] = dir.constrained[static_cast<std::size_t>(v) * d + a] ? 1.0 : 0.0;
        x[d + a] = dir.values[static_cast<Eigen::Index>(v) * d + a];
      }
      for (int a = 0; a < 3; ++a) x[3 * d + 3 + a] = view.local.vertex(v)[a];
    }
  }
  for (const auto& row : mortar.rows()) {
    double* x = data.data() + static_cast<std::ptrdiff_t>(local(slaveBody, row.local)) * W;
    x[2 * d] = 1;
    for (int a = 0; a < d; ++a) x[2 * d + 1 + a] = row.normal[a];
    x[3 * d + 1] = row.gap / row.D;
    x[3 * d + 2] = row.D;
  }
  halo_->update(data, W);
  DirichletValues dirichlet;
  dirichlet.constrained.assign(static_cast<std::size_t>(n) * d, 0);
  dirichlet.values = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n) * d);
  ContactSet::Data set;
  set.dimension = d;
  set.label = "mortar";
  set.obstacleName = "mortar";
  set.numMeshVertices = n;
  for (Index l = 0; l < n; ++l) {
    const double* x = data.data() + static_cast<std::ptrdiff_t>(l) * W;
    for (int a = 0; a < d; ++a) {
      dirichlet.constrained[static_cast<std::size_t>(l) * d + a] = x[a] != 0;
      dirichlet.values[static_cast<Eigen::Index>(l) * d + a] = x[d + a];
    }
    if (x[2 * d] == 0) continue;
    Point normal = Point::Zero(), position;
    for (int a = 0; a < d; ++a) normal[a] = x[2 * d + 1 + a];
    for (int a = 0; a < 3; ++a) position[a] = x[3 * d + 3 + a];
    set.vertices.push_back(l);
    set.positions.push_back(position);
    set.directions.push_back(normal);
    set.gaps.push_back(x[3 * d + 1]);
    set.masses.push_back(x[3 * d + 2]);
  }
  dirichlet_ = dirichlet;
  comm.collective([&] {
    problem_ = std::make_unique<ContactProblem<d>>(std::move(M), std::move(load), std::move(dirichlet),
                                                   ContactSet(std::move(set)), std::move(C),
                                                   typename ContactProblem<d>::Transformed{});
  });
}

template <int d>
void DistributedMultiBody<d>::transform(const std::vector<Source>& sources, const std::function<Index(Index)>& localOf,
                                        BlockSparseMatrix<d>& M, Eigen::VectorXd& load, Index* received) const {
  using Mat = Eigen::Matrix<double, d, d>;
  using Vec = Eigen::Matrix<double, d, 1>;
  const Communicator& comm = bodies_[0].view->halo.communicator();
  const int me = comm.rank(), ranks = comm.size();
  // the terms T_rp of a row r (local index below firstExtra_): (r, 1) and (m, C_rm) but the skipped
  // components
  struct Term {
    Index vertex;  ///< stacked global
    Vec t;         ///< T_rp as a diagonal
  };
  const auto termsOf = [&](Index l, std::vector<Term>& T) {
    T.clear();
    T.push_back({global_[l], Vec::Ones()});
    for (const auto& [m, c] : crow_[l]) {
      Vec t = Vec::Constant(c);
      for (int a = 0; a < d; ++a)
        if (skip_[l] & (1u << a)) t[a] = 0;
      T.push_back({m, t});
    }
  };
  // the sources' rows and columns in this numbering; a column beyond the bodies' vertices (an extra
  // ghost of a stacked source) couples nothing the constructor's operator does not: refused
  bool outside = false;
  comm.collective([&] {
    for (const Source& src : sources) {
      const Index rows = src.body < 0 ? numLocal() : bodies_[src.body].view->halo.numLocal();
      if (!src.matrix || src.matrix->rows() != rows || !src.load || src.load->size() != static_cast<Eigen::Index>(rows) * d)
        throw Error("distributed multi-body problem: an operator or load of " +
                    std::to_string(src.matrix ? src.matrix->rows() : 0) + " rows for " + std::to_string(rows) + " vertices");
    }
  });
  const auto rowOf = [&](const Source& src, Index v) { return src.body < 0 ? v : local(src.body, v); };
  // Two passes over the terms, so that no block is stored twice: the pattern first (the columns of
  // the owned rows, and the (p, q) of other ranks' rows, sent to their owners), then the blocks
  // summed into T'AT in place and into the buffers for the other ranks, each in the order of its
  // terms; the owners add the other ranks' sums in rank order.
  std::vector<Term> Tr, Ts;
  const auto forEachTerm = [&](auto&& block, auto&& loadTerm) {
    for (const Source& src : sources) {
      const BlockSparseMatrix<d>& A = *src.matrix;
      const Index owned = src.body < 0 ? owned_ : bodies_[src.body].view->halo.numOwned();
      for (Index r = 0; r < owned; ++r) {
        termsOf(rowOf(src, r), Tr);
        const Vec br = src.load->template segment<d>(static_cast<Eigen::Index>(r) * d);
        for (const Term& p : Tr) loadTerm(p.vertex, p.t.cwiseProduct(br));
        for (Index k = A.rowBegin(r); k < A.rowEnd(r); ++k) {
          const Index col = rowOf(src, A.column(k));
          if (col >= firstExtra_) {
            outside = true;
            continue;
          }
          termsOf(col, Ts);
          for (const Term& p : Tr)
            for (const Term& q : Ts) block(p, q, A.blockAt(k), Tr.size() == 1 && Ts.size() == 1);
        }
      }
    }
  };
  const auto keyOf = [](Index p, Index q) { return (static_cast<std::uint64_t>(p) << 32) | static_cast<std::uint32_t>(q); };
  // pass 1: the pattern
  std::vector<std::vector<Index>> columns(static_cast<std::size_t>(owned_));  // global, owned rows
  std::unordered_map<std::uint64_t, std::size_t> sent;  // (p, q) of another rank's row -> its slot
  std::vector<std::vector<double>> keysOut(static_cast<std::size_t>(ranks));  // [p, q] per slot
  forEachTerm(
      [&](const Term& p, const Term& q, const Mat&, bool) {
        const int o = owner(p.vertex);
        if (o == me) {
          columns[p.vertex - rankOffset_[me]].push_back(q.vertex);
          return;
        }
        if (sent.try_emplace(keyOf(p.vertex, q.vertex), keysOut[o].size() / 2).second) {
          keysOut[o].push_back(static_cast<double>(p.vertex));
          keysOut[o].push_back(static_cast<double>(q.vertex));
        }
      },
      [](Index, const Vec&) {});
  const auto keysIn = comm.exchange(keysOut);
  keysOut.clear();
  for (int r = 0; r < ranks; ++r)
    for (std::size_t k = 0; k < keysIn[r].size(); k += 2)
      columns[static_cast<Index>(keysIn[r][k]) - rankOffset_[me]].push_back(static_cast<Index>(keysIn[r][k + 1]));

  // --- the owned rows in local numbering ---
  for (auto& row : columns) {
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
    for (Index& q : row) {
      q = localOf(q);
      outside = outside || q < 0;
    }
    std::sort(row.begin(), row.end());
  }
  if (comm.max(outside ? 1.0 : 0.0) > 0)
    throw Error("distributed multi-body problem: an operator couples vertices that the transformed stiffness does not "
                "(its pattern must be the stiffness' pattern or part of it)");
  const Index n = numLocal();
  typename BlockSparseMatrix<d>::Pattern pattern;
  pattern.rowStart.assign(static_cast<std::size_t>(n) + 1, 0);
  for (Index p = 0; p < n; ++p)
    pattern.rowStart[p + 1] = pattern.rowStart[p] + (p < owned_ ? static_cast<Index>(columns[p].size()) : 1);
  pattern.columns.resize(static_cast<std::size_t>(pattern.rowStart[n]));
  for (Index p = 0; p < n; ++p) {
    Index k = pattern.rowStart[p];
    if (p < owned_) {
      for (Index q : columns[p]) pattern.columns[k++] = q;
      columns[p] = {};
    } else {
      pattern.columns[k] = p;  // a ghost row: an identity row, never read
    }
  }
  columns.clear();
  M = BlockSparseMatrix<d>(std::move(pattern));
  for (Index p = owned_; p < n; ++p) M.blockAt(M.rowBegin(p)) = Mat::Identity();

  // pass 2: the blocks and the right-hand side
  load = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n) * d);
  std::vector<std::vector<double>> out(static_cast<std::size_t>(ranks)), loadOut(static_cast<std::size_t>(ranks));
  for (const auto& [key, slot] : sent) {
    auto& m = out[owner(static_cast<Index>(key >> 32))];
    m.resize(std::max(m.size(), (slot + 1) * d * d), 0.0);
  }
  forEachTerm(
      [&](const Term& p, const Term& q, const Mat& A, bool plain) {
        const Mat B = plain ? A : Mat(p.t.asDiagonal() * A * q.t.asDiagonal());
        const int o = owner(p.vertex);
        if (o == me) {
          const Index row = p.vertex - rankOffset_[me];
          M.blockAt(M.find(row, localOf(q.vertex))) += B;
        } else {
          Eigen::Map<Mat>(out[o].data() + sent.at(keyOf(p.vertex, q.vertex)) * d * d) += B;
        }
      },
      [&](Index p, const Vec& f) {
        const int o = owner(p);
        if (o == me) {
          load.template segment<d>((p - rankOffset_[me]) * d) += f;
          return;
        }
        loadOut[o].push_back(static_cast<double>(p));
        loadOut[o].insert(loadOut[o].end(), f.data(), f.data() + d);
      });
  sent.clear();
  const auto got = comm.exchange(out);
  out.clear();
  const auto gotLoad = comm.exchange(loadOut);
  loadOut.clear();
  for (int r = 0; r < ranks; ++r) {
    for (std::size_t k = 0; 2 * k < keysIn[r].size(); ++k) {
      const Index row = static_cast<Index>(keysIn[r][2 * k]) - rankOffset_[me];
      M.blockAt(M.find(row, localOf(static_cast<Index>(keysIn[r][2 * k + 1])))) +=
          Eigen::Map<const Mat>(got[r].data() + k * d * d);
      if (received) ++*received;
    }
    for (std::size_t k = 0; k < gotLoad[r].size(); k += 1 + d)
      for (int a = 0; a < d; ++a)
        load[(static_cast<Index>(gotLoad[r][k]) - rankOffset_[me]) * d + a] += gotLoad[r][k + 1 + a];
  }
}

template <int d>
std::unique_ptr<ContactProblem<d>> DistributedMultiBody<d>::transformed(const BlockSparseMatrix<d>& stacked,
                                                                        const Eigen::VectorXd& load,
                                                                        const DirichletValues& dirichlet) const {
  const std::function<Index(Index)> localOf = [this](Index g) -> Index {
    const Index first = rankOffset_[communicator().rank()];
    if (g >= first && g < first + owned_) return g - first;
    const auto it = ghostLocal_.find(g);
    return it != ghostLocal_.end() ? it->second : -1;
  };
  BlockSparseMatrix<d> M;
  Eigen::VectorXd b;
  transform({Source{&stacked, &load, -1}}, localOf, M, b);
  std::unique_ptr<ContactProblem<d>> problem;
  communicator().collective([&] {
    if (dirichlet.constrained.size() != static_cast<std::size_t>(numLocal()) * d ||
        dirichlet.values.size() != static_cast<Eigen::Index>(numLocal()) * d)
      throw Error("distributed multi-body problem: Dirichlet data of another numbering");
    problem = std::make_unique<ContactProblem<d>>(std::move(M), std::move(b), dirichlet, contactSet(), basis(),
                                                  typename ContactProblem<d>::Transformed{});
  });
  return problem;
}

template <int d>
Eigen::VectorXd DistributedMultiBody<d>::transposedProduct(const Eigen::VectorXd& y, double sign) const {
  communicator().collective([&] {
    if (y.size() != static_cast<Eigen::Index>(numLocal()) * d)
      throw Error("distributed multi-body problem: a vector of " + std::to_string(y.size()) + " values for " +
                  std::to_string(numLocal()) + " vertices");
  });
  const Eigen::Index ownedDofs = static_cast<Eigen::Index>(owned_) * d;
  Eigen::VectorXd out = Eigen::VectorXd::Zero(y.size());
  out.head(ownedDofs) = y.head(ownedDofs);
  const mesh::CsrMatrix& C = basis();
  for (Index p = 0; p < owned_; ++p) {  // the owned slave rows: C_pq y_p to q (local or a ghost's)
    if (C.rowStart[p + 1] == C.rowStart[p]) continue;
    Eigen::Matrix<double, d, 1> yp = y.template segment<d>(static_cast<Eigen::Index>(p) * d);
    for (int a = 0; a < d; ++a)
      if (skip_[p] & (1u << a)) yp[a] = 0;
    for (Index k = C.rowStart[p]; k < C.rowStart[p + 1]; ++k)
      out.template segment<d>(static_cast<Eigen::Index>(C.columns[k]) * d) += sign * (C.values[k] * yp);
  }
  halo_->accumulate(out, d);
  halo_->update(out, d);
  return out;
}

template <int d>
BlockSparseMatrix<d> DistributedMultiBody<d>::stack(const std::vector<const BlockSparseMatrix<d>*>& parts) const {
  const Index n = numLocal();
  communicator().collective([&] {
    if (static_cast<int>(parts.size()) != numBodies())
      throw Error("distributed multi-body problem: " + std::to_string(parts.size()) + " matrices for " +
                  std::to_string(numBodies()) + " bodies");
    for (int b = 0; b < numBodies(); ++b)
      if (!parts[b] || parts[b]->rows() != bodies_[b].view->halo.numLocal())
        throw Error("distributed multi-body problem: the matrix of body " + std::to_string(b) +
                    " is not on its view's local mesh");
  });
  // rows in local order: a body vertex's row is its body's row with the columns mapped (sorted)
  std::vector<std::pair<int, Index>> source(static_cast<std::size_t>(n), {-1, 0});
  for (int b = 0; b < numBodies(); ++b)
    for (Index v = 0; v < bodies_[b].view->halo.numLocal(); ++v) source[local(b, v)] = {b, v};
  typename BlockSparseMatrix<d>::Pattern pattern;
  pattern.rowStart.assign(static_cast<std::size_t>(n) + 1, 0);
  for (Index l = 0; l < n; ++l) {
    const auto [b, v] = source[l];
    pattern.rowStart[l + 1] = pattern.rowStart[l] + (b < 0 ? 1 : parts[b]->rowEnd(v) - parts[b]->rowBegin(v));
  }
  pattern.columns.resize(static_cast<std::size_t>(pattern.rowStart[n]));
  std::vector<std::pair<Index, Index>> row;  // (local column, source block)
  std::vector<Index> where(static_cast<std::size_t>(pattern.rowStart[n]), -1);
  for (Index l = 0; l < n; ++l) {
    const auto [b, v] = source[l];
    Index k = pattern.rowStart[l];
    if (b < 0) {
      pattern.columns[k] = l;
      continue;
    }
    row.clear();
    for (Index j = parts[b]->rowBegin(v); j < parts[b]->rowEnd(v); ++j) row.emplace_back(local(b, parts[b]->column(j)), j);
    std::sort(row.begin(), row.end());
    for (const auto& [col, j] : row) {
      pattern.columns[k] = col;
      where[k++] = j;
    }
  }
  BlockSparseMatrix<d> S(std::move(pattern));
  for (Index l = 0; l < n; ++l) {
    const int b = source[l].first;
    if (b < 0) continue;
    for (Index k = S.rowBegin(l); k < S.rowEnd(l); ++k) S.blockAt(k) = parts[b]->blockAt(where[k]);
  }
  return S;
}

template <int d>
Eigen::VectorXd DistributedMultiBody<d>::stack(const std::vector<Eigen::VectorXd>& parts, int components) const {
  communicator().collective([&] {
    if (static_cast<int>(parts.size()) != numBodies())
      throw Error("distributed multi-body problem: " + std::to_string(parts.size()) + " vectors for " +
                  std::to_string(numBodies()) + " bodies");
    for (int b = 0; b < numBodies(); ++b)
      if (parts[b].size() != static_cast<Eigen::Index>(bodies_[b].view->halo.numLocal()) * components)
        throw Error("distributed multi-body problem: the vector of body " + std::to_string(b) + " has " +
                    std::to_string(parts[b].size()) + " values, its view " +
                    std::to_string(bodies_[b].view->halo.numLocal()) + " vertices");
  });
  Eigen::VectorXd out = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(numLocal()) * components);
  for (int b = 0; b < numBodies(); ++b)
    for (Index v = 0; v < bodies_[b].view->halo.numLocal(); ++v)
      out.segment(static_cast<Eigen::Index>(local(b, v)) * components, components) =
          parts[b].segment(static_cast<Eigen::Index>(v) * components, components);
  halo_->update(out, components);
  return out;
}

template <int d>
Index DistributedMultiBody<d>::local(int body, Index v) const {
  const Index owned = bodies_[body].view->halo.numOwned();
  return v < owned ? ownedStart_[body] + v : ghostStart_[body] + (v - owned);
}

template <int d>
int DistributedMultiBody<d>::owner(Index g) const {
  return static_cast<int>(std::upper_bound(rankOffset_.begin(), rankOffset_.end(), g) - rankOffset_.begin()) - 1;
}

template <int d>
Index DistributedMultiBody<d>::stackedGlobal(int body, Index g) const {
  const std::vector<Index>& off = bodies_[body].view->numbering.offsets;
  const auto r = static_cast<std::size_t>(std::upper_bound(off.begin(), off.end(), g) - off.begin()) - 1;
  Index s = rankOffset_[r] + (g - off[r]);
  for (int b = 0; b < body; ++b) s += ownedCounts_[b][r];
  return s;
}

template <int d>
Eigen::VectorXd DistributedMultiBody<d>::bodyPart(int body, const Eigen::VectorXd& stacked, int components) const {
  const Index m = bodies_[body].view->halo.numLocal();
  if (stacked.size() != static_cast<Eigen::Index>(numLocal()) * components)
    throw Error("distributed multi-body problem: a vector of " + std::to_string(stacked.size()) + " values for " +
                std::to_string(numLocal()) + " vertices");
  Eigen::VectorXd out(static_cast<Eigen::Index>(m) * components);
  for (Index v = 0; v < m; ++v)
    out.segment(static_cast<Eigen::Index>(v) * components, components) =
        stacked.segment(static_cast<Eigen::Index>(local(body, v)) * components, components);
  return out;
}

template class DistributedMultiBody<2>;
template class DistributedMultiBody<3>;

}  // namespace obs
