// Grid::adapt(): marking closure (which elements are refined red), red refinement, and the green
// closure of the remaining elements with refined edges. The rules are stated in Grid.hpp.
//
// Work per adapt() is linear in the number of regular leaves plus the work of the refinement
// itself: one vertex -> element adjacency of the regular leaves, a work list for the propagation,
// and flat hash maps keyed on sorted vertex pairs (edge midpoints) and sorted quadrilateral faces
// (face centres), so shared vertices are created once and found in O(1).
//
// adapt(threads) with threads > 1 refines red on the threads from kRedOnThreadsMin red elements on
// (refineRedOnThreads), and a uniform refinement (every regular element red from the start) also
// propagates on them (propagateAllRed); both give the grid of one thread, bit for bit
// (docs/performance.md#refinement-threads). Boundary projections (user functions) keep it on one.
#include <algorithm>
#include <atomic>
#include <bit>
#include <climits>

#include "obs/mesh/Error.hpp"
#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"
#include "obs/mesh/RedRefinement.hpp"

namespace obs::mesh {
namespace {

struct CodedChild {
  CellType type;
  std::array<std::uint8_t, 8> points;
};

/// Per-type tables for the refinement: the red rules in local point codes, the corner supports
/// of the local points, and which edge or face of a cell contains a given set of corners.
struct AdaptTables {
  std::array<std::array<std::vector<CodedChild>, 3>, 7> red;  // [type][variant]
  std::array<std::array<std::uint32_t, 3>, 7> redUsed{};      // points used by the rule
  std::array<std::array<std::uint8_t, LocalPoints::kMaxPoints>, 7> support{};  // corner bits
  /// entity[type][corner bits]: the local edge e (value e) or else face f (value 16 + f) whose
  /// corners include all the given corners, or -1.
  std::array<std::array<std::int8_t, 256>, 7> entity{};
  std::array<std::array<std::uint8_t, 6>, 7> faceCorners{};  // corner bits of each face

  AdaptTables() {
    for (CellType t : kVolumeCellTypes) {
      const int ti = static_cast<int>(t);
      const LocalPoints& lp = LocalPoints::of(t);
      const auto edges = localEdges(t);
      const auto faces = localFaces(t);
      std::array<std::uint8_t, 12> edgeBits{};
      for (int e = 0; e < lp.numEdges; ++e)
        edgeBits[e] = static_cast<std::uint8_t>((1u << edges[e][0]) | (1u << edges[e][1]));
      for (int f = 0; f < lp.numFaces; ++f)
        for (int v : faces[f].span()) faceCorners[ti][f] |= static_cast<std::uint8_t>(1u << v);
      for (int i = 0; i < lp.numCorners; ++i) support[ti][i] = static_cast<std::uint8_t>(1u << i);
      for (int e = 0; e < lp.numEdges; ++e) support[ti][lp.edgePoint(e)] = edgeBits[e];
      for (int f = 0; f < lp.numFaces; ++f) support[ti][lp.facePoint(f)] = faceCorners[ti][f];
      support[ti][lp.centroidPoint()] = static_cast<std::uint8_t>((1u << lp.numCorners) - 1);
      for (int bits = 0; bits < 256; ++bits) {
        std::int8_t ent = -1;
        for (int e = 0; e < lp.numEdges && ent < 0; ++e)
          if ((bits & ~edgeBits[e]) == 0) ent = static_cast<std::int8_t>(e);
        for (int f = 0; f < lp.numFaces && ent < 0; ++f)
          if ((bits & ~faceCorners[ti][f]) == 0) ent = static_cast<std::int8_t>(16 + f);
        entity[ti][bits] = ent;
      }
      for (int variant = 0; variant < numRedRuleVariants(t); ++variant) {
        const RefinementRule& rule = redRefinementRule(t, variant);
        std::vector<int> code(rule.points.size());
        for (std::size_t i = 0; i < code.size(); ++i) {
          const PointSite& s = rule.sites[i];
          code[i] = s.location == PointLocation::Corner ? s.index
                    : s.location == PointLocation::Edge ? lp.edgePoint(s.index)
                    : s.location == PointLocation::Face ? lp.facePoint(s.index)
                                                        : lp.centroidPoint();
        }
        for (const RefinementChild& c : rule.children) {
          CodedChild cc{c.type, {}};
          for (std::size_t k = 0; k < c.points.size(); ++k) {
            cc.points[k] = static_cast<std::uint8_t>(code[c.points[k]]);
            redUsed[ti][variant] |= 1u << code[c.points[k]];
          }
          red[ti][variant].push_back(cc);
        }
      }
    }
  }
};

const AdaptTables& tables() {
  static const AdaptTables t;
  return t;
}

/// Red refinements below this many elements stay on one thread (the fork does not pay).
constexpr std::size_t kRedOnThreadsMin = 2048;

int localIndex(std::span<const Index> v, Index g) {
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i] == g) return static_cast<int>(i);
  return -1;
}

}  // namespace

/// Work data of one adapt(), indexed by the elements that existed when it started.
struct Grid::Context {
  Index numOld = 0;
  std::vector<char> regular;         ///< leaves that are not green, and fathers of green leaves
  std::vector<Index> adjStart, adj;  ///< vertex -> regular elements having it as a corner
  std::vector<char> red;             ///< to be refined red
  std::vector<char> touched;         ///< got a newly refined edge
  std::vector<char> childCheck;      ///< red, and its children may get refined edges
  std::vector<std::uint32_t> scanned;  ///< red fathers: edges/faces (bits e, 16 + f) done (rule 1)
  std::vector<Index> queue, touchedList;
  EdgeMap newEdges{~std::uint64_t{0}};  ///< edges refined by this adapt

