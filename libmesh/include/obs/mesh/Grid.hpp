#pragma once
/// \file Grid.hpp
/// A hierarchical grid with local red refinement and a conforming green closure, for all six cell
/// types and mixed meshes (red-green refinement: Bank, Sherman, Weiser 1983; tetrahedra: Bey 1995;
/// cone closure of mixed meshes in the spirit of UG, Bastian et al. 1997).
///
/// Hierarchy. Level 0 is the coarse mesh. A refined element owns its children (stored
/// contiguously), which are one level finer. Red children follow the rules of RedRefinement.hpp
/// (tetrahedra with the shortest interior diagonal). Green children close an unrefined element
/// that has refined edges ("hanging" edge midpoints of finer neighbours); they are never refined
/// themselves: marking one refines its father red instead, and a father whose closure no longer
/// fits gets a new closure (or is refined red), the old green children being *removed* (their
/// indices stay valid, isRemoved() says so). Element and vertex indices never change.
///
/// Protocol (as dune-grid): mark() leaves -> adapt() -> transfer data -> mark again. adapt()
/// returns an AdaptResult; the elements and vertices it created are the index ranges starting at
/// firstNewElement / firstNewVertex, and every new vertex knows its origin (the element whose
/// refinement created it and the local point of that element it is, see LocalPoints), so vertex
/// data are transferred either by transferMatrix() (Prolongation.hpp) between the leaf views before
/// and after, or directly from vertexOrigin().
///
/// Marking closure (adapt()). Call "regular" the elements that are leaves and not green, or
/// fathers of green leaves. Marked regular leaves and the fathers of marked green leaves are
/// refined red (so markAll() refines the fathers of green leaves, not the green leaves), and
/// refinement propagates until stable by two rules:
///   1. irregularity: if a red child F of P is refined, every regular element that contains an edge
///      or face of P on which an edge of F lies is refined red. So an edge of a regular element
///      carries at most its own midpoint, neighbours differ by at most one level, and the level
///      views are conforming (Bank et al.: 1-irregular red refinement plus green closure);
///   2. closure economy (as in UG): a regular element with more than half of its edges refined is
///      refined red (in 2D the classical rule: a triangle with two refined edges is refined red).
///      setClosureRule(ClosureRule::AllEdges) restricts the rule to elements with all edges
///      refined, so every other edge pattern is closed green (measured in
///      docs/estimators.md#closure-overhead: on hexahedra the same accuracy with fewer unknowns
///      under mean-value marking, on tetrahedra worse).
/// Every other regular element with refined edges gets the green closure of its edge pattern
/// (below), as do red children created by this adapt() that already have refined edges (from finer
/// neighbours refined at the same time). The least fixed point of the rules is computed with a work
/// list; it does not depend on the processing order, and vertices and elements are created in
/// element order, so the result is deterministic (same grid and marks => same output).
///
/// Green closure rules (local point codes of LocalPoints; a face rule depends only on the face's
/// refined edges and global data, so both cells sharing a face split it identically):
///  - triangle face: 1 refined edge -> bisection from the opposite corner; 2 -> the corner triangle
///    at the common corner plus the remaining quadrilateral cut along its shorter diagonal (ties:
///    the diagonal at the corner first in lexicographic coordinate order, so the split does not
///    depend on the vertex numbers); 3 -> the 4 red children;
///  - quadrilateral face: 4 refined edges -> the 4 red children (through the face centre); 1 to 3 ->
///    a fan of triangles from the face centre over the (halved) edges;
///  - 2D cells: the face rule applied to the cell itself;
///  - tetrahedra and pyramids: if a corner touches no refined edge and all its faces are triangles
///    (tetrahedron: any such corner, the first; pyramid: the apex), the cone from that corner over
///    the split faces opposite to it (e.g. a tetrahedron with one refined edge is bisected);
///  - otherwise (and for hexahedra and prisms): the cone from the centroid over all split faces,
///    a tetrahedron per triangle and a pyramid per quadrilateral.
/// Faces with refined edges are always shared with a neighbour that sees the same refined edges;
/// a quadrilateral face of a red neighbour has all four edges refined, matching the 4-quad rule.
///
/// Views. The leaf view (all leaves) and level view l (the elements of level l plus the leaves of
/// coarser levels) are conforming meshes; GridView holds one as a Mesh with boundary faces (ids
/// inherited from the coarse boundary faces, names copied) and the maps to grid elements and
/// grid vertices.
///
/// Boundary projection. setBoundaryProjection(id, f) moves every vertex created later on a
/// boundary face with that id (edge midpoints, quadrilateral face centres, red and green) to f(x);
/// a vertex on faces of several such ids gets each projection, in increasing id order (e.g. a
/// curved side and a flat cap whose projection keeps the cap plane). The hierarchy then stops
/// being geometrically nested there; transfer operators interpolate at the unprojected position.
/// New elements that a projection inverts are counted in AdaptResult::invertedElements.
///
/// Coarse-mesh checks (constructor): cells whose vertex order is mirrored are reoriented and
/// reported (inputReport()); repeated vertices, zero-volume or inverted cells (Jacobian changing
/// sign), duplicate cells, faces shared by more than two cells, overlapping cells and boundary
/// faces that are not the face of exactly one cell are obs::Errors naming the cell or face.
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "obs/mesh/CellType.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::mesh {

