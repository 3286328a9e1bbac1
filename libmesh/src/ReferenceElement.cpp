// Reference elements and first-order shape functions of the six cell types (and segments).
// Conventions are documented in ReferenceElement.hpp; each type is one table plus three kernels.
#include "obs/mesh/ReferenceElement.hpp"

#include <algorithm>

#include "obs/mesh/MeshTopology.hpp"

namespace obs::mesh {
namespace {

// ------------------------------------------------------------------------------------------------
// Segment [0,1]: P1
void segValues(const Point& p, double* f) {
  f[0] = 1 - p[0];
  f[1] = p[0];
}
void segGradients(const Point&, double* g) {
  g[0] = -1;
  g[1] = 1;
}
void segHessians(const Point&, double* h) { std::fill(h, h + 2, 0.0); }

// ------------------------------------------------------------------------------------------------
// Triangle (0,0) (1,0) (0,1): P1
void triValues(const Point& p, double* f) {
  f[0] = 1 - p[0] - p[1];
  f[1] = p[0];
  f[2] = p[1];
}
void triGradients(const Point&, double* g) {
  const double G[6] = {-1, -1, 1, 0, 0, 1};
  std::copy(G, G + 6, g);
}
void triHessians(const Point&, double* h) { std::fill(h, h + 12, 0.0); }

// ------------------------------------------------------------------------------------------------
// Quadrilateral [0,1]^2 counter-clockwise: Q1
void quadValues(const Point& p, double* f) {
  const double x = p[0], y = p[1];
  f[0] = (1 - x) * (1 - y);
  f[1] = x * (1 - y);
  f[2] = x * y;
  f[3] = (1 - x) * y;
}
void quadGradients(const Point& p, double* g) {
  const double x = p[0], y = p[1];
  const double G[8] = {-(1 - y), -(1 - x), (1 - y), -x, y, x, -y, (1 - x)};
  std::copy(G, G + 8, g);
}
void quadHessians(const Point&, double* h) {
  // only the mixed derivative d2/dxdy is non-zero: +1, -1, +1, -1
  const double s[4] = {1, -1, 1, -1};
  for (int i = 0; i < 4; ++i) {
    h[4 * i + 0] = 0;
    h[4 * i + 1] = s[i];
    h[4 * i + 2] = s[i];
    h[4 * i + 3] = 0;
  }
}

// ------------------------------------------------------------------------------------------------
// Tetrahedron (0,0,0) (1,0,0) (0,1,0) (0,0,1): P1
void tetValues(const Point& p, double* f) {
  f[0] = 1 - p[0] - p[1] - p[2];
  f[1] = p[0];
  f[2] = p[1];
  f[3] = p[2];
}
void tetGradients(const Point&, double* g) {
  const double G[12] = {-1, -1, -1, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  std::copy(G, G + 12, g);
}
void tetHessians(const Point&, double* h) { std::fill(h, h + 36, 0.0); }

// ------------------------------------------------------------------------------------------------
// Hexahedron [0,1]^3: Q1. Corner i has coordinates (cx[i], cy[i], cz[i]).
constexpr int hx[8] = {0, 1, 1, 0, 0, 1, 1, 0};
constexpr int hy[8] = {0, 0, 1, 1, 0, 0, 1, 1};
constexpr int hz[8] = {0, 0, 0, 0, 1, 1, 1, 1};
// 1D factor and derivative: c = 0 -> 1 - t, c = 1 -> t
inline double lin(int c, double t) { return c ? t : 1 - t; }
inline double dlin(int c) { return c ? 1.0 : -1.0; }

void hexValues(const Point& p, double* f) {
  for (int i = 0; i < 8; ++i) f[i] = lin(hx[i], p[0]) * lin(hy[i], p[1]) * lin(hz[i], p[2]);
}
void hexGradients(const Point& p, double* g) {
  for (int i = 0; i < 8; ++i) {
    const double a = lin(hx[i], p[0]), b = lin(hy[i], p[1]), c = lin(hz[i], p[2]);
    g[3 * i + 0] = dlin(hx[i]) * b * c;
    g[3 * i + 1] = a * dlin(hy[i]) * c;
    g[3 * i + 2] = a * b * dlin(hz[i]);
  }
}
void hexHessians(const Point& p, double* h) {
  for (int i = 0; i < 8; ++i) {
    const double a = lin(hx[i], p[0]), b = lin(hy[i], p[1]), c = lin(hz[i], p[2]);
    const double da = dlin(hx[i]), db = dlin(hy[i]), dc = dlin(hz[i]);
    double* H = h + 9 * i;
    H[0] = 0;          H[1] = da * db * c; H[2] = da * b * dc;
    H[3] = H[1];       H[4] = 0;           H[5] = a * db * dc;
    H[6] = H[2];       H[7] = H[5];        H[8] = 0;
  }
}

// ------------------------------------------------------------------------------------------------
// Prism: triangle (x, y) x segment z; vertices 0-2 at z = 0, 3-5 above them at z = 1.
void prismValues(const Point& p, double* f) {
  double t[3];
  triValues(p, t);
  for (int i = 0; i < 3; ++i) {
    f[i] = t[i] * (1 - p[2]);
    f[i + 3] = t[i] * p[2];
  }
}
void prismGradients(const Point& p, double* g) {
  double t[3];
  triValues(p, t);
  const double tg[6] = {-1, -1, 1, 0, 0, 1};
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 2; ++k) {
      g[3 * i + k] = tg[2 * i + k] * (1 - p[2]);
      g[3 * (i + 3) + k] = tg[2 * i + k] * p[2];
    }
    g[3 * i + 2] = -t[i];
    g[3 * (i + 3) + 2] = t[i];
  }
}
void prismHessians(const Point&, double* h) {
  // d2/dz dx_k = +-(triangle gradient); all other second derivatives vanish
  const double tg[6] = {-1, -1, 1, 0, 0, 1};
  std::fill(h, h + 54, 0.0);
  for (int i = 0; i < 6; ++i) {
    const int j = i % 3;
    const double s = i < 3 ? -1.0 : 1.0;
    double* H = h + 9 * i;
    for (int k = 0; k < 2; ++k) {
      H[3 * k + 2] = s * tg[2 * j + k];
      H[3 * 2 + k] = s * tg[2 * j + k];
    }
  }
}

// ------------------------------------------------------------------------------------------------
// Pyramid: base [0,1]^2 at z = 0 (counter-clockwise), apex (0,0,1). With q = x y / (1 - z):
//   phi_0 = (1-z) - x - y + q,  phi_1 = x - q,  phi_2 = q,  phi_3 = y - q,  phi_4 = z.
// Bilinear on the base, linear on the four triangular faces. At the apex (z -> 1) q and its
// derivatives are bounded but direction dependent; we evaluate the limit along x = y = 0.
constexpr double kApexEps = 1e-14;
constexpr double qSign[5] = {1, -1, 1, -1, 0};

void pyrValues(const Point& p, double* f) {
  const double x = p[0], y = p[1], z = p[2], w = 1 - z;
  const double q = w > kApexEps ? x * y / w : 0.0;
  f[0] = w - x - y + q;
  f[1] = x - q;
  f[2] = q;
  f[3] = y - q;
  f[4] = z;
}
void pyrGradients(const Point& p, double* g) {
  const double x = p[0], y = p[1], z = p[2], w = 1 - z;
  double qx = 0, qy = 0, qz = 0;
  if (w > kApexEps) {
    qx = y / w;
    qy = x / w;
    qz = x * y / (w * w);
  }
  const double lin[5][3] = {{-1, -1, -1}, {1, 0, 0}, {0, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int i = 0; i < 5; ++i) {
    g[3 * i + 0] = lin[i][0] + qSign[i] * qx;
    g[3 * i + 1] = lin[i][1] + qSign[i] * qy;
    g[3 * i + 2] = lin[i][2] + qSign[i] * qz;
  }
}
void pyrHessians(const Point& p, double* h) {
  const double x = p[0], y = p[1], z = p[2], w = 1 - z;
  double Q[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  if (w > kApexEps) {
    const double w2 = w * w;
    Q[1] = Q[3] = 1 / w;           // q_xy
    Q[2] = Q[6] = y / w2;          // q_xz
    Q[5] = Q[7] = x / w2;          // q_yz
    Q[8] = 2 * x * y / (w2 * w);   // q_zz
  }
  for (int i = 0; i < 5; ++i)
    for (int k = 0; k < 9; ++k) h[9 * i + k] = qSign[i] * Q[k];
}

// ------------------------------------------------------------------------------------------------
/// One reference element; its edge and face tables are the topology tables of MeshTopology.hpp
/// (constant-initialised, so safe to read during static initialisation).
ReferenceElement make(CellType type, double volume, Point centroid, std::vector<Point> vertices,
                      ReferenceElement::Kernel v, ReferenceElement::Kernel g,
                      ReferenceElement::Kernel h) {
  ReferenceElement e;
  e.type = type;
  e.dim = dimension(type);
  e.numVertices = static_cast<int>(vertices.size());
  e.volume = volume;
  e.centroid = centroid;
  e.vertices = std::move(vertices);
  for (const auto& edge : localEdges(type)) e.edges.push_back(edge);
  for (const LocalFace& f : localFaces(type))
    e.faces.push_back({f.type, std::vector<int>(f.span().begin(), f.span().end())});
  e.values_ = v;
  e.gradients_ = g;
  e.hessians_ = h;
  return e;
}

const ReferenceElement kElements[] = {
    make(CellType::Segment, 1.0, Point(0.5, 0, 0), {Point(0, 0, 0), Point(1, 0, 0)},
         segValues, segGradients, segHessians),
    make(CellType::Triangle, 0.5, Point(1.0 / 3, 1.0 / 3, 0), {Point(0, 0, 0), Point(1, 0, 0), Point(0, 1, 0)},
         triValues, triGradients, triHessians),
    make(CellType::Quadrilateral, 1.0, Point(0.5, 0.5, 0),
         {Point(0, 0, 0), Point(1, 0, 0), Point(1, 1, 0), Point(0, 1, 0)},
         quadValues, quadGradients, quadHessians),
    make(CellType::Tetrahedron, 1.0 / 6, Point(0.25, 0.25, 0.25),
         {Point(0, 0, 0), Point(1, 0, 0), Point(0, 1, 0), Point(0, 0, 1)},
         tetValues, tetGradients, tetHessians),
    make(CellType::Hexahedron, 1.0, Point(0.5, 0.5, 0.5),
         {Point(0, 0, 0), Point(1, 0, 0), Point(1, 1, 0), Point(0, 1, 0), Point(0, 0, 1),
          Point(1, 0, 1), Point(1, 1, 1), Point(0, 1, 1)},
         hexValues, hexGradients, hexHessians),
    make(CellType::Prism, 0.5, Point(1.0 / 3, 1.0 / 3, 0.5),
         {Point(0, 0, 0), Point(1, 0, 0), Point(0, 1, 0), Point(0, 0, 1), Point(1, 0, 1),
          Point(0, 1, 1)},
         prismValues, prismGradients, prismHessians),
    make(CellType::Pyramid, 1.0 / 3, Point(0.375, 0.375, 0.25),
         {Point(0, 0, 0), Point(1, 0, 0), Point(1, 1, 0), Point(0, 1, 0), Point(0, 0, 1)},
         pyrValues, pyrGradients, pyrHessians),
};

}  // namespace

const ReferenceElement& referenceElement(CellType type) {
  return kElements[static_cast<int>(type)];
}

}  // namespace obs::mesh