  std::span<const Index> around(Index v) const {
    return {adj.data() + adjStart[v], adj.data() + adjStart[v + 1]};
  }
};

// ------------------------------------------------------------------------------------------------
void Grid::startClosure(Context& ctx, AdaptResult& result) const {
  const Index n = ctx.numOld = numElements();
  ctx.regular.assign(n, 0);
  for (Index e = 0; e < n; ++e)
    ctx.regular[e] = !isRemoved(e) && ((refinement_[e] == Refinement::None && !isGreen(e)) ||
                                       refinement_[e] == Refinement::Green);
  // Vertex -> regular element adjacency (CSR, ascending elements).
  ctx.adjStart.assign(numVertices() + 1, 0);
  for (Index e = 0; e < n; ++e)
    if (ctx.regular[e])
      for (Index v : vertices(e)) ++ctx.adjStart[v + 1];
  for (Index v = 0; v < numVertices(); ++v) ctx.adjStart[v + 1] += ctx.adjStart[v];
  ctx.adj.resize(ctx.adjStart.back());
  {
    std::vector<Index> fill(ctx.adjStart.begin(), ctx.adjStart.end() - 1);
    for (Index e = 0; e < n; ++e)
      if (ctx.regular[e])
        for (Index v : vertices(e)) ctx.adj[fill[v]++] = e;
  }
  ctx.red.assign(n, 0);
  ctx.touched.assign(n, 0);
  ctx.childCheck.assign(n, 0);
  ctx.scanned.assign(n, 0);

  for (Index e = 0; e < n; ++e)
    if (marks_[e]) {
      ++result.marked;
      const Index target = isGreen(e) ? father_[e] : e;
      if (!ctx.red[target]) {
        ctx.red[target] = 1;
        ctx.queue.push_back(target);
      }
    }
}

std::vector<Index> Grid::redClosure() const {
  Context ctx;
  AdaptResult unused;
  startClosure(ctx, unused);
  ctx.newEdges.reserve(3 * ctx.queue.size());
  propagate(ctx);
  std::vector<Index> red = std::move(ctx.queue);
  std::sort(red.begin(), red.end());
  return red;
}

// ------------------------------------------------------------------------------------------------
AdaptResult Grid::adapt(int threads) {
  AdaptResult result;
  result.firstNewElement = numElements();
  result.firstNewVertex = numVertices();
  Context ctx;
  startClosure(ctx, result);
  const std::size_t initiallyRed = ctx.queue.size();
  // on threads where it pays and no boundary projection (a user function) is involved; the same
  // grid either way
  const auto onThreads = [&](std::size_t red) {
    return threads > 1 && red >= kRedOnThreadsMin && projections_.empty();
  };
  if (onThreads(initiallyRed) &&
      static_cast<std::size_t>(std::count(ctx.regular.begin(), ctx.regular.end(), 1)) == initiallyRed) {
    propagateAllRed(ctx, threads);  // ctx.newEdges stays empty: refineRedOnThreads() counts them
  } else {
    ctx.newEdges.reserve(3 * initiallyRed);  // about the new edges per refined cell (grows if needed)
    propagate(ctx);
  }
  result.propagated = static_cast<Index>(ctx.queue.size() - initiallyRed);

  // Red refinement, in element order (deterministic vertex and element numbering).
  std::vector<Index> red = ctx.queue;
  std::sort(red.begin(), red.end());
  {  // Room for the red children and their new vertices (and some closures), no reallocation.
    std::size_t children = 0, connectivity = 0, quadFaces = 0;
    for (Index e : red) {
      for (const CodedChild& c : tables().red[static_cast<int>(type_[e])][0]) {
        ++children;
        connectivity += mesh::numVertices(c.type);
      }
      for (const LocalFace& f : localFaces(type_[e])) quadFaces += f.size == 4;
    }
    const std::size_t closures = 6 * ctx.touchedList.size();
    reserve(static_cast<Index>(numElements() + children + closures),
            conn_.size() + connectivity + 4 * closures,
            static_cast<Index>(numVertices() + ctx.newEdges.size() + quadFaces + red.size() +
                               ctx.touchedList.size()));
    edgeMidpoints_.reserve(edgeMidpoints_.size() + ctx.newEdges.size());
    faceCentres_.reserve(faceCentres_.size() + quadFaces);
  }
  for (Index e : red)  // green fathers lose their green children (refineRed does not read them)
    if (refinement_[e] == Refinement::Green) {
      removeChildren(e);
      ++result.greenRemoved;
    }
  if (onThreads(red.size())) {
    refineRedOnThreads(red, ctx, threads);
  } else {
    for (Index e : red) refineRed(e);
  }
  result.redRefined = static_cast<Index>(red.size());

  // Green closure of the elements whose edge pattern changed.
  std::vector<Index> candidates;
  for (Index e : ctx.touchedList)
    if (!ctx.red[e]) candidates.push_back(e);
  for (Index e : red)
    if (ctx.childCheck[e])
      for (int k = 0; k < numChildren_[e]; ++k) candidates.push_back(firstChild_[e] + k);
  std::sort(candidates.begin(), candidates.end());
  std::vector<LocalChild> closure;
  for (Index e : candidates) {
    const unsigned pattern = edgePattern(e);
    if (pattern == 0) continue;
    if (refinement_[e] == Refinement::Green) {
      if (greenPattern_[e] == pattern) continue;
      removeChildren(e);
      ++result.greenRemoved;
    }
    closeGreen(e, pattern, closure);
    ++result.greenClosed;
  }

  // Orientation check of the new elements that can be inverted: green children of distorted
  // elements and (with projections) children with moved vertices. Red children of a valid element
  // are valid for the cell types here.
  std::array<Point, 8> x{};
  for (Index e = result.firstNewElement; e < numElements(); ++e) {
    if (isRemoved(e) || (!isGreen(e) && projections_.empty())) continue;
    const auto v = vertices(e);
    for (std::size_t i = 0; i < v.size(); ++i) x[i] = x_[v[i]];
    if (!isPositivelyOriented(type_[e], std::span<const Point>(x.data(), v.size())))
      ++result.invertedElements;
  }
  maxLevel_ = 0;
  for (Index e = 0; e < numElements(); ++e)
    if (!isRemoved(e)) maxLevel_ = std::max<int>(maxLevel_, level_[e]);
  clearMarks();
  return result;
}