/// Local points of a cell type, numbered ("local point codes"): the corners, the edge midpoints
/// (localEdges() order), the face centres (localFaces() order) and the centroid (the image of the
/// reference centroid). Children of refined elements and new vertices are described by them.
class LocalPoints {
public:
  static const LocalPoints& of(CellType type);
  static constexpr int kMaxPoints = 27;  ///< hexahedron: 8 + 12 + 6 + 1

  CellType type;
  int numCorners = 0, numEdges = 0, numFaces = 0, size = 0;
  int edgePoint(int edge) const { return numCorners + edge; }
  int facePoint(int face) const { return numCorners + numEdges + face; }
  int centroidPoint() const { return size - 1; }
  /// Reference coordinates of a point.
  const Point& reference(int point) const { return ref_[point]; }
  /// Shape function values at the point (the weights of the corners in its position).
  std::span<const double> weights(int point) const {
    return {weights_[point].data(), static_cast<std::size_t>(numCorners)};
  }
  /// Bit f is set if the point lies on local face f.
  unsigned faceMask(int point) const { return faceMask_[point]; }
  /// Local edge joining corners a and b, or -1.
  int edge(int a, int b) const { return edgeOf_[a][b]; }
  /// Local edge of the j-th edge (corners j, j+1 cyclically) of local face f.
  int faceEdge(int f, int j) const { return faceEdges_[f][j]; }

private:
  std::array<Point, kMaxPoints> ref_{};
  std::array<std::array<double, 8>, kMaxPoints> weights_{};
  std::array<unsigned, kMaxPoints> faceMask_{};
  std::array<std::array<int, 8>, 8> edgeOf_{};
  std::array<std::array<int, 4>, 6> faceEdges_{};
  friend struct LocalPointTables;
};

/// How an element is refined.
enum class Refinement : std::uint8_t { None, Red, Green };

/// What the constructor found in the coarse mesh.
struct GridInputReport {
  std::vector<Index> reorientedCells;  ///< coarse cells whose vertex order was mirrored
  Index unlistedBoundaryFaces = 0;     ///< one-cell faces not listed as boundary faces (id 0)
};

/// Boundary id given to one-cell coarse faces that the coarse mesh does not list.
inline constexpr int kUnlistedBoundaryId = 0;

/// When adapt() refines an unmarked regular element with refined edges red instead of closing it
/// green (rule 2 of the marking closure, see Grid).
enum class ClosureRule {
  MoreThanHalfEdges,  ///< red when more than half of its edges are refined (default)
  AllEdges,           ///< red only when all of its edges are refined
};

/// Statistics of one adapt() call.
struct AdaptResult {
  Index marked = 0;           ///< marked leaves
  Index redRefined = 0;       ///< elements refined red
  Index propagated = 0;       ///< of these, refined without being (the father of) a marked leaf
  Index greenClosed = 0;      ///< elements given a new green closure
  Index greenRemoved = 0;     ///< green closures removed (father refined red or closed anew)
  Index firstNewElement = 0;  ///< elements created: [firstNewElement, numElements())
  Index firstNewVertex = 0;   ///< vertices created: [firstNewVertex, numVertices())
  Index invertedElements = 0; ///< new elements not positively oriented (possible with projections)
};

