#pragma once
/// \file GridCheck.hpp
/// A reusable consistency check of a mesh::Grid (in the spirit of dune-grid's gridcheck), shared by
/// the mesh tests and by every test that adapts a grid (estimators: after each step of an
/// AdaptiveLoop). It checks with GoogleTest expectations:
///  - every view (leaf and levels) is a conforming mesh: no hanging, non-manifold, misoriented or
///    unmatched faces (checkConformity), positively oriented cells, no vertex at the midpoint of a
///    cell edge or the centre of a quadrilateral face (hanging vertices found geometrically);
///  - the views tile the domain: total volume and boundary measure per id equal the reference;
///  - the hierarchy: levels of fathers and children, green children only below green closures,
///    green elements never refined, children inside their father (geometryInFather mapped by the
///    father's geometry gives the child's corners), and the children's volumes add up to the
///    father's (for green children only if the father's faces are planar).
/// The reference volume and boundary measures default to those of the coarse mesh, which is right
/// for grids without boundary projection; grids with curved boundaries pass GridCheckOptions with
/// `geometry = false` (the topological and hierarchical checks still run).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/mesh/ReferenceElement.hpp"

namespace obs::test {

using mesh::CellType;
using mesh::Grid;
using mesh::Index;
using mesh::Mesh;
using mesh::Point;

/// Signed volume of element e of the grid.
inline double volume(const Grid& g, Index e) {
  std::vector<Point> x;
  for (Index v : g.vertices(e)) x.push_back(g.vertex(v));
  return mesh::signedMeasure(g.type(e), x);
}

/// Geometry map of element e at reference coordinates xi.
inline Point mapPoint(const Grid& g, Index e, const Point& xi) {
  const mesh::ReferenceElement& ref = mesh::referenceElement(g.type(e));
  std::vector<double> phi(ref.numVertices);
  ref.values(xi, phi);
  Point x = Point::Zero();
  for (int i = 0; i < ref.numVertices; ++i) x += phi[i] * g.vertex(g.vertices(e)[i]);
  return x;
}

/// One view: conformity, orientation, no hanging vertices; with `measures` also its volume and
/// boundary measures per id.
inline void checkView(const Mesh& m, double vol, const std::map<int, double>& area, const std::string& what,
                      bool measures = true) {
  const mesh::ConformityReport r = mesh::checkConformity(m);
  EXPECT_TRUE(r.conforming()) << what << ": hanging " << r.hangingFaces << " nonmanifold "
                              << r.nonManifoldFaces << " misoriented " << r.misorientedFaces
                              << " unmatched " << r.unmatchedBoundaryFaces;
  Index inverted = 0;
  for (Index c = 0; c < m.numCells(); ++c) inverted += !mesh::isPositivelyOriented(m, c);
  EXPECT_EQ(inverted, 0) << what;
  // No hanging vertices, checked geometrically: no vertex at the midpoint of a cell edge or at the
  // centre of a quadrilateral face.
  std::set<std::array<long long, 3>> at;
  auto key = [](const Point& x) {
    return std::array<long long, 3>{std::llround(x[0] * 1e9), std::llround(x[1] * 1e9),
                                    std::llround(x[2] * 1e9)};
  };
  for (const Point& x : m.vertices()) at.insert(key(x));
  Index hanging = 0;
  for (Index c = 0; c < m.numCells(); ++c) {
    const auto cv = m.cellVertices(c);
    for (const auto& e : mesh::localEdges(m.cellType(c)))
      hanging += at.count(key(0.5 * (m.vertex(cv[e[0]]) + m.vertex(cv[e[1]]))));
    if (m.dimension() == 3)
      for (const mesh::LocalFace& f : mesh::localFaces(m.cellType(c)))
        if (f.size == 4) {
          Point s = Point::Zero();
          for (int k = 0; k < 4; ++k) s += 0.25 * m.vertex(cv[f.vertices[k]]);
          hanging += at.count(key(s));
        }
  }
  EXPECT_EQ(hanging, 0) << what;
  if (!measures) return;
  EXPECT_NEAR(mesh::totalVolume(m), vol, 1e-12 * vol) << what;
  const auto a = mesh::boundaryMeasureById(m);
  ASSERT_EQ(a.size(), area.size()) << what;
  for (const auto& [id, value] : area) EXPECT_NEAR(a.at(id), value, 1e-12 * value) << what << " id " << id;
}

/// Every invariant of the grid: views, hierarchy, children inside their fathers (corners at the
/// father's geometry map of geometryInFather) and tiling them (green children only if the father
/// has planar faces: `planar`).
inline void checkGrid(const Grid& g, double vol, const std::map<int, double>& area, bool planar = true,
                      bool measures = true) {
  checkView(g.leafMesh(), vol, area, "leaf view", measures);
  for (int l = 0; l <= g.maxLevel(); ++l)
    checkView(g.levelMesh(l), vol, area, "level " + std::to_string(l), measures);
  for (Index e = 0; e < g.numElements(); ++e) {
    if (g.isRemoved(e)) continue;
    if (g.level(e) > 0) {
      const Index f = g.father(e);
      EXPECT_EQ(g.level(e), g.level(f) + 1);
      EXPECT_EQ(g.isGreen(e), g.refinement(f) == mesh::Refinement::Green);
      const auto xi = g.geometryInFather(e);
      for (std::size_t i = 0; i < xi.size(); ++i) {
        EXPECT_TRUE(mesh::insideReferenceElement(g.type(f), xi[i], 1e-14)) << e;
        EXPECT_NEAR((mapPoint(g, f, xi[i]) - g.vertex(g.vertices(e)[i])).norm(), 0, 1e-12) << e;
      }
    }
    if (g.numChildren(e) > 0) {
      EXPECT_NE(g.refinement(e), mesh::Refinement::None);
      EXPECT_FALSE(g.isGreen(e)) << "green elements are never refined";
      double sum = 0;
      for (int k = 0; k < g.numChildren(e); ++k) {
        EXPECT_EQ(g.father(g.child(e, k)), e);
        EXPECT_FALSE(g.isRemoved(g.child(e, k)));
        sum += volume(g, g.child(e, k));
      }
      if (planar || g.refinement(e) == mesh::Refinement::Red) {
        // exact up to the rounding of the vertex coordinates: a cell of size h at distance |x| from
        // the origin has relative volume errors of about d eps |x| / h (deep local refinement)
        const double v = volume(g, e);
        double far = 0;
        for (Index p : g.vertices(e)) far = std::max(far, g.vertex(p).template lpNorm<Eigen::Infinity>());
        const int dim = mesh::dimension(g.type(e));
        const double h = std::pow(v, 1.0 / dim);
        const double rounding = 8 * dim * std::numeric_limits<double>::epsilon() * far / h;
        EXPECT_NEAR(sum, v, std::max(1e-12, rounding) * v) << e;
      }
    }
  }
}


/// checkGrid against the coarse mesh's volume and boundary measures (grids without boundary
/// projection); with `geometry` false only the topological and hierarchical checks run.
inline void checkGrid(const Grid& g, bool geometry = true) {
  const Mesh coarse = g.levelMesh(0);
  if (geometry) {
    checkGrid(g, mesh::totalVolume(coarse), mesh::boundaryMeasureById(coarse));
    return;
  }
  checkGrid(g, 0, {}, false, false);  // topology and hierarchy only
}

/// Marks and adapts `cycles` times the leaves whose centroid lies within `radius` of `centre`
/// (radius multiplied by `shrink` after each cycle), checking the grid after every adapt().
inline void refineNear(Grid& grid, const Point& centre, double radius, int cycles, double shrink = 1.0) {
  for (int c = 0; c < cycles; ++c) {
    for (Index e : grid.leafElements()) {
      Point x = Point::Zero();
      for (Index v : grid.vertices(e)) x += grid.vertex(v) / static_cast<double>(grid.vertices(e).size());
      if ((x - centre).norm() < radius) grid.mark(e);
    }
    grid.adapt();
    checkGrid(grid);
    radius *= shrink;
  }
}

}  // namespace obs::test
