#include "obs/obs/DistributedMultiBody.hpp"

#include <algorithm>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <utility>

#include "obs/mesh/Error.hpp"

namespace obs {

template <int d>
DistributedMultiBody<d>::DistributedMultiBody(std::vector<DistributedBody<d>> bodies, const DistributedMortar& mortar,
                                              int slaveBody, int masterBody)
    : bodies_(std::move(bodies)) {
  using Mat = Eigen::Matrix<double, d, d>;
  using Vec = Eigen::Matrix<double, d, 1>;
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
  std::vector<std::vector<std::pair<Index, double>>> crow(static_cast<std::size_t>(firstExtra_));
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
  std::vector<std::uint8_t> skip(static_cast<std::size_t>(firstExtra_), 0);
  for (int b = 0; b < nb; ++b)
    for (Index v = 0; v < bodies_[b].view->halo.numLocal(); ++v) {
      const Index l = local(b, v);
      if (crow[l].empty()) continue;
      for (int a = 0; a < d; ++a)
        if (bodies_[b].system->dirichlet.constrained[static_cast<std::size_t>(v) * d + a]) skip[l] |= static_cast<std::uint8_t>(1u << a);
    }

  // --- the terms of T'AT and T'b from the owned rows r of each body ---
  struct Term {
    Index vertex;  ///< stacked global
    Vec t;         ///< T_rp as a diagonal
  };
  const auto termsOf = [&](Index l, std::vector<Term>& T) {
    T.clear();
    T.push_back({global_[l], Vec::Ones()});
    for (const auto& [m, c] : crow[l]) {
      Vec t = Vec::Constant(c);
      for (int a = 0; a < d; ++a)
        if (skip[l] & (1u << a)) t[a] = 0;
      T.push_back({m, t});
    }
  };
  // Two passes over the terms, so that no block is stored twice: the pattern first (the columns of
  // the owned rows, and the (p, q) of other ranks' rows, sent to their owners), then the blocks
  // summed into T'AT in place and into the buffers for the other ranks, each in the order of its
  // terms; the owners add the other ranks' sums in rank order.
  std::vector<Term> Tr, Ts;
  const auto forEachTerm = [&](auto&& block, auto&& loadTerm) {
    for (int b = 0; b < nb; ++b) {
      const BodySystem<d>& sys = *bodies_[b].system;
      const BlockSparseMatrix<d>& A = sys.stiffness;
      for (Index r = 0; r < bodies_[b].view->halo.numOwned(); ++r) {
        termsOf(local(b, r), Tr);
        const Vec br = sys.load.template segment<d>(static_cast<Eigen::Index>(r) * d);
        for (const Term& p : Tr) loadTerm(p.vertex, p.t.cwiseProduct(br));
        for (Index k = A.rowBegin(r); k < A.rowEnd(r); ++k) {
          termsOf(local(b, A.column(k)), Ts);
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

  // --- the owned rows in local numbering: columns outside both ghost layers become extra ghosts ---
  const auto localOf = [&](Index g) {
    if (g >= rankOffset_[me] && g < rankOffset_[me + 1]) return g - rankOffset_[me];
    const auto it = ghostLocal_.find(g);
    if (it != ghostLocal_.end()) return it->second;
    const auto l = static_cast<Index>(global_.size());
    global_.push_back(g);
    ghostLocal_.emplace(g, l);
    return l;
  };
  for (auto& row : columns) {
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
    for (Index& q : row) q = localOf(q);
    std::sort(row.begin(), row.end());
  }
  mesh::CsrMatrix C;  // local rows at the held slave vertices
  {
    std::vector<std::vector<std::pair<Index, double>>> lrow(static_cast<std::size_t>(firstExtra_));
    for (Index l = 0; l < firstExtra_; ++l)
      for (const auto& [q, c] : crow[l]) lrow[l].emplace_back(localOf(q), c);
    const auto n = static_cast<Index>(global_.size());
    C.rows = C.cols = n;
    C.rowStart.assign(static_cast<std::size_t>(n) + 1, 0);
    for (Index l = 0; l < firstExtra_; ++l) {
      std::sort(lrow[l].begin(), lrow[l].end());
      C.rowStart[l + 1] = static_cast<Index>(lrow[l].size());
    }
    for (Index l = 0; l < n; ++l) C.rowStart[l + 1] += C.rowStart[l];
    for (Index l = 0; l < firstExtra_; ++l)
      for (const auto& [q, c] : lrow[l]) {
        C.columns.push_back(q);
        C.values.push_back(c);
      }
  }
  const auto n = static_cast<Index>(global_.size());
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
  BlockSparseMatrix<d> M(std::move(pattern));
  for (Index p = owned_; p < n; ++p) M.blockAt(M.rowBegin(p)) = Mat::Identity();

  // pass 2: the blocks and the right-hand side
  Eigen::VectorXd load = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(owned_) * d);
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
      ++receivedTerms_;
    }
    for (std::size_t k = 0; k < gotLoad[r].size(); k += 1 + d)
      for (int a = 0; a < d; ++a)
        load[(static_cast<Index>(gotLoad[r][k]) - rankOffset_[me]) * d + a] += gotLoad[r][k + 1 + a];
  }

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
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n) * d);
  rhs.head(load.size()) = load;
  comm.collective([&] {
    problem_ = std::make_unique<ContactProblem<d>>(std::move(M), std::move(rhs), std::move(dirichlet),
                                                   ContactSet(std::move(set)), std::move(C),
                                                   typename ContactProblem<d>::Transformed{});
  });
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