/// A conforming view of the grid (leaf view or level view) as a flat Mesh.
struct GridView {
  int level = -1;               ///< level of a level view, -1 for the leaf view
  Mesh mesh;                    ///< cells in `elements` order, vertices in `vertices` order
  std::vector<Index> elements;  ///< mesh cell -> grid element (ascending)
  std::vector<Index> vertices;  ///< mesh vertex -> grid vertex (ascending)
  std::vector<Index> vertexIndex;  ///< grid vertex -> mesh vertex, or -1 if not in the view

  /// Mesh vertex of a grid vertex, -1 if not in the view (also for vertices created later).
  Index viewVertex(Index gridVertex) const {
    return gridVertex < static_cast<Index>(vertexIndex.size()) ? vertexIndex[gridVertex] : -1;
  }

  /// Face neighbours: neighbour(c, f) is the cell across local face f of cell c, -1 on the boundary.
  struct Neighbours {
    std::vector<Index> offsets;  ///< per cell, into cells
    std::vector<Index> cells;
    Index operator()(Index c, int localFace) const { return cells[offsets[c] + localFace]; }
  };
  Neighbours faceNeighbours() const;
};

namespace detail {
/// Open-addressing hash map (linear probing, power-of-two capacity, load <= 1/2) from a trivially
/// copyable key to an Index: no allocation per entry. The key `empty` marks free slots.
template <class Key, class Hash, class Equal = std::equal_to<Key>>
class FlatIndexMap {
public:
  explicit FlatIndexMap(Key empty) : empty_(empty) {}
  std::size_t size() const { return size_; }
  Index find(const Key& key) const {
    if (keys_.empty()) return -1;
    const std::size_t mask = keys_.size() - 1;
    for (std::size_t i = Hash{}(key)&mask;; i = (i + 1) & mask) {
      if (Equal{}(keys_[i], key)) return values_[i];
      if (Equal{}(keys_[i], empty_)) return -1;
    }
  }
  /// Inserts (key, value) unless key is present; returns the stored value and whether it inserted.
  std::pair<Index, bool> insert(const Key& key, Index value) {
    if (2 * (size_ + 1) > keys_.size()) rehash(keys_.empty() ? 64 : 2 * keys_.size());
    const std::size_t mask = keys_.size() - 1;
    for (std::size_t i = Hash{}(key)&mask;; i = (i + 1) & mask) {
      if (Equal{}(keys_[i], key)) return {values_[i], false};
      if (Equal{}(keys_[i], empty_)) {
        keys_[i] = key;
        values_[i] = value;
        ++size_;
        return {value, true};
      }
    }
  }
  void reserve(std::size_t n) {
    std::size_t cap = 64;
    while (cap < 2 * n) cap *= 2;
    if (cap > keys_.size()) rehash(cap);
  }
  /// insert() for a key that is not in the map, callable from several threads at once after
  /// reserve(size() + the number of such inserts), with nothing else using the map meanwhile; then
  /// addToSize(that number). The value must be >= 0: a slot is claimed by setting its value from -1
  /// (empty) by compare-and-swap. Which slot a key gets may depend on the threads' timing; what
  /// find() returns does not.
  void insertAbsentConcurrently(const Key& key, Index value) {
    const std::size_t mask = keys_.size() - 1;
    for (std::size_t i = Hash{}(key)&mask;; i = (i + 1) & mask) {
      std::atomic_ref<Index> slot(values_[i]);
      Index expected = -1;
      if (slot.load(std::memory_order_relaxed) == -1 &&
          slot.compare_exchange_strong(expected, value, std::memory_order_relaxed)) {
        keys_[i] = key;
        return;
      }
    }
  }
  void addToSize(std::size_t n) { size_ += n; }

private:
  void rehash(std::size_t capacity) {
    std::vector<Key> keys(capacity, empty_);
    std::vector<Index> values(capacity, -1);
    keys.swap(keys_);
    values.swap(values_);
    size_ = 0;
    for (std::size_t i = 0; i < keys.size(); ++i)
      if (!Equal{}(keys[i], empty_)) insert(keys[i], values[i]);
  }
  Key empty_;
  std::vector<Key> keys_;
  std::vector<Index> values_;
  std::size_t size_ = 0;
};

struct U64Hash {
  std::size_t operator()(std::uint64_t h) const noexcept {  // splitmix64 finaliser
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebULL;
    return static_cast<std::size_t>(h ^ (h >> 31));
  }
};
struct Key4Equal {
  bool operator()(const std::array<Index, 4>& a, const std::array<Index, 4>& b) const noexcept {
    return a[0] == b[0] && a[1] == b[1] && a[2] == b[2] && a[3] == b[3];
  }
};
struct Key4Hash {
  std::size_t operator()(const std::array<Index, 4>& k) const noexcept {
    std::uint64_t a = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k[0])) << 32) |
                      static_cast<std::uint32_t>(k[1]);
    std::uint64_t b = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k[2])) << 32) |
                      static_cast<std::uint32_t>(k[3]);
    return U64Hash{}(a ^ U64Hash{}(b));
  }
};
}  // namespace detail

