#pragma once
/// \file Summary.hpp
/// summary.json of a run (nlohmann_json), e.g.
///   { "obs_version": "0.1.0", "scene": "data/scenes/cantilever.toml", "dimension": 2,
///     "vertices": 297, "cells": 256, "cells_per_type": {"quadrilateral": 256}, "refine": 0,
///     "dofs": 594, "free_dofs": 576,
///     "times": {"mesh_s": .., "assembly_s": .., "solve_s": .., "output_s": .., "total_s": ..},
///     "peak_memory_mb": 12.5, "max_displacement": 0.21, "max_von_mises": 4.7,
///     "solver": {"type": "direct", "iterations": 1, "converged": true, "time_s": ..},
///     "output_files": ["out/cantilever/cantilever.vtu", "out/cantilever/summary.json"] }
/// Iterative solvers add tolerance, correction and convergence_rate to "solver", contact solvers
/// also "kkt" (feasibility, multiplier_sign, complementarity, stationarity, dirichlet). Contact
/// scenes add "contact": obstacle, boundary, boundary_vertices, potential_vertices,
/// actual_vertices, force, load_P, area (3D) or width (2D), radius, radius_nodes, max_violation
/// (RunResult.hpp, docs/scenes.md). The runners write it with the sections of their kind
/// ("adaptivity", "dynamics") in finishRun (drivers/src/RunSupport.hpp).
#include <nlohmann/json.hpp>

#include "obs/drivers/RunResult.hpp"

namespace obs::drivers {

/// The summary.json object of a run's figures.
nlohmann::json summaryJson(const RunResult& result);

}  // namespace obs::drivers
