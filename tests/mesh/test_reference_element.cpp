// Reference elements: shape function identities, derivatives against finite differences, face
// tables (outward orientation, vanishing of off-face functions), pyramid conformity.
#include <gtest/gtest.h>

#include <random>

#include "obs/mesh/Quadrature.hpp"
#include "obs/mesh/ReferenceElement.hpp"

using namespace obs::mesh;

namespace {

/// Random points strictly inside the reference element (rejection from the bounding box).
std::vector<Point> interiorPoints(const ReferenceElement& e, int n) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> U(0.02, 0.98);
  std::vector<Point> pts;
  while (static_cast<int>(pts.size()) < n) {
    Point p(U(rng), e.dim > 1 ? U(rng) : 0, e.dim > 2 ? U(rng) : 0);
    bool inside = true;
    switch (e.type) {
      case CellType::Triangle: inside = p[0] + p[1] < 0.98; break;
      case CellType::Tetrahedron: inside = p[0] + p[1] + p[2] < 0.98; break;
      case CellType::Prism: inside = p[0] + p[1] < 0.98; break;
      case CellType::Pyramid: inside = p[0] < 0.98 - p[2] && p[1] < 0.98 - p[2]; break;
      default: break;
    }
    if (inside) pts.push_back(p);
  }
  return pts;
}

class ReferenceElementTest : public ::testing::TestWithParam<CellType> {};

TEST_P(ReferenceElementTest, KroneckerAtVertices) {
  const auto& e = referenceElement(GetParam());
  std::vector<double> f(e.numVertices);
  for (int v = 0; v < e.numVertices; ++v) {
    Point x = e.vertices[v];
    if (e.type == CellType::Pyramid && v == 4) x[2] -= 1e-15;  // apex: evaluate the limit
    e.values(x, f);
    for (int i = 0; i < e.numVertices; ++i) EXPECT_NEAR(f[i], i == v ? 1.0 : 0.0, 1e-13);
  }
}

TEST_P(ReferenceElementTest, PartitionOfUnityAndLinearReproduction) {
  const auto& e = referenceElement(GetParam());
  std::vector<double> f(e.numVertices), g(e.numVertices * e.dim);
  for (const Point& p : interiorPoints(e, 50)) {
    e.values(p, f);
    e.gradients(p, g);
    double sum = 0;
    Point x = Point::Zero();
    Eigen::Matrix3d dx = Eigen::Matrix3d::Zero();
    for (int i = 0; i < e.numVertices; ++i) {
      sum += f[i];
      x += f[i] * e.vertices[i];
      for (int k = 0; k < e.dim; ++k) dx.col(k) += g[i * e.dim + k] * e.vertices[i];
    }
    EXPECT_NEAR(sum, 1.0, 1e-14);
    EXPECT_NEAR((x - p).norm(), 0.0, 1e-14);  // the element reproduces the identity map
    EXPECT_NEAR((dx.topLeftCorner(e.dim, e.dim) - Eigen::MatrixXd::Identity(e.dim, e.dim)).norm(),
                0.0, 1e-13);
  }
}

TEST_P(ReferenceElementTest, DerivativesMatchFiniteDifferences) {
  const auto& e = referenceElement(GetParam());
  const int n = e.numVertices, d = e.dim;
  std::vector<double> g(n * d), h(n * d * d), fp(n), fm(n), gp(n * d), gm(n * d);
  const double eps = 1e-6;
  for (const Point& p : interiorPoints(e, 20)) {
    e.gradients(p, g);
    e.hessians(p, h);
    for (int k = 0; k < d; ++k) {
      Point xp = p, xm = p;
      xp[k] += eps;
      xm[k] -= eps;
      e.values(xp, fp);
      e.values(xm, fm);
      e.gradients(xp, gp);
      e.gradients(xm, gm);
      for (int i = 0; i < n; ++i) {
        EXPECT_NEAR(g[i * d + k], (fp[i] - fm[i]) / (2 * eps), 1e-7);
        for (int l = 0; l < d; ++l)
          EXPECT_NEAR(h[(i * d + l) * d + k], (gp[i * d + l] - gm[i * d + l]) / (2 * eps), 1e-6);
      }
    }
    // Hessians are symmetric
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < d; ++k)
        for (int l = 0; l < d; ++l)
          EXPECT_DOUBLE_EQ(h[(i * d + k) * d + l], h[(i * d + l) * d + k]);
  }
}

