// Hierarchical grid: uniform refinement (counts and cells equal to refineUniformly), random local
// refinement with green closure, also of distorted meshes (conformity of leaf and level views, no
// hanging vertices, volume, orientation, boundary ids and measures, hierarchy and geometry in
// father), shape regularity under repeated refinement at a corner, determinism, marking of green
// elements, boundary projection and face neighbours; parameterised over all six cell types and the
// mixed 3D mesh.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <random>
#include <set>

#include "obs/mesh/BoxMesh.hpp"
#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/Prolongation.hpp"
#include "obs/mesh/RedRefinement.hpp"
#include "obs/mesh/ReferenceElement.hpp"

#include "../GridCheck.hpp"

using namespace obs::mesh;
using obs::test::checkGrid;
using obs::test::checkView;

namespace {

struct GridCase {
  std::string name;
  std::function<Mesh()> make;
};
/// Prints the case by name (otherwise GoogleTest dumps its bytes into every test's listing).
void PrintTo(const GridCase& c, std::ostream* os) { *os << c.name; }

std::vector<GridCase> gridCases() {
  std::vector<GridCase> out;
  for (CellType t : kVolumeCellTypes)
    out.push_back({std::string(name(t)), [t] {
                     return boxMesh(t, {2, 2, 2}, Point(0, 0, 0), Point(2, 1.5, 1));
                   }});
  out.push_back({"mixed", [] { return mixedBoxMesh3D({2, 2, 4}, Point::Zero(), Point(1, 1, 2)); }});
  return out;
}

std::vector<Point> corners(const Grid& g, Index e) {
  std::vector<Point> x;
  for (Index v : g.vertices(e)) x.push_back(g.vertex(v));
  return x;
}

}  // namespace

class GridTest : public ::testing::TestWithParam<GridCase> {};

TEST_P(GridTest, UniformRefinementMatchesRefineUniformly) {
  const Mesh coarse = GetParam().make();
  Grid g(coarse);
  const double vol = totalVolume(coarse);
  const auto area = boundaryMeasureById(coarse);
  Mesh flat = coarse;
  const int levels = coarse.dimension() == 2 ? 3 : 2;
  for (int k = 1; k <= levels; ++k) {
    const AdaptResult r = g.refineUniformly();
    flat = refineUniformly(flat);
    EXPECT_EQ(r.propagated, 0);
    EXPECT_EQ(r.greenClosed, 0);
    EXPECT_EQ(g.maxLevel(), k);
    const Mesh leaf = g.leafMesh();
    EXPECT_EQ(leaf.cellCounts(), flat.cellCounts());
    EXPECT_EQ(leaf.numVertices(), flat.numVertices());
    EXPECT_EQ(leaf.numBoundaryFaces(), flat.numBoundaryFaces());
    // Same cells: compare the sorted cell centroids.
    auto centroids = [](const Mesh& m) {
      std::vector<std::array<double, 4>> c;
      for (Index i = 0; i < m.numCells(); ++i) {
        Point s = Point::Zero();
        for (Index v : m.cellVertices(i)) s += m.vertex(v);
        s /= static_cast<double>(m.cellVertices(i).size());
        c.push_back({std::round(s[0] * 1e9), std::round(s[1] * 1e9), std::round(s[2] * 1e9),
                     static_cast<double>(m.cellType(i))});
      }
      std::sort(c.begin(), c.end());
      return c;
    };
    EXPECT_EQ(centroids(leaf), centroids(flat));
    checkGrid(g, vol, area);
  }
}

TEST_P(GridTest, ElementCountsAfterUniformRefinement) {
  const Mesh coarse = GetParam().make();
  Grid g(coarse);
  // Children per red refinement: 4 in 2D, 8 in 3D except the pyramid (6 pyramids + 4 tets).
  auto counts = coarse.cellCounts();
  const int levels = coarse.dimension() == 2 ? 4 : 2;
  for (int k = 1; k <= levels; ++k) {
    g.refineUniformly();
    std::array<Index, 7> next{};
    const int tri = 1, quad = 2, tet = 3, hex = 4, prism = 5, pyr = 6;
    next[tri] = 4 * counts[tri];
    next[quad] = 4 * counts[quad];
    next[tet] = 8 * counts[tet] + 4 * counts[pyr];
    next[hex] = 8 * counts[hex];
    next[prism] = 8 * counts[prism];
    next[pyr] = 6 * counts[pyr];
    counts = next;
    EXPECT_EQ(g.leafMesh().cellCounts(), counts) << "after " << k << " refinements";
  }
}