// ------------------------------------------------------------------------------------------------
/// Does regular element g have the corners vs[0..k-1] as an edge (k = 2) or a face?
bool Grid::hasEntity(Index g, const std::array<Index, 4>& vs, int k) const {
  const auto gv = vertices(g);
  unsigned bits = 0;
  for (int i = 0; i < k; ++i) {
    const int l = localIndex(gv, vs[i]);
    if (l < 0) return false;
    bits |= 1u << l;
  }
  const int ti = static_cast<int>(type_[g]);
  if (k == 2) return LocalPoints::of(type_[g]).edge(std::countr_zero(bits), 31 - std::countl_zero(bits)) >= 0;
  for (int f = 0; f < LocalPoints::of(type_[g]).numFaces; ++f)
    if (tables().faceCorners[ti][f] == bits) return true;
  return false;
}

/// The corners of entity `ent` of element p (edge e: value e, face f: 16 + f) and their number.
int Grid::entityCorners(Index p, int ent, std::array<Index, 4>& vs) const {
  const auto pv = vertices(p);
  vs = {-1, -1, -1, -1};
  if (ent < 16) {
    const auto& le = localEdges(type_[p])[ent];
    vs = {pv[le[0]], pv[le[1]], -1, -1};
    return 2;
  }
  const LocalFace& f = localFaces(type_[p])[ent - 16];
  for (int k = 0; k < f.size; ++k) vs[k] = pv[f.vertices[k]];
  return f.size;
}

/// The edges and faces of e's father (bits e, 16 + f) on which edges of e lie.
std::uint32_t Grid::fatherEntitiesOfEdges(Index e) const {
  const AdaptTables& tab = tables();
  const int pt = static_cast<int>(type_[father_[e]]);
  const auto& sup = tab.support[pt];
  std::uint32_t bits = 0;
  for (const auto& le : localEdges(type_[e])) {
    const int ent = tab.entity[pt][sup[inFather_[e][le[0]]] | sup[inFather_[e][le[1]]]];
    if (ent >= 0) bits |= 1u << ent;
  }
  return bits;
}

/// f(g) for every regular element g that has one of the entities `bits` of element p (as
/// fatherEntitiesOfEdges) as an edge or face (once per entity it has).
template <class F>
void Grid::forElementsWithEntities(const Context& ctx, Index p, std::uint32_t bits, F&& f) const {
  while (bits) {
    const int ent = std::countr_zero(bits);
    bits &= bits - 1;
    std::array<Index, 4> vs;
    const int k = entityCorners(p, ent, vs);
    for (Index g : ctx.around(vs[0]))
      if (hasEntity(g, vs, k)) f(g);
  }
}

// ------------------------------------------------------------------------------------------------
void Grid::propagate(Context& ctx) const {
  auto push = [&](Index g) {
    if (!ctx.red[g]) {
      ctx.red[g] = 1;
      ctx.queue.push_back(g);
    }
  };
  auto refinedEdge = [&](std::uint64_t key) {
    return edgeMidpoints_.find(key) >= 0 || ctx.newEdges.find(key) >= 0;
  };
  // Rule 2: more than half (ClosureRule::AllEdges: all) of the edges refined.
  const bool allEdges = closureRule_ == ClosureRule::AllEdges;
  auto mostlyRefined = [&](Index g) {
    const auto gv = vertices(g);
    const auto edges = localEdges(type_[g]);
    int count = 0;
    for (const auto& le : edges) count += refinedEdge(edgeKey(gv[le[0]], gv[le[1]]));
    const int n = static_cast<int>(edges.size());
    return allEdges ? count == n : 2 * count > n;
  };

  for (std::size_t qi = 0; qi < ctx.queue.size(); ++qi) {
    const Index e = ctx.queue[qi];
    const CellType t = type_[e];
    std::array<Index, 8> ev{};
    std::copy(vertices(e).begin(), vertices(e).end(), ev.begin());
    // Its edges become refined; regular leaves containing a newly refined edge get a new pattern.
    for (const auto& le : localEdges(t)) {
      const Index a = ev[le[0]], b = ev[le[1]];
      const std::uint64_t key = edgeKey(a, b);
      if (edgeMidpoints_.find(key) >= 0 || !ctx.newEdges.insert(key, 0).second) continue;
      for (Index g : ctx.around(a)) {
        if (ctx.red[g] || !hasEntity(g, {a, b, -1, -1}, 2)) continue;
        if (!ctx.touched[g]) {
          ctx.touched[g] = 1;
          ctx.touchedList.push_back(g);
        }
        if (mostlyRefined(g)) push(g);
      }
    }
    // Rule 1: a red child is refined; the edges and faces of its father on which its edges lie
    // must be refined in every regular element containing them.
    if (level_[e] == 0) continue;
    const Index p = father_[e];
    const std::uint32_t bits = fatherEntitiesOfEdges(e) & ~ctx.scanned[p];
    ctx.scanned[p] |= bits;
    forElementsWithEntities(ctx, p, bits, [&](Index g) {
      ctx.childCheck[g] = 1;
      push(g);
    });
  }
}