TEST_P(ReferenceElementTest, FacesAreOutwardAndOffFaceFunctionsVanish) {
  const auto& e = referenceElement(GetParam());
  std::vector<double> f(e.numVertices);
  for (const auto& face : e.faces) {
    ASSERT_EQ(static_cast<int>(face.vertices.size()), numVertices(face.type));
    Point c = Point::Zero();
    for (int v : face.vertices) c += e.vertices[v];
    c /= face.vertices.size();
    const Point& a = e.vertices[face.vertices[0]];
    const Point& b = e.vertices[face.vertices[1]];
    Point normal;
    if (e.dim == 2) {
      const Point t = b - a;
      normal = Point(t[1], -t[0], 0);
    } else {
      normal = (b - a).cross(e.vertices[face.vertices.back()] - a);
    }
    EXPECT_GT(normal.dot(c - e.centroid), 0) << "face " << &face - e.faces.data();
    // at the face centroid only the face's vertex functions are non-zero, and on a
    // triangular face they are linear: each equals 1/3
    e.values(c, f);
    for (int i = 0; i < e.numVertices; ++i) {
      const bool onFace = std::find(face.vertices.begin(), face.vertices.end(), i) !=
                          face.vertices.end();
      const double expected = onFace ? 1.0 / face.vertices.size() : 0.0;
      EXPECT_NEAR(f[i], expected, 1e-14);
    }
  }
}

TEST_P(ReferenceElementTest, VolumeAndCentroidMatchQuadrature) {
  const auto& e = referenceElement(GetParam());
  const auto& q = quadratureRule(e.type, 2);
  double vol = 0;
  Point m = Point::Zero();
  for (std::size_t i = 0; i < q.size(); ++i) {
    vol += q.weights[i];
    m += q.weights[i] * q.points[i];
  }
  EXPECT_NEAR(vol, e.volume, 1e-14);
  EXPECT_NEAR((m / vol - e.centroid).norm(), 0.0, 1e-14);
}

/// Pyramid conformity: on every triangular face the pyramid functions are the linear (P1)
/// functions of the face, so they match a neighbouring tetrahedron or prism; on the base they are
/// the bilinear functions of the quadrilateral, matching a hexahedron or prism face.
TEST(PyramidElement, RestrictionsToFacesAreP1AndQ1) {
  const auto& e = referenceElement(CellType::Pyramid);
  std::vector<double> f(5);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(0, 1);
  for (const auto& face : e.faces) {
    for (int s = 0; s < 30; ++s) {
      double r = U(rng), t = U(rng);
      double w[4];
      Point x;
      if (face.type == CellType::Triangle) {
        if (r + t > 1) { r = 1 - r; t = 1 - t; }
        w[0] = 1 - r - t; w[1] = r; w[2] = t;
        x = w[0] * e.vertices[face.vertices[0]] + w[1] * e.vertices[face.vertices[1]] +
            w[2] * e.vertices[face.vertices[2]];
      } else {
        // bilinear parametrisation of the base in face order
        w[0] = (1 - r) * (1 - t); w[1] = r * (1 - t); w[2] = r * t; w[3] = (1 - r) * t;
        x = Point::Zero();
        for (int k = 0; k < 4; ++k) x += w[k] * e.vertices[face.vertices[k]];
      }
      if (x[2] > 1 - 1e-9) continue;
      e.values(x, f);
      for (std::size_t k = 0; k < face.vertices.size(); ++k)
        EXPECT_NEAR(f[face.vertices[k]], w[k], 1e-13);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllTypes, ReferenceElementTest,
                         ::testing::ValuesIn(kAllCellTypes),
                         [](const auto& info) { return std::string(name(info.param)); });

}  // namespace