// Each cycle marks a random 10% of the leaves (every level, green leaves included). In 3D a
// closure touches many neighbours and 10% of all leaves multiplies the grid by 3-5 per cycle, so
// there at most 15 marks are kept per cycle (the first ones drawn) to keep the test fast.
TEST_P(GridTest, RandomLocalRefinementStaysConforming) {
  const Mesh coarse = GetParam().make();
  Grid g(coarse);
  const double vol = totalVolume(coarse);
  const auto area = boundaryMeasureById(coarse);
  const int cap = coarse.dimension() == 2 ? 1 << 30 : 15;
  std::mt19937 gen(2024);
  Index greenSeen = 0, removedSeen = 0, propagated = 0;
  for (int cycle = 0; cycle < 12; ++cycle) {
    int marked = 0;
    for (Index e : g.leafElements())
      if (gen() % 10 == 0 && marked < cap) {
        g.mark(e);
        ++marked;
      }
    const AdaptResult r = g.adapt();
    EXPECT_EQ(r.marked, marked);
    greenSeen += r.greenClosed;
    removedSeen += r.greenRemoved;
    propagated += r.propagated;
    EXPECT_EQ(r.invertedElements, 0);
    SCOPED_TRACE("cycle " + std::to_string(cycle));
    if (cycle % 4 == 3 || cycle == 11)
      checkGrid(g, vol, area);
    else
      checkView(g.leafMesh(), vol, area, "leaf view");
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_GT(greenSeen, 0);
  EXPECT_GT(removedSeen, 0);
  EXPECT_GT(propagated, 0);
}

// ClosureRule::AllEdges: the same random refinement stays conforming, no green father has all of
// its edges refined, and some have more than half (which the default rule refines red); with the
// default rule no green father has more than half of its edges refined.
TEST_P(GridTest, ClosureRulesDecideWhichPatternsAreClosedGreen) {
  const Mesh coarse = GetParam().make();
  const double vol = totalVolume(coarse);
  const auto area = boundaryMeasureById(coarse);
  const int cap = coarse.dimension() == 2 ? 1 << 30 : 15;
  for (ClosureRule rule : {ClosureRule::MoreThanHalfEdges, ClosureRule::AllEdges}) {
    const bool all = rule == ClosureRule::AllEdges;
    SCOPED_TRACE(all ? "all-edges" : "more-than-half");
    Grid g(coarse);
    g.setClosureRule(rule);
    EXPECT_EQ(g.closureRule(), rule);
    std::mt19937 gen(2024);
    int aboveHalf = 0;
    for (int cycle = 0; cycle < 8; ++cycle) {
      int marked = 0;
      for (Index e : g.leafElements())
        if (gen() % 10 == 0 && marked < cap) {
          g.mark(e);
          ++marked;
        }
      EXPECT_EQ(g.adapt().invertedElements, 0);
      for (Index e = 0; e < g.numElements(); ++e) {
        if (g.isRemoved(e) || g.refinement(e) != Refinement::Green) continue;
        const int refined = std::popcount(g.edgePattern(e));
        const int edges = static_cast<int>(localEdges(g.type(e)).size());
        EXPECT_LT(refined, edges) << "green father " << e;
        if (!all) {
          EXPECT_LE(2 * refined, edges) << "green father " << e;
        }
        aboveHalf += 2 * refined > edges;
      }
    }
    checkGrid(g, vol, area);
    if (all) {
      EXPECT_GT(aboveHalf, 0) << "the rule never mattered in this run";
    }
  }
}

// The same on distorted meshes (random interior vertex moves: non-planar faces, non-affine cells).
TEST_P(GridTest, RandomLocalRefinementOfDistortedMeshes) {
  Mesh coarse = GetParam().name == "mixed"
                    ? mixedBoxMesh3D({3, 3, 5}, Point::Zero(), Point(1, 1, 2))
                    : boxMesh(GetParam().make().cellType(0), {3, 3, 3}, Point::Zero(), Point(2, 1.5, 1));
  perturbInteriorVertices(coarse, 0.3, 17);
  Grid g(coarse);
  const double vol = totalVolume(coarse);
  const auto area = boundaryMeasureById(coarse);
  std::mt19937 gen(99);
  for (int cycle = 0; cycle < 8; ++cycle) {
    int marked = 0;
    for (Index e : g.leafElements())
      if (gen() % 10 == 0 && marked < 10) {
        g.mark(e);
        ++marked;
      }
    EXPECT_EQ(g.adapt().invertedElements, 0);
  }
  checkGrid(g, vol, area, false);
}

TEST_P(GridTest, ShapeRegularityUnderCornerRefinement) {
  const Mesh coarse = GetParam().make();
  Grid g(coarse);
  auto minQuality = [&] {
    double q = 1;
    for (Index e : g.leafElements()) q = std::min(q, shapeQuality(g.type(e), corners(g, e)));
    return q;
  };
  const double q0 = minQuality();
  for (int cycle = 0; cycle < 10; ++cycle) {
    for (Index e : g.leafElements())
      for (Index v : g.vertices(e))
        if (g.vertex(v).norm() < 1e-12) g.mark(e);
    g.adapt();
  }
  const double q = minQuality();
  std::printf("[ quality ] %-13s coarse %.4f  after 10 corner refinements %.4f  factor %.3f  "
              "(leaves %d, levels %d)\n",
              GetParam().name.c_str(), q0, q, q / q0, g.numLeafElements(), g.maxLevel());
  EXPECT_GE(g.maxLevel(), 10);
  // Measured factors (min quality after / before): triangle 0.474, quadrilateral 0.562,
  // tetrahedron 0.374, hexahedron 0.390, prism 0.329, pyramid 0.329, mixed 0.511.
  EXPECT_GT(q / q0, 0.25);
  checkView(g.leafMesh(), totalVolume(coarse), boundaryMeasureById(coarse), "leaf view");
}

TEST_P(GridTest, DeterministicForEqualMarks) {
  auto run = [&] {
    Grid g(GetParam().make());
    std::mt19937 gen(7);
    for (int cycle = 0; cycle < 5; ++cycle) {
      int marked = 0;
      for (Index e : g.leafElements())
        if (gen() % 5 == 0 && marked < 25) {
          g.mark(e);
          ++marked;
        }
      g.adapt();
    }
    return g.leafMesh();
  };
  const Mesh a = run(), b = run();
  ASSERT_EQ(a.numVertices(), b.numVertices());
  ASSERT_EQ(a.numCells(), b.numCells());
  for (Index v = 0; v < a.numVertices(); ++v) EXPECT_EQ(a.vertex(v), b.vertex(v));
  for (Index c = 0; c < a.numCells(); ++c) {
    const auto x = a.cellVertices(c), y = b.cellVertices(c);
    EXPECT_TRUE(std::equal(x.begin(), x.end(), y.begin(), y.end()));
  }
}

/// Every array of two grids, bit for bit: vertices (position, boundary flag, origin) and elements
/// (type, level, flags, refinement, father, children, vertices, points in the father, boundary ids).
void expectSameGrid(const Grid& a, const Grid& b) {
  ASSERT_EQ(a.numVertices(), b.numVertices());
  ASSERT_EQ(a.numElements(), b.numElements());
  EXPECT_EQ(a.maxLevel(), b.maxLevel());
  Index differentVertices = 0, differentElements = 0;
  for (Index v = 0; v < a.numVertices(); ++v) {
    const auto oa = a.vertexOrigin(v), ob = b.vertexOrigin(v);
    differentVertices += std::memcmp(a.vertex(v).data(), b.vertex(v).data(), 3 * sizeof(double)) != 0 ||
                         a.isBoundaryVertex(v) != b.isBoundaryVertex(v) || oa.element != ob.element ||
                         oa.point != ob.point;
  }
  for (Index e = 0; e < a.numElements(); ++e) {
    bool same = a.type(e) == b.type(e) && a.level(e) == b.level(e) && a.isGreen(e) == b.isGreen(e) &&
                a.isRemoved(e) == b.isRemoved(e) && a.refinement(e) == b.refinement(e) &&
                a.father(e) == b.father(e) && a.numChildren(e) == b.numChildren(e) &&
                (a.numChildren(e) == 0 || a.child(e, 0) == b.child(e, 0));
    if (same) {
      const auto va = a.vertices(e), vb = b.vertices(e);
      same = std::equal(va.begin(), va.end(), vb.begin(), vb.end());
    }
    if (same && e >= 0 && a.level(e) > 0) {
      const auto pa = a.pointsInFather(e), pb = b.pointsInFather(e);
      same = std::equal(pa.begin(), pa.end(), pb.begin(), pb.end());
    }
    if (same && !a.isRemoved(e))
      for (int f = 0; f < static_cast<int>(localFaces(a.type(e)).size()); ++f)
        same = same && a.boundaryId(e, f) == b.boundaryId(e, f);
    differentElements += !same;
  }
  EXPECT_EQ(differentVertices, 0);
  EXPECT_EQ(differentElements, 0);
}

/// Marks the leaves of `one` whose first vertex lies in the ball of `radius` around the origin, in
/// both grids (which have the same leaves).
void markBall(Grid& one, Grid& two, double radius) {
  for (Index e : one.leafElements())
    if (one.vertex(one.vertices(e)[0]).norm() < radius) {
      one.mark(e);
      two.mark(e);
    }
}

// The red refinement on threads (adapt(2), from 2,048 red elements on) builds the grid of one
// thread, bit for bit: uniform refinements to at least 16,384 leaves, then two cycles of local
// refinement marking the leaves whose first vertex lies in a ball around the origin (radius 1: green
// closures around it; then 1.2: their green fathers refined red; propagation in both). The grids of
// one thread are checked for conformity by the tests above.
TEST_P(GridTest, RedRefinementOnThreadsGivesTheGridOfOneThread) {
  Grid one(GetParam().make()), two(GetParam().make());
  while (one.numLeafElements() < 16384) {
    one.refineUniformly(1);
    two.refineUniformly(2);
  }
  expectSameGrid(one, two);
  Index greenClosed = 0, greenRemoved = 0;
  for (const double radius : {1.0, 1.2}) {
    ASSERT_EQ(one.leafElements(), two.leafElements());
    markBall(one, two, radius);
    const AdaptResult r1 = one.adapt(1), r2 = two.adapt(2);
    EXPECT_GE(r1.redRefined, 2048);  // on threads
    EXPECT_EQ(r1.redRefined, r2.redRefined);
    EXPECT_EQ(r1.greenClosed, r2.greenClosed);
    EXPECT_EQ(r1.greenRemoved, r2.greenRemoved);
    greenClosed += r1.greenClosed;
    greenRemoved += r1.greenRemoved;
    SCOPED_TRACE("radius " + std::to_string(radius));
    expectSameGrid(one, two);
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_GT(greenClosed, 0);
  EXPECT_GT(greenRemoved, 0);
}

// A uniform refinement of a locally refined grid on threads: every regular element is red from the
// start (Grid::propagateAllRed), and the leaves of two levels and the green fathers among them give
// red children of this refinement refined edges from their finer neighbours' children (rule 1), so
// that the closure has work. The grid of one thread, bit for bit.
TEST_P(GridTest, UniformRefinementOfALocallyRefinedGridOnThreadsGivesTheGridOfOneThread) {
  Grid one(GetParam().make()), two(GetParam().make());
  while (one.numLeafElements() < 2048) {
    one.refineUniformly(1);
    two.refineUniformly(1);
  }
  markBall(one, two, 1.0);
  one.adapt(1);
  two.adapt(1);
  const AdaptResult r1 = one.refineUniformly(1), r2 = two.refineUniformly(2);
  EXPECT_GE(r1.redRefined, 2048);  // on threads
  EXPECT_EQ(r1.propagated, 0);
  EXPECT_EQ(r1.redRefined, r2.redRefined);
  EXPECT_EQ(r1.greenClosed, r2.greenClosed);
  EXPECT_GT(r1.greenClosed, 0);
  expectSameGrid(one, two);
}

TEST_P(GridTest, MarkingAGreenLeafRefinesItsFatherRed) {
  Grid g(GetParam().make());
  g.mark(0);
  g.adapt();
  Index green = -1;
  for (Index e : g.leafElements())
    if (g.isGreen(e)) {
      green = e;
      break;
    }
  ASSERT_GE(green, 0) << "refining one cell must create a green closure";
  const Index father = g.father(green);
  g.mark(green);
  const AdaptResult r = g.adapt();
  EXPECT_TRUE(g.isRemoved(green));
  EXPECT_EQ(g.refinement(father), Refinement::Red);
  EXPECT_GE(r.greenRemoved, 1);
  EXPECT_THROW(g.mark(green), obs::Error);
  EXPECT_THROW(g.mark(father), obs::Error);
}

TEST_P(GridTest, BoundaryIdsAreInherited) {
  const Mesh coarse = GetParam().make();
  Grid g(coarse);
  g.mark(0);
  g.adapt();
  g.refineUniformly();
  const Mesh leaf = g.leafMesh();
  EXPECT_EQ(leaf.boundaryNames(), coarse.boundaryNames());
  // Every leaf boundary face lies in a coarse boundary face with the same id: on the box sides.
  const Point lo = Point::Zero();
  const Point hi = GetParam().name == "mixed" ? Point(1, 1, 2) : Point(2, 1.5, 1);
  for (Index f = 0; f < leaf.numBoundaryFaces(); ++f) {
    const int id = leaf.boundaryFaceId(f);
    const int axis = id <= 2 ? 0 : id <= 4 ? (leaf.dimension() == 2 ? 1 : 2) : 1;
    const double value = (id % 2 == 1) ? lo[axis] : hi[axis];
    for (Index v : leaf.boundaryFaceVertices(f)) EXPECT_NEAR(leaf.vertex(v)[axis], value, 1e-14);
  }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, GridTest, ::testing::ValuesIn(gridCases()),
                         [](const auto& info) { return info.param.name; });

// --- boundary projection -----------------------------------------------------------------------

TEST(GridProjection, NewTopVerticesFollowTheProjection) {
  for (CellType t : {CellType::Quadrilateral, CellType::Tetrahedron, CellType::Hexahedron}) {
    const Mesh coarse = boxMesh(t, {2, 2, 2}, Point(0, 0, 0), Point(1, 1, 1));
    Grid g(coarse);
    const int top = kTop;  // y = 1 in 2D, z = 1 in 3D
    const int axis = coarse.dimension() == 2 ? 1 : 2;
    auto bump = [axis](const Point& x) {
      Point y = x;
      y[axis] = 1 + 0.05 * std::sin(M_PI * x[0]);
      return y;
    };
    g.setBoundaryProjection(top, bump);
    g.refineUniformly();
    g.mark(g.leafElements().front());
    g.adapt();
    const Mesh leaf = g.leafMesh();
    EXPECT_TRUE(checkConformity(leaf).conforming());
    for (Index c = 0; c < leaf.numCells(); ++c) EXPECT_TRUE(isPositivelyOriented(leaf, c));
    Index moved = 0;
    for (Index f = 0; f < leaf.numBoundaryFaces(); ++f) {
      if (leaf.boundaryFaceId(f) != top) continue;
      for (Index v : leaf.boundaryFaceVertices(f)) {
        const Point& x = leaf.vertex(v);
        if (x[0] > 1e-14 && x[0] < 1 - 1e-14 && std::abs(x[0] - 0.5) > 1e-14) {
          EXPECT_NEAR(x[axis], 1 + 0.05 * std::sin(M_PI * x[0]), 1e-14) << name(t);
          ++moved;
        }
      }
    }
    EXPECT_GT(moved, 0) << name(t);
    // The other sides are untouched.
    for (Index f = 0; f < leaf.numBoundaryFaces(); ++f) {
      if (leaf.boundaryFaceId(f) != kBottom) continue;
      for (Index v : leaf.boundaryFaceVertices(f)) EXPECT_EQ(leaf.vertex(v)[axis], 0.0);
    }
  }
}

TEST(GridViews, LevelViewOutOfRangeThrows) {
  Grid g(boxMesh(CellType::Triangle, 2));
  EXPECT_THROW(g.levelView(1), obs::Error);
  EXPECT_THROW(g.levelView(-1), obs::Error);
  EXPECT_THROW(g.geometryInFather(0), obs::Error);
  EXPECT_THROW(g.mark(100), obs::Error);
}

TEST(GridViews, FaceNeighboursAreSymmetric) {
  Grid g(mixedBoxMesh3D({2, 2, 4}, Point::Zero(), Point(1, 1, 2)));
  g.mark(3);
  g.adapt();
  const GridView view = g.leafView();
  const auto nb = view.faceNeighbours();
  Index boundary = 0;
  for (Index c = 0; c < view.mesh.numCells(); ++c)
    for (int f = 0; f < static_cast<int>(localFaces(view.mesh.cellType(c)).size()); ++f) {
      const Index d = nb(c, f);
      if (d < 0) {
        ++boundary;
        continue;
      }
      bool back = false;
      for (int h = 0; h < static_cast<int>(localFaces(view.mesh.cellType(d)).size()); ++h)
        back = back || nb(d, h) == c;
      EXPECT_TRUE(back);
    }
  EXPECT_EQ(boundary, view.mesh.numBoundaryFaces());
  // The maps between view and grid.
  for (std::size_t i = 0; i < view.vertices.size(); ++i) {
    EXPECT_EQ(view.vertexIndex[view.vertices[i]], static_cast<Index>(i));
    EXPECT_EQ(view.mesh.vertex(static_cast<Index>(i)), g.vertex(view.vertices[i]));
  }
}
