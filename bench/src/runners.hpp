// SPDX-License-Identifier: Apache-2.0
// The implementations under test, each behind `Runner`: nearpoint (any options, cold or warm) and
// the peers built from Debian packages (FCL 0.7 with its libccd-based and its own GJK, Bullet 3.24
// in double precision, libccd 2.1's yes/no query).
#pragma once

#include <memory>
#include <span>
#include <string>

#include "harness.hpp"

namespace nearpoint::bench {

/// nearpoint on `inputs`. With `options.penetration_depth` the Outcome carries the depth, its
/// interval, D(K), and in code_a / code_b the DepthTermination and the expansion steps. With
/// `warm`, one SimplexCache is carried from each query to the next (Section VIII: consecutive
/// inputs are consecutive steps of a path); `reset()` empties it. With `climb`, polytopes are built
/// by nearpoint::hull_polytope (hull vertices and faces), so large ones climb their edges instead
/// of scanning.
std::unique_ptr<Runner> make_nearpoint_runner(std::span<const PairInput> inputs,
                                              const DistanceOptions<double>& options, bool warm,
                                              bool climb = false);

/// How a nearpoint result ended (DS / BP / numerical limit / cap …), from its `termination` and
/// `finished_by`.
template <class S>
Exit exit_of(const DistanceResult<S>& r) {
  // Through converged() rather than a list of Termination values, so that a new convergence test
  // in the engine is classified correctly without touching this file.
  if (r.status == Status::invalid_input) return Exit::invalid_input;
  if (r.termination == Termination::iteration_limit) return Exit::iteration_cap;
  if (r.termination == Termination::beyond_cutoff) return Exit::beyond_cutoff;
  if (!r.converged()) return Exit::numerical_limit;
  return r.finished_by == FinishedBy::backup_procedure ? Exit::backup_procedure
                                                       : Exit::distance_subalgorithm;
}

enum class Peer : unsigned char {
  fcl_libccd,     ///< fcl::distance, GST_LIBCCD, fcl::Convex from the hull
  fcl_indep,      ///< fcl::distance, GST_INDEP (FCL's own GJK)
  bullet,         ///< btGjkPairDetector + btVoronoiSimplexSolver on btConvexHullShape, double
  ccd_intersect,  ///< libccd's ccdGJKIntersect: the yes/no query only
  opengjk,  ///< openGJK's compute_minimum_distance (scalar, double), vertices posed in the call
  coal,     ///< coal's GJKSolver::shapeDistance on coal::Convex (GJK only, no EPA)
};
const char* to_string(Peer peer);

/// The knob each peer offers for accuracy against speed. NaN keeps the peer's default.
///   FCL (both solvers): DistanceRequest::distance_tolerance (default 1e-6);
///   Bullet: btVoronoiSimplexSolver::setEqualVertexThreshold (default 1e-12 in double; its GJK's
///           relative stopping tolerance REL_ERROR2 = 1e-6 is compiled in and cannot be changed);
///   libccd: ccd_t::max_iterations is its only knob (set to 1000 here, see peers.cpp);
///   openGJK: none (its tolerances are compiled in);
///   coal: GJKSolver::gjk_tolerance (default 1e-6).
struct PeerSettings {
  double tolerance = kNaN;
};

/// True when the benchmark was built with NEARPOINT_BENCH_PEERS.
bool peers_available();

/// A runner for `peer` on `inputs`, or nullptr with `*why` saying why the peer cannot take them
/// (e.g. a rounded shape for fcl::Convex, which has no radius). Shapes are prepared here (hulls
/// for FCL, btConvexHullShape for Bullet), poses converted to the peer's native types.
std::unique_ptr<Runner> make_peer_runner(Peer peer, std::span<const PairInput> inputs,
                                         const PeerSettings& settings, std::string* why);

/// A primitive for the primitives experiment (issue 25, item 3), in its local frame: a sphere
/// (`radius`), a capsule along z (`radius`, the segment from −half_length to +half_length), a box
/// (`half_extents`) or a small hull (`hull`, a vertex list).
struct Primitive {
  enum class Kind : unsigned char { sphere, capsule, box, hull };
  Kind kind = Kind::sphere;
  double radius = 0;
  double half_length = 0;
  Vec3<double> half_extents = Vec3<double>::Zero();
  std::shared_ptr<const std::vector<Vec3<double>>> hull;
};

struct PrimitiveInput {
  const Primitive* a;
  Pose<double> pose_a;
  const Primitive* b;
  Pose<double> pose_b;
};

/// The peers' best path for primitives: FCL's fcl::distance on its own shape types (it picks its
/// specialised sphere–sphere, sphere–box, sphere–capsule and capsule–capsule routines, GJK for the
/// rest) with either solver; coal's internal::ShapeShapeDistance (its specialised routines, GJK on
/// its shape types otherwise) with the GJK tolerance 1e-12 or 1e-6.
enum class PrimitivePeer : unsigned char { fcl_libccd, fcl_indep, coal_1e12, coal_1e6 };
const char* to_string(PrimitivePeer peer);
std::unique_ptr<Runner> make_primitive_peer_runner(PrimitivePeer peer,
                                                   std::span<const PrimitiveInput> inputs,
                                                   std::string* why);

/// The peers' penetration depth (the depth experiment), each through its documented entry point:
///   coal:        GJKSolver::shapeDistance(compute_penetration = true) on coal::Convex (GJK then
///                EPA); knob: gjk_tolerance = epa_tolerance (default 1e-6), EPA's default cap;
///   fcl_epa:     fcl::distance with enable_signed_distance, GST_LIBCCD (FCL's copy of libccd's
///                GJK + EPA, ccdGJKSignedDist); knob: distance_tolerance (its EPA tolerance too);
///   fcl_mpr:     fcl::collide with enable_contact, GST_LIBCCD: FCL 0.7 answers this with libccd's
///                MPR (ccdMPRPenetration), not EPA; knob: CollisionRequest::gjk_tolerance (its
///                mpr_tolerance, default 1e-6);
///   libccd_epa:  libccd 2.1's ccdGJKPenetration (GJK + EPA); knob: ccd_t::epa_tolerance
///                (default 1e-4);
///   bullet:      btGjkEpaSolver2::Penetration (double build, margins 0); accuracies compiled in.
/// `depth` in the Outcome is the reported depth, 0 when the peer reports no penetration;
/// code_a / code_b carry the peer's status codes where it has them (coal: GJK / EPA status;
/// Bullet: sResults::status; libccd / FCL: the return value).
enum class DepthPeer : unsigned char { coal, fcl_epa, fcl_mpr, libccd_epa, bullet };
const char* to_string(DepthPeer peer);
std::unique_ptr<Runner> make_depth_peer_runner(DepthPeer peer, std::span<const PairInput> inputs,
                                               const PeerSettings& settings, std::string* why);

/// Checks, by computing with it, that the Bullet library linked uses the same btScalar as the
/// headers we were compiled with (BT_USE_DOUBLE_PRECISION on both sides). Returns "" when
/// consistent, else a description. Called once at start-up.
std::string check_peer_builds();

}  // namespace nearpoint::bench
