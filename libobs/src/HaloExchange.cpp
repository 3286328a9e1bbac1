#include "obs/obs/HaloExchange.hpp"

#include <algorithm>
#include <set>
#include <string>

#include "obs/mesh/Error.hpp"

namespace obs {

HaloExchange::HaloExchange(const ViewNumbering& numbering, const PartView& part, const Communicator& comm)
    : comm_(comm) {
  const int me = comm.rank(), ranks = comm.size();
  if (numbering.offsets.size() != static_cast<std::size_t>(ranks) + 1)
    throw Error("halo exchange: a numbering of " + std::to_string(numbering.offsets.size() - 1) + " parts for " +
                std::to_string(ranks) + " ranks");
  vertices_ = part.ownedVertices;
  owned_ = static_cast<Index>(vertices_.size());
  if (owned_ != numbering.offsets[me + 1] - numbering.offsets[me])
    throw Error("halo exchange: the part view of another part or numbering");
  vertices_.insert(vertices_.end(), part.ghostVertices.begin(), part.ghostVertices.end());
  localOf_.assign(numbering.owner.size(), -1);
  for (Index i = 0; i < numLocal(); ++i) localOf_[vertices_[i]] = i;
  std::vector<int> owners;
  std::vector<Index> globals;
  for (Index i = owned_; i < numLocal(); ++i) {
    owners.push_back(numbering.owner[vertices_[i]]);
    globals.push_back(numbering.global[vertices_[i]]);
  }
  connect(owners, globals, numbering.offsets[me]);
}

HaloExchange::HaloExchange(Index owned, Index offset, const std::vector<Index>& ghostGlobal,
                           const std::vector<int>& ghostOwner, const Communicator& comm)
    : comm_(comm), owned_(owned) {
  if (owned < 0 || offset < 0 || ghostGlobal.size() != ghostOwner.size())
    throw Error("halo exchange: inconsistent owned count, offset or ghost lists");
  for (int o : ghostOwner)
    if (o < 0 || o >= comm.size() || o == comm.rank())
      throw Error("halo exchange: a ghost owned by rank " + std::to_string(o) + " (rank " + std::to_string(comm.rank()) +
                  " of " + std::to_string(comm.size()) + ")");
  const Index n = owned + static_cast<Index>(ghostGlobal.size());
  vertices_.resize(static_cast<std::size_t>(n));
  localOf_.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) vertices_[i] = localOf_[i] = i;
  connect(ghostOwner, ghostGlobal, offset);
}

void HaloExchange::connect(const std::vector<int>& ghostOwner, const std::vector<Index>& ghostGlobal, Index offset) {
  const int me = comm_.rank(), ranks = comm_.size();
  // each ghost vertex's global index to its owner; the owners learn what to send
  std::vector<std::vector<double>> request(static_cast<std::size_t>(ranks));
  recvGhost_.assign(static_cast<std::size_t>(ranks), {});
  for (std::size_t j = 0; j < ghostGlobal.size(); ++j) {
    const int o = ghostOwner[j];
    request[o].push_back(static_cast<double>(ghostGlobal[j]));  // exact below 2^53
    recvGhost_[o].push_back(owned_ + static_cast<Index>(j));
  }
  const std::vector<std::vector<double>> asked = comm_.exchange(request);
  sendOwned_.assign(static_cast<std::size_t>(ranks), {});
  for (int r = 0; r < ranks; ++r)
    for (double g : asked[r]) {
      const auto i = static_cast<Index>(g) - offset;
      if (i < 0 || i >= owned_) throw Error("halo exchange: rank " + std::to_string(r) + " asked for a vertex this rank does not own");
      sendOwned_[r].push_back(i);
    }
  for (int r = 0; r < ranks; ++r) {
    if (r != me && !sendOwned_[r].empty()) sendRanks_.push_back(r);
    if (r != me && !recvGhost_[r].empty()) recvRanks_.push_back(r);
  }
}

Index HaloExchange::local(Index viewVertex) const {
  return viewVertex >= 0 && viewVertex < static_cast<Index>(localOf_.size()) ? localOf_[viewVertex] : -1;
}