// propagate() when every regular element is red from the start (a uniform refinement): rule 2 and
// the touched elements concern elements that are not red, and rule 1 pushes only red ones, so what
// is left of it is rule 1's childCheck. It is set here on threads, father by father: the entities of
// a father scanned are those of all its queued children, as propagate() scans them child by child.
void Grid::propagateAllRed(Context& ctx, int threads) const {
  std::vector<Index> fathers;
  {
    std::vector<char> seen(static_cast<std::size_t>(ctx.numOld), 0);
    for (Index e : ctx.queue)
      if (level_[e] > 0 && !seen[father_[e]]) {
        seen[father_[e]] = 1;
        fathers.push_back(father_[e]);
      }
  }
  const auto nf = static_cast<Index>(fathers.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads)
  for (Index i = 0; i < nf; ++i) {
    const Index p = fathers[i];
    std::uint32_t bits = 0;
    for (int k = 0; k < numChildren_[p]; ++k)
      if (const Index c = firstChild_[p] + k; ctx.red[c]) bits |= fatherEntitiesOfEdges(c);
    forElementsWithEntities(ctx, p, bits, [&](Index g) {
      std::atomic_ref<char>(ctx.childCheck[g]).store(1, std::memory_order_relaxed);
    });
  }
}

// ------------------------------------------------------------------------------------------------
unsigned Grid::edgePattern(Index e) const {
  const auto ev = vertices(e);
  unsigned pattern = 0;
  int k = 0;
  for (const auto& le : localEdges(type_[e])) {
    if (edgeMidpoints_.find(edgeKey(ev[le[0]], ev[le[1]])) >= 0) pattern |= 1u << k;
    ++k;
  }
  return pattern;
}

void Grid::removeChildren(Index e) {
  for (int k = 0; k < numChildren_[e]; ++k) flags_[firstChild_[e] + k] |= kRemoved;
  refinement_[e] = Refinement::None;
  firstChild_[e] = -1;
  numChildren_[e] = 0;
  greenPattern_[e] = 0;
}

void Grid::refineRed(Index e) {
  const AdaptTables& tab = tables();
  const CellType t = type_[e];
  const int ti = static_cast<int>(t);
  const LocalPoints& lp = LocalPoints::of(t);
  std::array<Index, 8> ev{};
  std::array<Point, 8> x{};
  const int nv = lp.numCorners;
  for (int i = 0; i < nv; ++i) x[i] = x_[ev[i] = vertices(e)[i]];
  const int variant = t == CellType::Tetrahedron ? shortestTetDiagonal(std::span(x.data(), 4)) : 0;
  // Global vertices of the points the rule uses, created in point order.
  std::array<Index, LocalPoints::kMaxPoints> g{};
  for (int p = 0; p < lp.size; ++p) {
    if (!((tab.redUsed[ti][variant] >> p) & 1u)) continue;
    if (p < nv)
      g[p] = ev[p];
    else if (p < nv + lp.numEdges)
      g[p] = edgeMidpoint(e, p - nv);
    else if (p < lp.centroidPoint())
      g[p] = faceCentre(e, p - nv - lp.numEdges);
    else
      g[p] = centroid(e);
  }
  const auto& children = tab.red[ti][variant];
  const Index first = numElements();
  std::array<Index, 8> cv{};
  for (const CodedChild& c : children) {
    const int n = mesh::numVertices(c.type);
    for (int k = 0; k < n; ++k) cv[k] = g[c.points[k]];
    addElement(c.type, std::span<const Index>(cv.data(), n), e, level_[e] + 1,
               std::span<const std::uint8_t>(c.points.data(), n), false);
  }
  refinement_[e] = Refinement::Red;
  firstChild_[e] = first;
  numChildren_[e] = static_cast<std::uint8_t>(children.size());
}

/// The tables of refineRedOnThreads (see there): per red element (position i in `red`) its rule,
/// where its point entries start, the source of each point, the points it creates, and the first
/// numbers of its new vertices, children and connectivity.
struct Grid::RedPlan {
  explicit RedPlan(const std::vector<Index>& elements) : red(elements), nr(static_cast<Index>(elements.size())) {}
  const std::vector<Index>& red;
  Index nr = 0;
  std::vector<Index> position;          ///< of each old element in red (-1: not red)
  std::vector<std::uint8_t> variant;    ///< the red rule (tetrahedra: the shortest diagonal)
  std::vector<std::size_t> pointStart;  ///< the element's entries of `source` (its points after the corners)
  /// per point: a vertex (>= 0), or -1 - (creator's position * 32 + its local point)
  std::vector<std::int64_t> source;
  std::vector<std::uint32_t> created;  ///< bit p: the element creates point p
  std::vector<Index> firstVertex, firstElement;
  std::vector<std::size_t> firstConn;

  static std::int64_t code(Index j, int point) { return -1 - (static_cast<std::int64_t>(j) * 32 + point); }
  std::size_t slot(const Grid& g, Index j, int point) const {
    return pointStart[j] + static_cast<std::size_t>(point - LocalPoints::of(g.type_[red[j]]).numCorners);
  }
  std::vector<std::uint32_t> used;  ///< bit p: the element's rule uses point p
  bool uses(Index i, int point) const { return ((used[static_cast<std::size_t>(i)] >> point) & 1u) != 0; }
  /// The vertex of a source entry: the vertex itself, or the creator's: the vertex the point had
  /// before, or the one it creates.
  Index vertexOf(const Grid& g, std::int64_t s) const {
    if (s >= 0) return static_cast<Index>(s);
    const std::int64_t c = -1 - s;
    const auto j = static_cast<std::size_t>(c / 32);
    const int point = static_cast<int>(c % 32);
    const std::int64_t own = source[slot(g, static_cast<Index>(j), point)];
    if (own >= 0) return static_cast<Index>(own);
    return firstVertex[j] + std::popcount(created[j] & ((1u << point) - 1u));
  }
};

