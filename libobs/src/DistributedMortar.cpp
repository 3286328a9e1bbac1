#include "obs/obs/DistributedMortar.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <sstream>

#include "obs/mesh/Error.hpp"

namespace obs {
namespace {

using Box = Eigen::AlignedBox3d;

Box faceBox(const mesh::Mesh& m, Index f) {
  Box b;
  for (Index v : m.boundaryFaceVertices(f)) b.extend(m.vertex(v));
  return b;
}

double largestCoordinate(const Box& b) {
  return b.isEmpty() ? 0.0 : std::max(b.min().cwiseAbs().maxCoeff(), b.max().cwiseAbs().maxCoeff());
}

/// The cell of `m` that has every vertex of boundary face f (-1: none).
Index cellOfFace(const mesh::Mesh& m, const mesh::VertexCells& around, Index f) {
  const auto fv = m.boundaryFaceVertices(f);
  for (Index c : around.cellsOf(fv[0])) {
    const auto cv = m.cellVertices(c);
    if (std::all_of(fv.begin(), fv.end(), [&](Index v) { return std::find(cv.begin(), cv.end(), v) != cv.end(); }))
      return c;
  }
  return -1;
}

/// The global vertex index of local vertex v of a distributed view.
Index globalOf(const DistributedView& view, Index v) {
  return view.numbering.global[static_cast<std::size_t>(view.halo.viewVertices()[static_cast<std::size_t>(v)])];
}

}  // namespace

DistributedMortar::DistributedMortar(const DistributedMortarSurface& slave, const DistributedMortarSurface& master,
                                     const MortarOptions& options)
    : comm_(slave.view ? slave.view->halo.communicator() : Communicator::world()) {
  const std::string label = slave.label + " / " + master.label;
  if (!slave.view || !master.view) throw Error("mortar coupling " + label + ": missing view");
  const Communicator& comm = slave.view->halo.communicator();
  const mesh::Mesh& sm = slave.view->local;
  const mesh::Mesh& mm = master.view->local;
  const int dim = sm.dimension();
  if (mm.dimension() != dim)
    throw Error("mortar coupling " + label + ": the slave mesh has dimension " + std::to_string(dim) +
                ", the master mesh " + std::to_string(mm.dimension()));
  const Index slaveOwned = slave.view->halo.numOwned();
  const auto ownedMasterCells = static_cast<Index>(master.view->part.owned.size());

  // 1. this rank's slave faces (those with an owned vertex) and the master faces of its owned cells
  std::vector<Index> slaveFaces, masterFaces, masterCells;
  Box slaveBox, masterBox;
  double largestSlaveFace = 0;
  comm.collective([&] {
    for (Index f = 0; f < sm.numBoundaryFaces(); ++f) {
      if (sm.boundaryFaceId(f) != slave.boundaryId) continue;
      const auto fv = sm.boundaryFaceVertices(f);
      if (std::none_of(fv.begin(), fv.end(), [&](Index v) { return v < slaveOwned; })) continue;
      slaveFaces.push_back(f);
      const Box b = faceBox(sm, f);
      slaveBox.extend(b);
      largestSlaveFace = std::max(largestSlaveFace, b.diagonal().norm());
    }
    const mesh::VertexCells around = mesh::vertexCells(mm);
    for (Index f = 0; f < mm.numBoundaryFaces(); ++f) {
      if (mm.boundaryFaceId(f) != master.boundaryId) continue;
      const Index c = cellOfFace(mm, around, f);
      if (c < 0 || c >= ownedMasterCells) continue;  // sent by the rank that owns the cell
      masterFaces.push_back(f);
      masterCells.push_back(c);
      masterBox.extend(faceBox(mm, f));
    }
  });

  // 2. extents of the whole surfaces: boxes (as maxima of max and -min), largest face, coordinate
  std::vector<double> ext(16);
  for (int a = 0; a < 3; ++a) {
    ext[a] = slaveBox.isEmpty() ? -std::numeric_limits<double>::infinity() : -slaveBox.min()[a];
    ext[3 + a] = slaveBox.isEmpty() ? -std::numeric_limits<double>::infinity() : slaveBox.max()[a];
    ext[6 + a] = masterBox.isEmpty() ? -std::numeric_limits<double>::infinity() : -masterBox.min()[a];
    ext[9 + a] = masterBox.isEmpty() ? -std::numeric_limits<double>::infinity() : masterBox.max()[a];
  }
  ext[12] = largestSlaveFace;
  ext[13] = std::max(largestCoordinate(slaveBox), largestCoordinate(masterBox));
  ext[14] = slaveFaces.empty() ? 0.0 : 1.0;  // some rank has a face of the surface
  ext[15] = masterFaces.empty() ? 0.0 : 1.0;
  comm.max(ext);
  if (ext[14] == 0) throw Error("mortar surface " + slave.label + ": no boundary face has this id");
  if (ext[15] == 0) throw Error("mortar surface " + master.label + ": no boundary face has this id");
  Box wholeSlave, wholeMaster;
  for (int a = 0; a < 3; ++a) {
    wholeSlave.min()[a] = -ext[a];
    wholeSlave.max()[a] = ext[3 + a];
    wholeMaster.min()[a] = -ext[6 + a];
    wholeMaster.max()[a] = ext[9 + a];
  }
  search_ = options.searchDistance > 0 ? options.searchDistance
                                       : defaultMortarSearchDistance(wholeSlave.diagonal().norm(), ext[12]);

  // 3. the ranks' search boxes, then each owned master face (with its cell) to the ranks it meets
  std::vector<double> mine;
  if (!slaveBox.isEmpty()) {
    for (int a = 0; a < 3; ++a) mine.push_back(slaveBox.min()[a] - search_);
    for (int a = 0; a < 3; ++a) mine.push_back(slaveBox.max()[a] + search_);
  }
  const std::vector<std::vector<double>> boxes = comm.allGather(mine);
  std::vector<std::vector<double>> send(static_cast<std::size_t>(comm.size()));
  for (std::size_t i = 0; i < masterFaces.size(); ++i) {
    const Index f = masterFaces[i], c = masterCells[i];
    const Box fb = faceBox(mm, f);
    const auto cv = mm.cellVertices(c);
    const auto fv = mm.boundaryFaceVertices(f);
    for (int r = 0; r < comm.size(); ++r) {
      const auto& b = boxes[static_cast<std::size_t>(r)];
      if (b.size() != 6) continue;  // no slave face there
      if (!fb.intersects(Box(Point(b[0], b[1], b[2]), Point(b[3], b[4], b[5])))) continue;
      auto& out = send[static_cast<std::size_t>(r)];
      out.push_back(static_cast<double>(static_cast<int>(mm.cellType(c))));
      out.push_back(static_cast<double>(cv.size()));
      for (Index v : cv) {
        out.push_back(static_cast<double>(master.globalOffset + globalOf(*master.view, v)));
        for (int a = 0; a < 3; ++a) out.push_back(mm.vertex(v)[a]);
      }
      out.push_back(static_cast<double>(fv.size()));
      for (Index v : fv) out.push_back(static_cast<double>(std::find(cv.begin(), cv.end(), v) - cv.begin()));
    }
  }
  const std::vector<std::vector<double>> received = comm.exchange(send);
  send.clear();

  // 4. the local coupling: this rank's slave surface against the master faces it received
  comm.collective([&] {
    mesh::Mesh masterPart(dim);
    std::vector<Index> masterGlobal;   // masterPart vertex -> global stacked index
    std::map<Index, Index> partVertex;  // global stacked index -> masterPart vertex
    for (const auto& in : received) {
      std::size_t i = 0;
      while (i < in.size()) {
        const auto type = static_cast<mesh::CellType>(static_cast<int>(in[i]));
        const auto n = static_cast<std::size_t>(in[i + 1]);
        i += 2;
        std::vector<Index> cell(n);
        for (std::size_t k = 0; k < n; ++k, i += 4) {
          const auto g = static_cast<Index>(in[i]);
          auto [it, inserted] = partVertex.emplace(g, masterPart.numVertices());
          if (inserted) {
            masterPart.addVertex(Point(in[i + 1], in[i + 2], in[i + 3]));
            masterGlobal.push_back(g);
          }
          cell[k] = it->second;
        }
        masterPart.addCell(type, cell);
        const auto nf = static_cast<std::size_t>(in[i]);
        ++i;
        std::vector<Index> face(nf);
        for (std::size_t k = 0; k < nf; ++k) face[k] = cell[static_cast<std::size_t>(in[i + k])];
        i += nf;
        masterPart.addBoundaryFace(face, master.boundaryId);
        ++receivedMasterFaces_;
      }
    }
    if (slaveFaces.empty() || receivedMasterFaces_ == 0) return;

    // the slave side: the local vertices (so that a slave node is its local vertex), the cells
    // around the surface's vertices (the orientation of its faces) and the faces of step 1
    mesh::Mesh slavePart(dim);
    std::vector<char> onSurface(static_cast<std::size_t>(sm.numVertices()), 0);
    for (Index f : slaveFaces)
      for (Index v : sm.boundaryFaceVertices(f)) onSurface[static_cast<std::size_t>(v)] = 1;
    for (Index v = 0; v < sm.numVertices(); ++v) slavePart.addVertex(sm.vertex(v));
    for (Index c = 0; c < sm.numCells(); ++c) {
      const auto cv = sm.cellVertices(c);
      if (std::any_of(cv.begin(), cv.end(), [&](Index v) { return onSurface[static_cast<std::size_t>(v)] != 0; }))
        slavePart.addCell(sm.cellType(c), cv);
    }
    for (Index f : slaveFaces) slavePart.addBoundaryFace(sm.boundaryFaceVertices(f), slave.boundaryId);

    MortarOptions local = options;
    local.searchDistance = search_;
    local.coordinateScale = ext[13];
    local.requireCoverage = false;
    const Index n = slavePart.numVertices() + masterPart.numVertices();
    const MortarCoupling coupling({&slavePart, slave.boundaryId, 0, slave.label},
                                  {&masterPart, master.boundaryId, slavePart.numVertices(), master.label}, n, local);
    stats_ = coupling.statistics();
    const Index rankOffset = slave.view->numbering.offsets[static_cast<std::size_t>(comm.rank())];
    std::vector<Index> columns;
    for (Index k = 0; k < coupling.size(); ++k) {
      const Index v = coupling.vertex(k);
      if (v >= slaveOwned) continue;  // a ghost's row: its owner computes it whole
      Row row;
      row.local = v;
      row.global = slave.globalOffset + rankOffset + v;
      row.position = sm.vertex(v);
      row.normal = coupling.normal(k);
      row.D = coupling.D(k);
      row.mass = coupling.slaveMass(k);
      row.gap = coupling.weightedGap(k);
      for (const MortarCoupling::Entry& e : coupling.row(k)) {
        const Index q = masterGlobal[static_cast<std::size_t>(e.vertex - slavePart.numVertices())];
        row.entries.push_back({q, e.value});
        columns.push_back(q);
      }
      std::sort(row.entries.begin(), row.entries.end(),
                [](const MortarCoupling::Entry& a, const MortarCoupling::Entry& b) { return a.vertex < b.vertex; });
      rows_.push_back(std::move(row));
    }
    std::sort(columns.begin(), columns.end());
    columns.erase(std::unique(columns.begin(), columns.end()), columns.end());
    masterVertices_ = columns;
    for (Index q : columns) masterPositions_.push_back(masterPart.vertex(partVertex.at(q)));
  });

  globalSize_ = comm.sum(static_cast<long long>(rows_.size()));
  if (globalSize_ == 0) {
    std::ostringstream os;
    os << "mortar coupling " << label << ": the master surface covers no slave node (the surfaces do not overlap;"
       << " distance between their bounding boxes " << wholeSlave.exteriorDistance(wholeMaster) << ", search distance "
       << search_ << ")";
    throw Error(os.str());
  }

  // 5. the master-column exchange: each column's owner (from the master view's offsets) learns
  //    which of its vertices this rank needs
  const std::vector<Index>& offsets = master.view->numbering.offsets;
  masterLocalSize_ = master.view->halo.numLocal();
  askedColumns_.assign(static_cast<std::size_t>(comm.size()), {});
  std::vector<std::vector<double>> ask(static_cast<std::size_t>(comm.size()));
  for (std::size_t i = 0; i < masterVertices_.size(); ++i) {
    const Index g = masterVertices_[i] - master.globalOffset;
    const auto owner = static_cast<std::size_t>(std::upper_bound(offsets.begin(), offsets.end(), g) - offsets.begin() - 1);
    askedColumns_[owner].push_back(static_cast<Index>(i));
    ask[owner].push_back(static_cast<double>(g - offsets[owner]));  // the owner's local index
  }
  const std::vector<std::vector<double>> asked = comm.exchange(ask);
  sentOwned_.assign(static_cast<std::size_t>(comm.size()), {});
  for (std::size_t r = 0; r < asked.size(); ++r)
    for (double v : asked[r]) sentOwned_[r].push_back(static_cast<Index>(v));
}

void DistributedMortar::checkSize(const Eigen::VectorXd& v, Eigen::Index expected, const char* what) const {
  if (v.size() != expected)
    throw Error(std::string("distributed mortar: ") + what + " has " + std::to_string(v.size()) + " entries, expected " +
                std::to_string(expected));
}

void DistributedMortar::exchangeColumns(bool towardOwners, int components,
                                        const std::function<std::vector<double>(std::size_t)>& pack,
                                        const std::function<void(std::size_t, const std::vector<double>&)>& use) const {
  // gather: owners send the values of sentOwned_[r] to rank r, which reads them into askedColumns_[r];
  // add: the other way round
  const std::vector<std::vector<Index>>& out = towardOwners ? askedColumns_ : sentOwned_;
  const std::vector<std::vector<Index>>& in = towardOwners ? sentOwned_ : askedColumns_;
  const int me = comm_.rank();
  std::vector<int> to, from;
  std::vector<std::vector<double>> send, recv;
  for (int r = 0; r < comm_.size(); ++r) {
    const auto ru = static_cast<std::size_t>(r);
    if (r == me) continue;
    if (!out[ru].empty()) {
      to.push_back(r);
      send.push_back(pack(ru));
    }
    if (!in[ru].empty()) {
      from.push_back(r);
      recv.emplace_back(in[ru].size() * static_cast<std::size_t>(components));
    }
  }
  comm_.exchange(to, send, from, recv);
  // in rank order, this rank's own part in its place, so that sums do not depend on timing
  std::size_t k = 0;
  for (int r = 0; r < comm_.size(); ++r) {
    const auto ru = static_cast<std::size_t>(r);
    if (r == me)
      use(ru, pack(ru));
    else if (k < from.size() && from[k] == r)
      use(ru, recv[k++]);
  }
}

Eigen::VectorXd DistributedMortar::gatherMaster(const Eigen::VectorXd& masterLocal, int components) const {
  checkSize(masterLocal, static_cast<Eigen::Index>(masterLocalSize_) * components, "the master vector");
  Eigen::VectorXd out(static_cast<Eigen::Index>(masterVertices_.size()) * components);
  exchangeColumns(
      false, components,
      [&](std::size_t r) {
        std::vector<double> m;
        m.reserve(sentOwned_[r].size() * static_cast<std::size_t>(components));
        for (Index v : sentOwned_[r])
          for (int a = 0; a < components; ++a) m.push_back(masterLocal[static_cast<Eigen::Index>(v) * components + a]);
        return m;
      },
      [&](std::size_t r, const std::vector<double>& m) {
        std::size_t k = 0;
        for (Index i : askedColumns_[r])
          for (int a = 0; a < components; ++a) out[static_cast<Eigen::Index>(i) * components + a] = m[k++];
      });
  return out;
}

void DistributedMortar::addToMaster(const Eigen::VectorXd& columnValues, Eigen::VectorXd& masterLocal,
                                    int components) const {
  checkSize(columnValues, static_cast<Eigen::Index>(masterVertices_.size()) * components, "the column values");
  checkSize(masterLocal, static_cast<Eigen::Index>(masterLocalSize_) * components, "the master vector");
  exchangeColumns(
      true, components,
      [&](std::size_t r) {
        std::vector<double> m;
        m.reserve(askedColumns_[r].size() * static_cast<std::size_t>(components));
        for (Index i : askedColumns_[r])
          for (int a = 0; a < components; ++a) m.push_back(columnValues[static_cast<Eigen::Index>(i) * components + a]);
        return m;
      },
      [&](std::size_t r, const std::vector<double>& m) {
        std::size_t k = 0;
        for (Index v : sentOwned_[r])
          for (int a = 0; a < components; ++a) masterLocal[static_cast<Eigen::Index>(v) * components + a] += m[k++];
      });
}

Eigen::VectorXd DistributedMortar::applyTransformation(const Eigen::VectorXd& masterLocal, int components) const {
  const Eigen::VectorXd x = gatherMaster(masterLocal, components);
  Eigen::VectorXd out = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(rows_.size()) * components);
  for (std::size_t k = 0; k < rows_.size(); ++k) {
    const Row& row = rows_[k];
    for (const MortarCoupling::Entry& e : row.entries) {
      const auto i = std::lower_bound(masterVertices_.begin(), masterVertices_.end(), e.vertex) - masterVertices_.begin();
      for (int a = 0; a < components; ++a)
        out[static_cast<Eigen::Index>(k) * components + a] += e.value / row.D * x[i * components + a];
    }
  }
  return out;
}

void DistributedMortar::addTransposedTransformation(const Eigen::VectorXd& rowValues, Eigen::VectorXd& masterLocal,
                                                    int components) const {
  checkSize(rowValues, static_cast<Eigen::Index>(rows_.size()) * components, "the row values");
  Eigen::VectorXd columns = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(masterVertices_.size()) * components);
  for (std::size_t k = 0; k < rows_.size(); ++k) {
    const Row& row = rows_[k];
    for (const MortarCoupling::Entry& e : row.entries) {
      const auto i = std::lower_bound(masterVertices_.begin(), masterVertices_.end(), e.vertex) - masterVertices_.begin();
      for (int a = 0; a < components; ++a)
        columns[i * components + a] += e.value / row.D * rowValues[static_cast<Eigen::Index>(k) * components + a];
    }
  }
  addToMaster(columns, masterLocal, components);
}

}  // namespace obs
