#pragma once
/// \file ContactReports.hpp
/// The contact reports of a static run (summary.json "contact" and a coupling's "friction"), made by
/// one function for one process and for MPI ranks: each rank sums the contact nodes it owns and the
/// sums are reduced over the communicator (of one process without mpirun;
/// docs/architecture.md#one-path).
#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

#include "obs/drivers/RunResult.hpp"
#include "obs/drivers/Scene.hpp"
#include "obs/obs/Communicator.hpp"
#include "obs/obs/ContactProblem.hpp"
#include "obs/obs/FrictionLaw.hpp"
#include "obs/obs/HaloExchange.hpp"

namespace obs::drivers {

/// The part of a problem on a rank's local mesh that this rank reports: its vertices are numbered
/// owned first (the first `owned`), then the ghosts, whose values `halo` brings from their owners;
/// `global` is each local vertex's global index (a contact face is counted once, by the owner of its
/// vertex of smallest global index). One process (the defaults but `owned`): every vertex owned,
/// Communicator::self(), no halo, `global` empty (the local numbering is the global one).
struct OwnedPart {
  Index owned = 0;
  Communicator comm = Communicator::self();
  const HaloExchange* halo = nullptr;
  std::vector<Index> global;
  /// One process alone (Communicator::self()), owning all `vertices`.
  static OwnedPart oneProcess(Index vertices) {
    OwnedPart part;
    part.owned = vertices;
    return part;
  }
};

/// The friction report of a coupling with friction law `law` (nullopt without friction) from its
/// tangential force, stick and slip vertices and stick area.
std::optional<FrictionReport> frictionReport(const FrictionLaw& law, const Eigen::Vector3d& tangential, long long stick,
                                             long long slip, double stickArea, int dim);

/// The report of a one-body scene's [contact] (its obstacle coupling: vertex counts, force, load,
/// the force centre's radius, area, violation, friction) from the solution x of `problem` and its
/// ContactOutputs `out` (on ranks computed with the global scales of the KKT residuals, so that
/// every rank decides contact by the same thresholds). `states`, if given, receives the contact
/// state of every contact node (ContactOutputs::state) as its owner decided it. Collective.
template <int d>
ContactReport obstacleContactReport(const Scene& scene, const ContactProblem<d>& problem, const Eigen::VectorXd& x,
                                    const ContactOutputs& out, const OwnedPart& part,
                                    std::vector<char>* states = nullptr);

/// A [loading] increment's figures (normal and tangential force, contact, stick and slip vertices)
/// from the owned nodes of the contact set `set` and its ContactOutputs `out`, reduced over the
/// communicator. Collective.
IncrementReport incrementReport(const ContactSet& set, const ContactOutputs& out, const OwnedPart& part, int step,
                                int steps, long long iterations, bool converged);

/// The progress line of an increment ("increment i of N (t = ...): ... contact vertices ...").
std::string incrementLine(const IncrementReport& increment, int steps);

}  // namespace obs::drivers