/// The hierarchical grid (see the file comment).
class Grid {
public:
  using Projection = std::function<Point(const Point&)>;

  /// Level 0 from a coarse mesh (copied; checked and reoriented as described above).
  explicit Grid(const Mesh& coarse);

  int dimension() const { return dim_; }
  const GridInputReport& inputReport() const { return report_; }
  /// Number of coarse cells that were reoriented.
  Index reorientedCells() const { return static_cast<Index>(report_.reorientedCells.size()); }

  // --- vertices ----------------------------------------------------------------------------------
  Index numVertices() const { return static_cast<Index>(x_.size()); }
  const Point& vertex(Index v) const { return x_[v]; }
  const std::vector<Point>& vertices() const { return x_; }
  bool isBoundaryVertex(Index v) const { return boundaryVertex_[v] != 0; }
  /// Where a vertex came from: the element whose refinement created it and the local point of that
  /// element (LocalPoints code) it is; element -1 for coarse vertices. The creating element's
  /// corners existed before, so new values are sum_i weights(point)[i] * value(corner i).
  struct Origin {
    Index element = -1;
    int point = -1;
  };
  Origin vertexOrigin(Index v) const {
    return {vertexCreator_[v], vertexCreator_[v] < 0 ? -1 : vertexPoint_[v]};
  }
  /// Data transfer without views: `values` holds `components` numbers per grid vertex for the
  /// vertices [0, firstNewVertex); it is resized to numVertices() and the new vertices get
  /// sum_i weights(point)[i] * value(corner i) of their origin (in index order, so origins that
  /// are new themselves come first). This interpolates the data of the creating element; where a
  /// green closure was replaced, transferMatrix() of the old and new leaf views interpolates the
  /// old leaf function instead.
  void interpolateNewVertices(std::vector<double>& values, Index firstNewVertex,
                              int components = 1) const;

  // --- elements ----------------------------------------------------------------------------------
  /// All elements ever created, including removed green ones.
  Index numElements() const { return static_cast<Index>(type_.size()); }
  CellType type(Index e) const { return type_[e]; }
  int level(Index e) const { return level_[e]; }
  std::span<const Index> vertices(Index e) const {
    return {conn_.data() + connOffset_[e], static_cast<std::size_t>(mesh::numVertices(type_[e]))};
  }
  /// Father element, -1 on level 0.
  Index father(Index e) const { return father_[e]; }
  Refinement refinement(Index e) const { return refinement_[e]; }
  int numChildren(Index e) const { return numChildren_[e]; }
  Index child(Index e, int i) const { return firstChild_[e] + i; }
  /// Created by a green closure (never refined itself).
  bool isGreen(Index e) const { return (flags_[e] & kGreen) != 0; }
  /// A green element removed by a later adapt (no longer part of the hierarchy).
  bool isRemoved(Index e) const { return (flags_[e] & kRemoved) != 0; }
  bool isLeaf(Index e) const { return !isRemoved(e) && refinement_[e] == Refinement::None; }
  int maxLevel() const { return maxLevel_; }
  /// Local points (LocalPoints of the father's type) that are the corners of e; level > 0.
  std::span<const std::uint8_t> pointsInFather(Index e) const {
    return {inFather_[e].data(), static_cast<std::size_t>(mesh::numVertices(type_[e]))};
  }
  /// Reference coordinates of the corners of e in its father's reference element; level > 0.
  std::vector<Point> geometryInFather(Index e) const;
  /// Boundary id of local face f of element e (inherited from the coarse boundary face it lies
  /// on), or -1 for a face in the interior of the domain.
  int boundaryId(Index e, int localFace) const;
  const std::map<int, std::string>& boundaryNames() const { return names_; }