// refineRed() creates the new vertices of an element in local point order, each the first time an
// element needs it. On threads the same happens in three passes: (1) for each point of each red
// element, the vertex it had before this refinement, or else the element that creates it: the
// first red element (in `red` order) that uses the point, found among the regular elements around
// the point's smallest corner (ctx.around lists them in ascending order); (2) the numbers: an
// element's new vertices follow those of the elements before it, in its local point order, and its
// children follow theirs; (3) the vertices and children written at these numbers. The new points
// then go into the hash maps, on the threads too (FlatIndexMap::insertAbsentConcurrently): their
// keys are new and distinct, so what the maps return for a key does not depend on the order.
void Grid::refineRedOnThreads(const std::vector<Index>& red, const Context& ctx, int threads) {
  RedPlan plan(red);
  for (Index e : red) {
    if (level_[e] + 1 > 255) throw Error("Grid: more than 255 refinement levels");
    maxLevel_ = std::max(maxLevel_, level_[e] + 1);
  }
  redSources(plan, ctx, threads);
  numberRed(plan);
  writeRed(plan, threads);
  insertRedPoints(plan, threads);
}

/// refineRedOnThreads (1): the rule of each red element and the source of each of its points
/// (the existing vertex, or the element that creates it), and the points each element creates.
void Grid::redSources(RedPlan& plan, const Context& ctx, int threads) const {
  const std::vector<Index>& red = plan.red;
  const Index nr = plan.nr;
  std::vector<Index>& position = plan.position;
  position.assign(static_cast<std::size_t>(ctx.numOld), -1);
  for (Index i = 0; i < nr; ++i) position[red[i]] = i;
  // the rule of each element, and where its points' entries start (the points after the corners)
  std::vector<std::uint8_t>& variant = plan.variant;
  variant.assign(static_cast<std::size_t>(nr), 0);
  std::vector<std::size_t>& pointStart = plan.pointStart;
  pointStart.assign(static_cast<std::size_t>(nr) + 1, 0);
  for (Index i = 0; i < nr; ++i) {
    const LocalPoints& lp = LocalPoints::of(type_[red[i]]);
    pointStart[i + 1] = pointStart[i] + static_cast<std::size_t>(lp.size - lp.numCorners);
  }
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index i = 0; i < nr; ++i) {
    const Index e = red[i];
    if (type_[e] != CellType::Tetrahedron) continue;
    std::array<Point, 4> x;
    for (int k = 0; k < 4; ++k) x[k] = x_[vertices(e)[k]];
    variant[i] = static_cast<std::uint8_t>(shortestTetDiagonal(std::span<const Point>(x.data(), 4)));
  }
  // (1) per point: a vertex (>= 0), or -1 - (creator's position * 32 + its local point). An edge
  // point is decided at the edge's smaller vertex, a face point at the face's smallest vertex: of the
  // red elements around that vertex (ascending, so in `red` order) that use the point, the first
  // creates it. Here every entry is written once, at the corner of its edge or face (each corner
  // is handled by the first red element around it); below, each element rewrites its own entries.
  plan.source.assign(pointStart[nr], 0);
  plan.used.resize(static_cast<std::size_t>(nr));
  for (Index i = 0; i < nr; ++i)
    plan.used[static_cast<std::size_t>(i)] = tables().redUsed[static_cast<int>(type_[red[i]])][variant[i]];
  const auto entry = [&](Index j, int point) -> std::int64_t& { return plan.source[plan.slot(*this, j, point)]; };
  const auto code = [](Index j, int point) { return RedPlan::code(j, point); };
  const auto uses = [&](Index i, int point) { return plan.uses(i, point); };
#pragma omp parallel num_threads(threads)
  {
    struct Candidate {
      std::array<Index, 4> key;  // the other end of the edge, or the face's corners (sorted)
      Index j;
      int point;
    };
    std::vector<Candidate> candidates;
#pragma omp for schedule(dynamic, 256)
    for (Index i = 0; i < nr; ++i)
      for (const Index a : vertices(red[i])) {
        // each corner once: by the first red element around it
        if (const auto around = ctx.around(a);
            *std::find_if(around.begin(), around.end(), [&](Index g) { return position[g] >= 0; }) != red[i])
          continue;
        candidates.clear();
        for (Index g : ctx.around(a)) {
          const Index j = position[g];
          if (j < 0) continue;
          const CellType t = type_[g];
          const LocalPoints& lp = LocalPoints::of(t);
          const auto gv = vertices(g);
          const int la = localIndex(gv, a);
          const auto edges = localEdges(t);
          for (int k = 0; k < lp.numEdges; ++k) {
            const auto& le = edges[k];
            if (le[0] != la && le[1] != la) continue;
            const Index b = gv[le[0] == la ? le[1] : le[0]];
            if (b < a || !uses(j, lp.edgePoint(k))) continue;
            candidates.push_back({{b, -1, -1, -1}, j, lp.edgePoint(k)});
          }
          const auto faces = localFaces(t);
          for (int f = 0; f < lp.numFaces; ++f) {
            if (faces[f].size != 4 || !uses(j, lp.facePoint(f))) continue;
            std::array<Index, 4> key{};
            bool smallest = false;  // a is a corner of the face and the smallest
            for (int k = 0; k < 4; ++k) {
              key[k] = gv[faces[f].vertices[k]];
              smallest = smallest || key[k] == a;
            }
            if (!smallest || *std::min_element(key.begin(), key.end()) != a) continue;
            std::sort(key.begin(), key.end());
            candidates.push_back({key, j, lp.facePoint(f)});
          }
        }
        // the first candidate of each key creates its point (the candidates are in `red` order)
        for (std::size_t c = 0; c < candidates.size(); ++c) {
          std::size_t first = c;
          for (std::size_t k = 0; k < c; ++k)
            if (candidates[k].key == candidates[c].key) {
              first = k;
              break;
            }
          entry(candidates[c].j, candidates[c].point) = code(candidates[first].j, candidates[first].point);
        }
      }
  }
  // then each element: the points it creates, unless they exist already (looked up by the creator
  // only; the others find the vertex at the creator's entry in (3)), and its centroid
  std::vector<std::uint32_t>& created = plan.created;
  created.assign(static_cast<std::size_t>(nr), 0);  // bit p: the element creates point p
