#include "obs/obs/SolverConfig.hpp"

#include "obs/mesh/Error.hpp"
#include "obs/obs/PrimalDualActiveSet.hpp"
#include "obs/obs/ProjectedGaussSeidel.hpp"

namespace obs {

std::string_view name(ContactSolverKind kind) {
  switch (kind) {
    case ContactSolverKind::TNNMG: return "tnnmg";
    case ContactSolverKind::PrimalDualActiveSet: return "pdas";
    case ContactSolverKind::ProjectedGaussSeidel: return "pgs";
  }
  return "?";
}

std::optional<ContactSolverKind> contactSolverKindFromName(std::string_view name) {
  for (ContactSolverKind k :
       {ContactSolverKind::TNNMG, ContactSolverKind::PrimalDualActiveSet, ContactSolverKind::ProjectedGaussSeidel})
    if (obs::name(k) == name) return k;
  return std::nullopt;
}

int defaultMaxIterations(ContactSolverKind kind) {
  switch (kind) {
    case ContactSolverKind::TNNMG: return 200;
    case ContactSolverKind::PrimalDualActiveSet: return 100;
    case ContactSolverKind::ProjectedGaussSeidel: return 10000;
  }
  return 0;
}

template <int d>
typename TNNMG<d>::Options tnnmgOptions(const SolverConfig& config) {
  typename TNNMG<d>::Options o;
  o.tolerance = config.tolerance;
  o.maxIterations = config.iterationCap();
  o.preSmoothing = config.preSmoothing;
  o.postSmoothing = config.postSmoothing;
  o.multigrid = config.multigrid;
  return o;
}

template <int d>
std::unique_ptr<ContactSolver<d>> makeContactSolver(const SolverConfig& config,
                                                    const std::vector<const mesh::Grid*>& grids,
                                                    std::function<void(const IterationRecord&)> onIteration,
                                                    bool recordHistory) {
  auto common = [&](ContactSolverOptions& o) {
    o.tolerance = config.tolerance;
    o.maxIterations = config.iterationCap();
    o.onIteration = std::move(onIteration);
    o.recordHistory = recordHistory;
  };
  switch (config.kind) {
    case ContactSolverKind::TNNMG: {
      if (grids.empty()) throw Error("makeContactSolver: TNNMG needs the grid of every body");
      typename TNNMG<d>::Options o = tnnmgOptions<d>(config);
      common(o);
      return std::make_unique<TNNMG<d>>(grids, o);
    }
    case ContactSolverKind::PrimalDualActiveSet: {
      typename PrimalDualActiveSet<d>::Options o;
      common(o);
      return std::make_unique<PrimalDualActiveSet<d>>(o);
    }
    case ContactSolverKind::ProjectedGaussSeidel: {
      typename ProjectedGaussSeidel<d>::Options o;
      common(o);
      return std::make_unique<ProjectedGaussSeidel<d>>(o);
    }
  }
  throw Error("makeContactSolver: unknown solver kind");
}

template TNNMG<2>::Options tnnmgOptions<2>(const SolverConfig&);
template TNNMG<3>::Options tnnmgOptions<3>(const SolverConfig&);
template std::unique_ptr<ContactSolver<2>> makeContactSolver<2>(const SolverConfig&, const std::vector<const mesh::Grid*>&,
                                                                std::function<void(const IterationRecord&)>, bool);
template std::unique_ptr<ContactSolver<3>> makeContactSolver<3>(const SolverConfig&, const std::vector<const mesh::Grid*>&,
                                                                std::function<void(const IterationRecord&)>, bool);

}  // namespace obs
