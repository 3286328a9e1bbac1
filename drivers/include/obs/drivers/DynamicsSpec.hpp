#pragma once
/// \file DynamicsSpec.hpp
/// The scene section [dynamics] (docs/scenes.md): time stepping of dynamic contact with one scheme
/// of the Newmark family (libobs Newmark.hpp, docs/theory.md#newmark), its initial state, tracked points and
/// the schemes to compare. Read by the scene parser (every entry remembers its line), run by
/// DynamicScene.hpp.
#include <optional>
#include <string>
#include <vector>

#include "obs/drivers/Expression.hpp"
#include "obs/mesh/Mesh.hpp"

namespace obs::drivers {

struct DynamicsSpec {
  std::string scheme = "improved-contact-stabilized";  ///< a name of makeTimeStepper
  int schemeLine = 0;
  double timeStep = 0;  ///< tau > 0
  int timeStepLine = 0;
  /// Exactly one of endTime (> 0; steps = ceil(endTime / tau - 1e-9)) and steps (>= 1) is given.
  std::optional<double> endTime;
  std::optional<int> steps;
  int lengthLine = 0;  ///< line of end_time or steps
  /// v^0 and u^0 as vector expressions of x, y, z (one entry per coordinate; u^0 default 0).
  /// Dirichlet components take the prescribed value (u) and 0 (v).
  std::vector<Expression> initialVelocity;
  int initialVelocityLine = 0;
  std::vector<Expression> initialDisplacement;
  int initialDisplacementLine = 0;
  bool consistentMass = false;  ///< mass = "consistent" (default "lumped")
  int massLine = 0;
  /// Points whose nearest vertices are tracked (2 or 3 coordinates as written).
  std::vector<mesh::Point> tracked;
  std::vector<int> trackedDimensions;  ///< number of coordinates written per point
  int trackedLine = 0;
  int outputStride = 10;  ///< VTK file every outputStride steps (and the last step)
  int outputStrideLine = 0;
  /// Schemes to run besides `scheme` (names; "all" expands to every scheme). Empty: no comparison.
  std::vector<std::string> compare;
  int compareLine = 0;
  /// Inexact solves (NewmarkOptions::inexactFraction, docs/theory.md#dynamic-inexact-solves): in
  /// [0, 1); > 0 solves each step only to this fraction of the previous step's time-error estimate.
  double inexact = 0;
  int inexactLine = 0;
  /// Moments kept by the redistributed mass of the KLR/HHW schemes (MassRedistributionOptions::moments):
  /// 2 mass, centre of gravity and second moments (default), 1 mass and centre of gravity only.
  int redistributionMoments = 2;
  /// Initial iterate of each step's solve (NewmarkOptions::start): "predictor" or "previous-increment".
  std::string warmStart = "predictor";
  int line = 0;  ///< line of [dynamics]
};

}  // namespace obs::drivers