#pragma omp parallel for schedule(dynamic, 1024) num_threads(threads)
  for (Index i = 0; i < nr; ++i) {
    const Index e = red[i];
    const CellType t = type_[e];
    const LocalPoints& lp = LocalPoints::of(t);
    const auto ev = vertices(e);
    std::uint32_t mine = 0;
    for (int p = lp.numCorners; p < lp.size; ++p) {
      if (!uses(i, p)) continue;
      std::int64_t& out = entry(i, p);
      Index existing = -1;
      if (p < lp.centroidPoint()) {
        if (out != code(i, p)) continue;  // another element creates it
        if (p < lp.numCorners + lp.numEdges) {
          const auto& le = localEdges(t)[p - lp.numCorners];
          existing = edgeMidpoints_.find(edgeKey(ev[le[0]], ev[le[1]]));
        } else {
          existing = faceCentres_.find(faceKey(e, p - lp.numCorners - lp.numEdges));
        }
      } else {
        existing = centroids_.find(static_cast<std::uint64_t>(e));
      }
      if (existing >= 0) {
        out = existing;
      } else {
        out = code(i, p);
        mine |= 1u << p;
      }
    }
    created[static_cast<std::size_t>(i)] = mine;
  }
}

/// refineRedOnThreads (2): the numbers of each element's new vertices (after those of the elements
/// before it, in its local point order), children and connectivity; the arrays grown to them.
void Grid::numberRed(RedPlan& plan) {
  const std::vector<Index>& red = plan.red;
  const Index nr = plan.nr;
  std::vector<Index>& firstVertex = plan.firstVertex;
  std::vector<Index>& firstElement = plan.firstElement;
  std::vector<std::size_t>& firstConn = plan.firstConn;
  firstVertex.resize(static_cast<std::size_t>(nr) + 1);
  firstElement.resize(static_cast<std::size_t>(nr) + 1);
  firstConn.resize(static_cast<std::size_t>(nr) + 1);
  firstVertex[0] = numVertices();
  firstElement[0] = numElements();
  firstConn[0] = conn_.size();
  for (Index i = 0; i < nr; ++i) {
    const auto& children = tables().red[static_cast<int>(type_[red[i]])][plan.variant[i]];
    std::size_t conn = 0;
    for (const CodedChild& c : children) conn += static_cast<std::size_t>(mesh::numVertices(c.type));
    firstVertex[i + 1] = firstVertex[i] + std::popcount(plan.created[i]);
    firstElement[i + 1] = firstElement[i] + static_cast<Index>(children.size());
    firstConn[i + 1] = firstConn[i] + conn;
  }
  const auto nv = static_cast<std::size_t>(firstVertex[nr]), ne = static_cast<std::size_t>(firstElement[nr]);
  reserve(firstElement[nr], firstConn[nr], firstVertex[nr]);  // room for the closures too (geometric growth)
  x_.resize(nv);
  vertexCreator_.resize(nv);
  vertexPoint_.resize(nv);
  boundaryVertex_.resize(nv);
  type_.resize(ne);
  level_.resize(ne);
  flags_.resize(ne);
  refinement_.resize(ne);
  father_.resize(ne);
  firstChild_.resize(ne);
  numChildren_.resize(ne);
  connOffset_.resize(ne);
  conn_.resize(firstConn[nr]);
  inFather_.resize(ne);
  greenPattern_.resize(ne);
  marks_.resize(ne);
}