  // --- refinement --------------------------------------------------------------------------------
  /// Moves vertices created later on boundary faces with this id to projection(x) (nullptr: off).
  void setBoundaryProjection(int id, Projection projection);
  /// Rule 2 of adapt() (see the file comment): which unmarked elements with refined edges are
  /// refined red instead of closed green. Applies to later adapt() calls.
  void setClosureRule(ClosureRule rule) { closureRule_ = rule; }
  ClosureRule closureRule() const { return closureRule_; }
  /// Marks a leaf for refinement (a green leaf: its father is refined red). Throws for non-leaves.
  void mark(Index e);
  /// Marks every leaf.
  void markAll();
  bool isMarked(Index e) const { return marks_[e] != 0; }
  /// Refined edges of element e: bit k is set when local edge k (localEdges order) has a midpoint
  /// vertex (for a green father: the pattern its closure fits).
  unsigned edgePattern(Index e) const;
  void clearMarks();
  /// Refines the marked leaves, propagates and closes (see the file comment); clears the marks.
  /// The red refinement of many elements (from 2,048 on), and the propagation of a uniform
  /// refinement, run on `threads` threads (OpenMP) where no boundary projection is set; the grid is
  /// the same for any thread count: the same vertices, elements and numbers, bit for bit
  /// (docs/performance.md#refinement-threads).
  AdaptResult adapt(int threads = 1);
  /// The elements the next adapt() would refine red (ascending): the marked regular leaves, the
  /// fathers of marked green leaves and what the closure's rules 1 and 2 add. Nothing changes.
  std::vector<Index> redClosure() const;
  /// markAll() and adapt(threads).
  AdaptResult refineUniformly(int threads = 1);

  // --- views -------------------------------------------------------------------------------------
  std::vector<Index> leafElements() const;
  Index numLeafElements() const;
  GridView leafView() const { return makeView(-1); }
  /// The elements of `level` plus the leaves of coarser levels; 0 <= level <= maxLevel().
  GridView levelView(int level) const;
  Mesh leafMesh() const { return leafView().mesh; }
  Mesh levelMesh(int level) const { return levelView(level).mesh; }

private:
  static constexpr std::uint8_t kGreen = 1, kRemoved = 2;
  using EdgeMap = detail::FlatIndexMap<std::uint64_t, detail::U64Hash>;
  using FaceMap = detail::FlatIndexMap<std::array<Index, 4>, detail::Key4Hash, detail::Key4Equal>;
  struct Context;  // work data of one adapt() (GridAdapt.cpp)
  static std::uint64_t edgeKey(Index a, Index b) {
    if (a > b) std::swap(a, b);
    return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
  }
  /// A child in local point codes of its father.
  struct LocalChild {
    CellType type;
    std::array<std::uint8_t, 8> points;
  };

