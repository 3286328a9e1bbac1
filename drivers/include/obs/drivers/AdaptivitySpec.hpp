#pragma once
/// \file AdaptivitySpec.hpp
/// The scene section [adaptivity] (docs/scenes.md): `obs run` solves the scene with the adaptive
/// loop solve -> estimate -> mark -> refine of libestimators (AdaptiveLoop.hpp; thesis Sec. 4.1,
/// docs/theory.md#adaptive-loop), starting from the [mesh] grid (with its `refine`).
///
///   [adaptivity]
///   refinement = "adaptive"          # "adaptive" (default) | "uniform"
///   estimator = "contact-residual"   # registry name; default "contact-residual" with [contact],
///                                    # "residual" without
///   marking = "mean"                 # mean | doerfler | maximum | fraction
///   theta = 1.1                      # marking parameter (default: the strategy's)
///   steps = 8                        # number of solves (>= 1)
///   max_vertices = 0                 # stop once the leaf view has this many vertices (0: off)
///   eta_tolerance = 0                # stop once eta <= this (0: off)
///   reference = "punch"              # optional analytic reference: punch | wedge | hertz
///   vtk = "last"                     # every | last | none
///   warm_start = true                # start each solve from the prolonged previous solution
///   inexact = 0                      # > 0: solve steps only to this fraction of the predicted eta
///                                    # (TNNMG; docs/estimators.md#inexact-solves); 0: off
#include <optional>
#include <string>

namespace obs::drivers {

struct AdaptivitySpec {
  enum class Vtk { Every, Last, None };
  bool uniform = false;            ///< refinement = "uniform"
  std::string estimator;           ///< registry name (filled with the default by the parser)
  std::string marking = "mean";
  std::optional<double> theta;
  int steps = 8;
  long long maxVertices = 0;
  double etaTolerance = 0;
  std::string reference;           ///< empty: none; "punch", "wedge" or "hertz"
  std::optional<double> referenceLoad;  ///< reference_load: a fixed P for nodal_pressure_error_fixed_load
  bool pressureEvery = false;      ///< pressure = "every": pressure_NNN.csv per step (else pressure.csv, last step)
  Vtk vtk = Vtk::Last;
  bool warmStart = true;
  double inexact = 0;              ///< AdaptiveLoopOptions::inexactFraction
  bool closureAllEdges = false;    ///< closure = "all-edges" (mesh::ClosureRule::AllEdges)
  int line = 0;                    ///< line of [adaptivity] (0: from --set only)
  int referenceLine = 0;
};

/// The analytic references [adaptivity] reference may name ("punch, wedge, hertz").
inline constexpr const char* kAdaptivityReferences = "punch, wedge, hertz";

}  // namespace obs::drivers