/// refineRedOnThreads (3): the new vertices and the children, as refineRed() writes them.
void Grid::writeRed(const RedPlan& plan, int threads) {
  const std::vector<Index>& red = plan.red;
  const Index nr = plan.nr;
#pragma omp parallel num_threads(threads)
  {
    std::vector<int> ids;
#pragma omp for schedule(static)
    for (Index i = 0; i < nr; ++i) {
      const Index e = red[i];
      const CellType t = type_[e];
      const LocalPoints& lp = LocalPoints::of(t);
      const int nvc = lp.numCorners;
      std::array<Index, 8> ev{};
      std::copy(vertices(e).begin(), vertices(e).end(), ev.begin());
      std::array<Index, LocalPoints::kMaxPoints> g{};
      for (int p = 0; p < lp.size; ++p) {
        if (p < nvc) {
          g[p] = ev[p];
          continue;
        }
        if (!plan.uses(i, p)) continue;
        g[p] = plan.vertexOf(*this, plan.source[plan.pointStart[i] + static_cast<std::size_t>(p - nvc)]);
        if (!((plan.created[i] >> p) & 1u)) continue;
        Point x;
        bool boundary = false;
        if (p < nvc + lp.numEdges) {  // as edgeMidpoint()
          x = edgePointPosition(e, p - nvc, ids);
          boundary = !ids.empty();
        } else if (p < lp.centroidPoint()) {  // as faceCentre()
          const int localFace = p - nvc - lp.numEdges;
          x = facePointPosition(e, localFace, faceKey(e, localFace), boundary);
        } else {  // as centroid()
          x = pointPosition(e, p);
        }
        const auto v = static_cast<std::size_t>(g[p]);
        x_[v] = x;
        vertexCreator_[v] = e;
        vertexPoint_[v] = static_cast<std::uint8_t>(p);
        boundaryVertex_[v] = boundary ? 1 : 0;
      }
      const auto& children = tables().red[static_cast<int>(t)][plan.variant[i]];
      Index child = plan.firstElement[i];
      std::size_t conn = plan.firstConn[i];
      for (const CodedChild& c : children) {
        const int n = mesh::numVertices(c.type);
        type_[child] = c.type;
        level_[child] = static_cast<std::uint8_t>(level_[e] + 1);
        flags_[child] = 0;
        refinement_[child] = Refinement::None;
        father_[child] = e;
        firstChild_[child] = -1;
        numChildren_[child] = 0;
        connOffset_[child] = static_cast<Index>(conn);
        for (int k = 0; k < n; ++k) conn_[conn + k] = g[c.points[k]];
        std::array<std::uint8_t, 8> points{};
        std::copy(c.points.begin(), c.points.begin() + n, points.begin());
        inFather_[child] = points;
        greenPattern_[child] = 0;
        marks_[child] = 0;
        conn += static_cast<std::size_t>(n);
        ++child;
      }
      refinement_[e] = Refinement::Red;
      firstChild_[e] = plan.firstElement[i];
      numChildren_[e] = static_cast<std::uint8_t>(children.size());
    }
  }
}

/// refineRedOnThreads, last: the new points in the hash maps.
void Grid::insertRedPoints(const RedPlan& plan, int threads) {
  const std::vector<Index>& red = plan.red;
  const Index nr = plan.nr;
  // the new points in the hash maps: their keys are new and distinct (each point has one creator),
  // so the threads insert them at once; what the maps return for a key does not depend on the order
  std::size_t newEdges = 0, newFaces = 0, newCentroids = 0;
  for (Index i = 0; i < nr; ++i) {
    const LocalPoints& lp = LocalPoints::of(type_[red[i]]);
    const std::uint32_t bits = plan.created[static_cast<std::size_t>(i)];
    const std::uint32_t edgeBits = ((1u << lp.numEdges) - 1u) << lp.numCorners;
    const std::uint32_t faceBits = ((1u << lp.numFaces) - 1u) << (lp.numCorners + lp.numEdges);
    newEdges += static_cast<std::size_t>(std::popcount(bits & edgeBits));
    newFaces += static_cast<std::size_t>(std::popcount(bits & faceBits));
    newCentroids += (bits >> lp.centroidPoint()) & 1u;
  }
  edgeMidpoints_.reserve(edgeMidpoints_.size() + newEdges);
  faceCentres_.reserve(faceCentres_.size() + newFaces);
  centroids_.reserve(centroids_.size() + newCentroids);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (Index i = 0; i < nr; ++i) {
    std::uint32_t bits = plan.created[static_cast<std::size_t>(i)];
    if (bits == 0) continue;
    const Index e = red[i];
    const CellType t = type_[e];
    const LocalPoints& lp = LocalPoints::of(t);
    const auto ev = vertices(e);
    Index v = plan.firstVertex[i];
    while (bits) {
      const int p = std::countr_zero(bits);
      bits &= bits - 1;
      if (p < lp.numCorners + lp.numEdges) {
        const auto& le = localEdges(t)[p - lp.numCorners];
        edgeMidpoints_.insertAbsentConcurrently(edgeKey(ev[le[0]], ev[le[1]]), v);
      } else if (p < lp.centroidPoint()) {
        faceCentres_.insertAbsentConcurrently(faceKey(e, p - lp.numCorners - lp.numEdges), v);
      } else {
        centroids_.insertAbsentConcurrently(static_cast<std::uint64_t>(e), v);
      }
      ++v;
    }
  }
  edgeMidpoints_.addToSize(newEdges);
  faceCentres_.addToSize(newFaces);
  centroids_.addToSize(newCentroids);
}

void Grid::closeGreen(Index e, unsigned pattern, std::vector<LocalChild>& children) {
  closureRule(e, pattern, children);
  const CellType t = type_[e];
  const LocalPoints& lp = LocalPoints::of(t);
  const int nv = lp.numCorners;
  std::array<Index, LocalPoints::kMaxPoints> g;
  g.fill(-1);
  std::array<Index, 8> ev{};
  std::copy(vertices(e).begin(), vertices(e).end(), ev.begin());
  const Index first = numElements();
  std::array<Index, 8> cv{};
  for (const LocalChild& c : children) {
    const int n = mesh::numVertices(c.type);
    for (int k = 0; k < n; ++k) {
      const int p = c.points[k];
      if (g[p] < 0) {
        if (p < nv) {
          g[p] = ev[p];
        } else if (p < nv + lp.numEdges) {
          const auto& le = localEdges(t)[p - nv];
          g[p] = edgeMidpoints_.find(edgeKey(ev[le[0]], ev[le[1]]));
        } else if (p < lp.centroidPoint()) {
          g[p] = faceCentre(e, p - nv - lp.numEdges);
        } else {
          g[p] = centroid(e);
        }
      }
      cv[k] = g[p];
    }
    addElement(c.type, std::span<const Index>(cv.data(), n), e, level_[e] + 1,
               std::span<const std::uint8_t>(c.points.data(), n), true);
  }
  refinement_[e] = Refinement::Green;
  firstChild_[e] = first;
  numChildren_[e] = static_cast<std::uint8_t>(children.size());
  greenPattern_[e] = static_cast<std::uint16_t>(pattern);
}