  // GridCheck.cpp
  void checkAndLoad(const Mesh& coarse);
  // Grid.cpp
  Index addElement(CellType type, std::span<const Index> vertices, Index father, int level,
                   std::span<const std::uint8_t> pointsInFather, bool green);
  Index addVertex(const Point& x, Index creator, int point, bool boundary);
  void reserve(Index elements, std::size_t connectivity, Index vertices);
  Point pointPosition(Index e, int point) const;
  GridView makeView(int level) const;
  // GridAdapt.cpp
  /// The closure's start: the regular elements, their vertex adjacency, the marked ones queued red.
  void startClosure(Context& ctx, AdaptResult& result) const;
  void propagate(Context& ctx) const;
  void propagateAllRed(Context& ctx, int threads) const;
  bool hasEntity(Index g, const std::array<Index, 4>& vs, int k) const;
  int entityCorners(Index p, int ent, std::array<Index, 4>& vs) const;
  std::uint32_t fatherEntitiesOfEdges(Index e) const;
  template <class F>
  void forElementsWithEntities(const Context& ctx, Index p, std::uint32_t bits, F&& f) const;
  void refineRed(Index e);
  /// refineRed() of every element of `red` (ascending, regular in ctx) on `threads` threads, with
  /// the numbers and values of refineRed() called in that order.
  void refineRedOnThreads(const std::vector<Index>& red, const Context& ctx, int threads);
  /// Its passes (GridAdapt.cpp) on the tables of RedPlan: the sources of the new points, their
  /// numbers, the vertices and children, the hash maps.
  struct RedPlan;
  void redSources(RedPlan& plan, const Context& ctx, int threads) const;
  void numberRed(RedPlan& plan);
  void writeRed(const RedPlan& plan, int threads);
  void insertRedPoints(const RedPlan& plan, int threads);
  void closeGreen(Index e, unsigned pattern, std::vector<LocalChild>& scratch);
  void removeChildren(Index e);
  Index edgeMidpoint(Index e, int localEdge);
  void edgeBoundaryIds(Index e, int localEdge, std::vector<int>& ids) const;
  Index faceCentre(Index e, int localFace);
  Point edgePointPosition(Index e, int localEdge, std::vector<int>& ids) const;
  std::array<Index, 4> faceKey(Index e, int localFace) const;
  Point facePointPosition(Index e, int localFace, const std::array<Index, 4>& key, bool& boundary) const;
  Index centroid(Index e);
  Point project(const Point& x, const std::vector<int>& ids) const;
  // GridClosure.cpp: the closure rules, in local points
  void closureRule(Index e, unsigned pattern, std::vector<LocalChild>& out) const;

  int dim_ = 3;
  int maxLevel_ = 0;
  GridInputReport report_;
  std::map<int, std::string> names_;
  std::map<int, Projection> projections_;
  ClosureRule closureRule_ = ClosureRule::MoreThanHalfEdges;

  // vertices
  std::vector<Point> x_;
  std::vector<Index> vertexCreator_;
  std::vector<std::uint8_t> vertexPoint_;
  std::vector<char> boundaryVertex_;

  // elements (flat arrays, indexed by element)
  std::vector<CellType> type_;
  std::vector<std::uint8_t> level_;
  std::vector<std::uint8_t> flags_;
  std::vector<Refinement> refinement_;
  std::vector<Index> father_;
  std::vector<Index> firstChild_;
  std::vector<std::uint8_t> numChildren_;
  std::vector<Index> connOffset_;
  std::vector<Index> conn_;
  std::vector<std::array<std::uint8_t, 8>> inFather_;
  std::vector<std::uint16_t> greenPattern_;  ///< refined-edge pattern of the current green closure
  std::vector<char> marks_;

  // coarse boundary: id of local face f of coarse cell c at coarseFaceId_[coarseFaceOffset_[c]+f]
  std::vector<Index> coarseFaceOffset_;
  std::vector<int> coarseFaceId_;
  std::vector<std::pair<std::uint64_t, int>> coarseEdgeIds_;  ///< (edge key, id) of boundary edges

  // new vertices shared between elements
  EdgeMap edgeMidpoints_{~std::uint64_t{0}};          ///< sorted vertex pair -> midpoint
  FaceMap faceCentres_{std::array<Index, 4>{-1, -1, -1, -1}};  ///< sorted quad face -> centre
  EdgeMap centroids_{~std::uint64_t{0}};              ///< element -> centroid vertex
};

/// Shape quality of a cell: the minimum over its corners of the mean ratio
/// d det(J)^(2/d) / |J|_F^2 of the corner Jacobian J = [edge vectors leaving the corner] (the
/// pyramid apex is skipped, its four edges enter the base corners' Jacobians). It is 1 for a corner
/// with orthogonal edges of equal length, in (0, 1) otherwise, and 0 for a non-positive corner.
/// (Knupp 2001, "Algebraic mesh quality metrics", corner condition numbers.)
double shapeQuality(CellType type, std::span<const Point> corners);

}  // namespace obs::mesh