std::vector<Index> HaloExchange::sharedOwned() const {
  std::vector<Index> out;
  for (const auto& list : sendOwned_) out.insert(out.end(), list.begin(), list.end());
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<int> HaloExchange::neighbours() const {
  std::vector<int> n = sendRanks_;
  n.insert(n.end(), recvRanks_.begin(), recvRanks_.end());
  std::sort(n.begin(), n.end());
  n.erase(std::unique(n.begin(), n.end()), n.end());
  return n;
}

Index HaloExchange::sentValues() const {
  Index n = 0;
  for (const auto& s : sendOwned_) n += static_cast<Index>(s.size());
  return n;
}

void HaloExchange::update(Eigen::VectorXd& x, int components) const { exchangeGhosts(x, components, nullptr); }

void HaloExchange::update(Eigen::VectorXd& x, int components, const std::vector<char>& from) const {
  if (from.size() != static_cast<std::size_t>(comm_.size()))
    throw Error("halo exchange: " + std::to_string(from.size()) + " marks for " + std::to_string(comm_.size()) + " parts");
  exchangeGhosts(x, components, &from);
}

void HaloExchange::exchangeGhosts(Eigen::VectorXd& x, int components, const std::vector<char>* from) const {
  if (components < 1 || x.size() != static_cast<Eigen::Index>(numLocal()) * components)
    throw Error("halo exchange: a vector of " + std::to_string(x.size()) + " values for " + std::to_string(numLocal()) +
                " vertices of " + std::to_string(components) + " components");
  const bool sending = !from || (*from)[static_cast<std::size_t>(comm_.rank())];
  std::vector<int> to, sources;
  if (sending) to = sendRanks_;
  for (int q : recvRanks_)
    if (!from || (*from)[static_cast<std::size_t>(q)]) sources.push_back(q);
  std::vector<std::vector<double>> send(to.size()), got(sources.size());
  for (std::size_t k = 0; k < to.size(); ++k)
    for (Index i : sendOwned_[to[k]])
      for (int c = 0; c < components; ++c) send[k].push_back(x[static_cast<Eigen::Index>(i) * components + c]);
  for (std::size_t k = 0; k < sources.size(); ++k)
    got[k].resize(recvGhost_[sources[k]].size() * static_cast<std::size_t>(components));
  comm_.exchange(to, send, sources, got);
  for (std::size_t k = 0; k < sources.size(); ++k) {
    const std::vector<Index>& ghosts = recvGhost_[sources[k]];
    for (std::size_t j = 0; j < ghosts.size(); ++j)
      for (int c = 0; c < components; ++c) x[static_cast<Eigen::Index>(ghosts[j]) * components + c] = got[k][j * components + c];
  }
}

void HaloExchange::accumulate(Eigen::VectorXd& x, int components) const {
  if (components < 1 || x.size() != static_cast<Eigen::Index>(numLocal()) * components)
    throw Error("halo exchange: a vector of " + std::to_string(x.size()) + " values for " + std::to_string(numLocal()) +
                " vertices of " + std::to_string(components) + " components");
  // the messages of update() in the other direction: ghosts to their owners
  std::vector<std::vector<double>> send(recvRanks_.size()), got(sendRanks_.size());
  for (std::size_t k = 0; k < recvRanks_.size(); ++k)
    for (Index i : recvGhost_[recvRanks_[k]])
      for (int c = 0; c < components; ++c) send[k].push_back(x[static_cast<Eigen::Index>(i) * components + c]);
  for (std::size_t k = 0; k < sendRanks_.size(); ++k)
    got[k].resize(sendOwned_[sendRanks_[k]].size() * static_cast<std::size_t>(components));
  comm_.exchange(recvRanks_, send, sendRanks_, got);
  for (std::size_t k = 0; k < sendRanks_.size(); ++k) {
    const std::vector<Index>& owned = sendOwned_[sendRanks_[k]];
    for (std::size_t j = 0; j < owned.size(); ++j)
      for (int c = 0; c < components; ++c) x[static_cast<Eigen::Index>(owned[j]) * components + c] += got[k][j * components + c];
  }
  x.tail(static_cast<Eigen::Index>(numLocal() - numOwned()) * components).setZero();
}

mesh::Mesh localMesh(const mesh::GridView& view, const PartView& part, const HaloExchange& halo) {
  const mesh::Mesh& vm = view.mesh;
  mesh::Mesh m(vm.dimension());
  for (Index v : halo.viewVertices()) m.addVertex(vm.vertex(v));
  std::vector<Index> local;
  for (const std::vector<Index>* cells : {&part.owned, &part.ghosts})
    for (Index c : *cells) {
      local.clear();
      for (Index v : vm.cellVertices(c)) {
        const Index l = halo.local(v);
        if (l < 0) throw Error("local mesh: a vertex of cell " + std::to_string(c) + " is not held");
        local.push_back(l);
      }
      m.addCell(vm.cellType(c), local);
    }
  // the boundary faces on held vertices (with their ids and names): every face around an owned
  // vertex; a ghost vertex at the edge of the ghost layer may lie on faces with vertices not held,
  // so it is marked on their boundaries (Mesh::addBoundaryVertex) as the whole view marks it
  std::set<std::pair<Index, int>> partial;
  for (Index f = 0; f < vm.numBoundaryFaces(); ++f) {
    local.clear();
    for (Index v : vm.boundaryFaceVertices(f)) local.push_back(halo.local(v));
    if (std::all_of(local.begin(), local.end(), [](Index l) { return l >= 0; })) {
      m.addBoundaryFace(local, vm.boundaryFaceId(f));
    } else {
      for (Index l : local)
        if (l >= 0) partial.emplace(l, vm.boundaryFaceId(f));
    }
  }
  for (const auto& [l, id] : partial) m.addBoundaryVertex(l, id);
  for (const auto& [id, name] : vm.boundaryNames()) m.setBoundaryName(id, name);
  return m;
}

}  // namespace obs