// ------------------------------------------------------------------------------------------------
// New vertices.
Index Grid::edgeMidpoint(Index e, int localEdge) {
  const auto& le = localEdges(type_[e])[localEdge];
  const std::uint64_t key = edgeKey(vertices(e)[le[0]], vertices(e)[le[1]]);
  if (const Index m = edgeMidpoints_.find(key); m >= 0) return m;
  std::vector<int> ids;
  const Point x = edgePointPosition(e, localEdge, ids);
  const Index m = addVertex(x, e, LocalPoints::of(type_[e]).edgePoint(localEdge), !ids.empty());
  edgeMidpoints_.insert(key, m);
  return m;
}

/// The midpoint of edge localEdge of e (projected where the edge lies on a boundary with a
/// projection), and in ids the boundary ids of the edge: the vertex edgeMidpoint() creates.
Point Grid::edgePointPosition(Index e, int localEdge, std::vector<int>& ids) const {
  const auto& le = localEdges(type_[e])[localEdge];
  Index a = vertices(e)[le[0]], b = vertices(e)[le[1]];
  if (a > b) std::swap(a, b);
  Point x = 0.5 * (x_[a] + x_[b]);
  ids.clear();
  if (boundaryVertex_[a] && boundaryVertex_[b]) edgeBoundaryIds(e, localEdge, ids);
  if (!ids.empty() && !projections_.empty()) x = project(x, ids);
  return x;
}

/// Boundary ids of the boundary faces containing an edge, found through the hierarchy (the
/// neighbours around the edge may not exist yet): an edge of a child lies inside its father, in
/// the interior of one of its faces (boundary iff that face is), or on one of its edges (recurse);
/// coarse edges have their ids from the coarse boundary faces.
void Grid::edgeBoundaryIds(Index e, int localEdge, std::vector<int>& ids) const {
  const AdaptTables& tab = tables();
  while (level_[e] > 0) {
    const auto& le = localEdges(type_[e])[localEdge];
    const Index p = father_[e];
    const int pt = static_cast<int>(type_[p]);
    const int ent = tab.entity[pt][tab.support[pt][inFather_[e][le[0]]] |
                                   tab.support[pt][inFather_[e][le[1]]]];
    if (ent < 0) return;
    if (ent >= 16) {
      if (const int id = boundaryId(p, ent - 16); id >= 0) ids.push_back(id);
      return;
    }
    localEdge = ent;
    e = p;
  }
  const auto& le = localEdges(type_[e])[localEdge];
  const std::uint64_t key = edgeKey(vertices(e)[le[0]], vertices(e)[le[1]]);
  for (auto it = std::lower_bound(coarseEdgeIds_.begin(), coarseEdgeIds_.end(),
                                  std::pair<std::uint64_t, int>{key, INT_MIN});
       it != coarseEdgeIds_.end() && it->first == key; ++it)
    ids.push_back(it->second);
}

Index Grid::faceCentre(Index e, int localFace) {
  const std::array<Index, 4> key = faceKey(e, localFace);
  if (const Index c = faceCentres_.find(key); c >= 0) return c;
  bool boundary = false;
  const Point x = facePointPosition(e, localFace, key, boundary);
  const Index c = addVertex(x, e, LocalPoints::of(type_[e]).facePoint(localFace), boundary);
  faceCentres_.insert(key, c);
  return c;
}

/// The corners of quadrilateral face localFace of e, ascending: the key of its centre.
std::array<Index, 4> Grid::faceKey(Index e, int localFace) const {
  const LocalFace& f = localFaces(type_[e])[localFace];
  std::array<Index, 4> key{};
  for (int k = 0; k < 4; ++k) key[k] = vertices(e)[f.vertices[k]];
  for (int i = 1; i < 4; ++i)  // insertion sort of 4
    for (int j = i; j > 0 && key[j - 1] > key[j]; --j) std::swap(key[j - 1], key[j]);
  return key;
}

/// The centre of quadrilateral face localFace of e (key: faceKey), projected where the face lies on
/// a boundary with a projection, and whether it lies on the boundary: the vertex faceCentre() creates.
Point Grid::facePointPosition(Index e, int localFace, const std::array<Index, 4>& key, bool& boundary) const {
  Point x = 0.25 * (((x_[key[0]] + x_[key[1]]) + x_[key[2]]) + x_[key[3]]);
  boundary = false;
  if (boundaryVertex_[key[0]] && boundaryVertex_[key[1]] && boundaryVertex_[key[2]] && boundaryVertex_[key[3]]) {
    const int id = boundaryId(e, localFace);
    boundary = id >= 0;
    if (boundary && !projections_.empty()) x = project(x, {id});
  }
  return x;
}

Index Grid::centroid(Index e) {
  const std::uint64_t key = static_cast<std::uint64_t>(e);
  if (const Index c = centroids_.find(key); c >= 0) return c;
  const int p = LocalPoints::of(type_[e]).centroidPoint();
  const Index c = addVertex(pointPosition(e, p), e, p, false);
  centroids_.insert(key, c);
  return c;
}

}  // namespace obs::mesh
