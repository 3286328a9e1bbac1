// Green closure rules: how an unrefined element with some refined edges is split so that it
// matches its refined neighbours (see the file comment of Grid.hpp for the rules).
//
// The closure is a cone from an interior point over the element's faces, each face split by a
// rule that depends only on which of its edges are refined (and, for the one choice it has, on
// global vertex data), so the two cells sharing a face split it the same way. This is the
// classical construction of closure elements for mixed meshes (cf. UG's pyramid/tetrahedron
// closure, Bastian et al. 1997; for simplices with a refined face only it reduces to the cone from
// the opposite corner, i.e. Bey's green rules, Bey 1995).
#include <algorithm>

#include "obs/mesh/Grid.hpp"
#include "obs/mesh/MeshTopology.hpp"

namespace obs::mesh {
namespace {

/// A piece of a split face, in local point codes of the cell, oriented like the face.
struct Piece {
  int size;
  std::array<std::uint8_t, 4> p;
};

/// The pieces of one face (at most 7: a quadrilateral fan over three halved edges).
struct Pieces {
  std::array<Piece, 8> items;
  int count = 0;
  void push_back(const Piece& p) { items[count++] = p; }
  void clear() { count = 0; }
  const Piece* begin() const { return items.data(); }
  const Piece* end() const { return items.data() + count; }
};

/// Splits a face with corners c[0..n-1] (cell codes, in face orientation); mid[j] is the code of
/// the midpoint of face edge j (corners j, j+1) or -1 if that edge is not refined; centre is the
/// code of the face centre. `atA(a, m2, m1, c)` decides the diagonal of the quadrilateral
/// a, m1, m2, c left over by a triangle with two refined edges: true for a-m2, false for m1-c.
template <class Choose>
void splitFace(int n, const std::uint8_t* c, const int* mid, std::uint8_t centre, Choose&& atA,
               Pieces& out) {
  int k = 0;
  for (int j = 0; j < n; ++j) k += mid[j] >= 0;
  auto tri = [&](int a, int b, int d) {
    out.push_back({3, {static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(b),
                       static_cast<std::uint8_t>(d), 0}});
  };
  auto quad = [&](int a, int b, int d, int e) {
    out.push_back({4, {static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(b),
                       static_cast<std::uint8_t>(d), static_cast<std::uint8_t>(e)}});
  };
  if (n == 3) {
    if (k == 0) {
      tri(c[0], c[1], c[2]);
    } else if (k == 1) {  // bisection from the corner opposite to the refined edge
      const int j = mid[0] >= 0 ? 0 : mid[1] >= 0 ? 1 : 2;
      const int a = c[j], b = c[(j + 1) % 3], o = c[(j + 2) % 3];
      tri(a, mid[j], o);
      tri(mid[j], b, o);
    } else if (k == 2) {  // corner triangle at the common corner b, quadrilateral a m1 m2 c cut
      const int u = mid[0] < 0 ? 0 : mid[1] < 0 ? 1 : 2;  // the unrefined edge
      const int j = (u + 1) % 3;
      const int a = c[j], b = c[(j + 1) % 3], cc = c[(j + 2) % 3];
      const int m1 = mid[j], m2 = mid[(j + 1) % 3];
      tri(m1, b, m2);
      if (atA(a, m2, m1, cc)) {
        tri(a, m1, m2);
        tri(a, m2, cc);
      } else {
        tri(a, m1, cc);
        tri(m1, m2, cc);
      }
    } else {  // red
      tri(c[0], mid[0], mid[2]);
      tri(mid[0], c[1], mid[1]);
      tri(mid[2], mid[1], c[2]);
      tri(mid[0], mid[1], mid[2]);
    }
    return;
  }
  if (k == 0) {
    quad(c[0], c[1], c[2], c[3]);
  } else if (k == 4) {  // red: the four quarters through the centre
    quad(c[0], mid[0], centre, mid[3]);
    quad(mid[0], c[1], mid[1], centre);
    quad(centre, mid[1], c[2], mid[2]);
    quad(mid[3], centre, mid[2], c[3]);
  } else {  // fan of triangles from the centre over the (halved) edges
    for (int j = 0; j < 4; ++j) {
      const int a = c[j], b = c[(j + 1) % 4];
      if (mid[j] >= 0) {
        tri(a, mid[j], centre);
        tri(mid[j], b, centre);
      } else {
        tri(a, b, centre);
      }
    }
  }
}

}  // namespace

void Grid::closureRule(Index e, unsigned pattern, std::vector<LocalChild>& out) const {
  out.clear();
  const CellType t = type_[e];
  const LocalPoints& lp = LocalPoints::of(t);
  const auto ev = vertices(e);
  // Global vertex of a corner or edge-midpoint code (only these enter the diagonal choice).
  auto global = [&](int code) {
    if (code < lp.numCorners) return ev[code];
    const int edge = code - lp.numCorners;
    const auto& le = localEdges(t)[edge];
    const Index a = ev[le[0]], b = ev[le[1]];
    return edgeMidpoints_.find(edgeKey(a, b));
  };
  // Shorter diagonal; tie: the one at the corner that comes first in lexicographic order of the
  // coordinates, which depends on the geometry only, not on the vertex numbers (a distributed grid
  // numbers its vertices differently on every rank and must split the face as one process does).
  // Both cells of a face evaluate the same two distances (of the same vertex pairs), so they agree.
  auto atA = [&](int a, int m2, int m1, int c) {
    const Index ga = global(a), gm2 = global(m2), gm1 = global(m1), gc = global(c);
    const double la = (x_[ga] - x_[gm2]).squaredNorm(), lc = (x_[gm1] - x_[gc]).squaredNorm();
    if (la != lc) return la < lc;
    return std::lexicographical_compare(x_[ga].data(), x_[ga].data() + 3, x_[gc].data(), x_[gc].data() + 3);
  };
  auto refined = [&](int edge) { return ((pattern >> edge) & 1u) != 0; };
  Pieces pieces;
  std::array<std::uint8_t, 4> corners{};
  std::array<int, 4> mid{};
  auto faceSplit = [&](std::span<const int> fv, std::uint8_t centre) {
    const int n = static_cast<int>(fv.size());
    for (int j = 0; j < n; ++j) {
      corners[j] = static_cast<std::uint8_t>(fv[j]);
      const int edge = lp.edge(fv[j], fv[(j + 1) % n]);
      mid[j] = refined(edge) ? lp.edgePoint(edge) : -1;
    }
    splitFace(n, corners.data(), mid.data(), centre, atA, pieces);
  };

  if (mesh::dimension(t) == 2) {  // the cell is its own face
    static constexpr int order[] = {0, 1, 2, 3};
    faceSplit(std::span<const int>(order, lp.numCorners),
              static_cast<std::uint8_t>(lp.centroidPoint()));
    for (const Piece& p : pieces)
      out.push_back({p.size == 3 ? CellType::Triangle : CellType::Quadrilateral,
                     {p.p[0], p.p[1], p.p[2], p.p[3], 0, 0, 0, 0}});
    return;
  }

  // Apex: a corner of a tetrahedron or the apex of a pyramid that touches no refined edge (all
  // faces at it are triangles, split by bisection from it at most); otherwise the centroid.
  int apex = -1;
  if (t == CellType::Tetrahedron || t == CellType::Pyramid) {
    for (int v = t == CellType::Pyramid ? 4 : 0; v < lp.numCorners && apex < 0; ++v) {
      bool free = true;
      for (int edge = 0; edge < lp.numEdges && free; ++edge) {
        const auto& le = localEdges(t)[edge];
        free = !(refined(edge) && (le[0] == v || le[1] == v));
      }
      if (free) apex = v;
    }
  }
  const std::uint8_t top =
      static_cast<std::uint8_t>(apex >= 0 ? apex : lp.centroidPoint());
  const auto faces = localFaces(t);
  for (int f = 0; f < lp.numFaces; ++f) {
    const auto fv = faces[f].span();
    if (apex >= 0 && std::find(fv.begin(), fv.end(), apex) != fv.end()) continue;
    pieces.clear();
    faceSplit(fv, static_cast<std::uint8_t>(lp.facePoint(f)));
    for (const Piece& p : pieces) {
      // The piece is oriented outward; the cone over it with the top inside is positive as
      // tetrahedron (p0, p2, p1, top) or pyramid (p0, p3, p2, p1, top).
      if (p.size == 3)
        out.push_back({CellType::Tetrahedron, {p.p[0], p.p[2], p.p[1], top, 0, 0, 0, 0}});
      else
        out.push_back({CellType::Pyramid, {p.p[0], p.p[3], p.p[2], p.p[1], top, 0, 0, 0}});
    }
  }
}

}  // namespace obs::mesh
