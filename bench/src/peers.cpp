// The peers behind the common Runner interface. Built only with NEARPOINT_BENCH_PEERS (see
// peers_none.cpp for the build without them).
//
// Each peer is used the way its documentation intends for a convex polytope given by vertices:
//   FCL 0.7     fcl::Convex<double> (vertices + faces from the CGAL hull), fcl::distance with
//               DistanceRequest(enable_nearest_points = true) and GST_LIBCCD or GST_INDEP;
//   Bullet 3.24 btConvexHullShape (margin 0, or the shape's radius: Bullet's margin is exactly a
//               spherical extension), btGjkPairDetector + btVoronoiSimplexSolver, no penetration
//               depth solver (we ask for distances; EPA would only add cost on intersecting pairs);
//   libccd 2.1  ccdGJKIntersect with a support callback that rotates the direction into the
//               shape's frame and scans its vertices (FCL's own libccd glue does the same).
#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/NarrowPhaseCollision/btGjkPairDetector.h>
#include <BulletCollision/NarrowPhaseCollision/btPointCollector.h>
#include <BulletCollision/NarrowPhaseCollision/btVoronoiSimplexSolver.h>
#include <ccd/ccd.h>

#include <fcl/geometry/shape/convex.h>
#include <fcl/narrowphase/distance.h>

#include <map>

#include "nearpoint/hull.hpp"
#include "runners.hpp"

// Bullet's types change layout with BT_USE_DOUBLE_PRECISION: the headers must agree with the
// library (libBulletCollision-float64). The library side is checked by computing with it below.
#ifndef BT_USE_DOUBLE_PRECISION
#error "the benchmark must see Bullet's double-precision headers (pkg-config bullet-float64)"
#endif
static_assert(sizeof(btScalar) == 8, "Bullet must be the double-precision build");
// libccd: Debian builds it in double (ccd/config.h defines CCD_DOUBLE).
static_assert(sizeof(ccd_real_t) == 8, "libccd must be the double-precision build");

namespace nearpoint::bench {
namespace {

using VertexList = std::shared_ptr<const std::vector<Vec3<double>>>;

// ---------------------------------------------------------------------------------------------
// FCL

// Hulls by vertex list, shared by all FCL runners of a process: an experiment builds several
// runners on the same shapes (two solvers, many tolerance settings), and a hull of 10⁵ points
// takes seconds. The entry holds the list itself, so its address cannot be reused while cached.
const Hull& cached_hull(const VertexList& v) {
  static std::map<const void*, std::pair<VertexList, Hull>> cache;
  auto [it, inserted] = cache.try_emplace(v.get());
  if (inserted) it->second = {v, convex_hull(*v)};
  return it->second.second;
}

class FclRunner final : public Runner {
 public:
  FclRunner(std::span<const PairInput> inputs, fcl::GJKSolverType solver, double tolerance)
      : request_(/*enable_nearest_points=*/true) {
    request_.gjk_solver_type = solver;
    if (!std::isnan(tolerance)) request_.distance_tolerance = tolerance;
    queries_.reserve(inputs.size());
    for (const PairInput& in : inputs)
      queries_.push_back({convex(in.a), transform(in.pose_a), convex(in.b), transform(in.pose_b)});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    fcl::DistanceResultd result;
    fcl::distance(q.a, q.ta, q.b, q.tb, request_, result);
    // Without enable_signed_distance FCL reports intersection as a non-positive distance
    // ("mostly -1", fcl/narrowphase/distance_request.h). NaN stays NaN and is counted.
    const double d = result.min_distance;
    out.intersecting = d <= 0;
    out.distance = d <= 0 ? 0.0 : d;
    out.iterations = -1;  // FCL does not report them
    out.exit = Exit::unknown;
  }

 private:
  struct Query {
    const fcl::Convexd* a;
    fcl::Transform3d ta;
    const fcl::Convexd* b;
    fcl::Transform3d tb;
  };

  static fcl::Transform3d transform(const Pose<double>& pose) {
    fcl::Transform3d t = fcl::Transform3d::Identity();
    t.linear() = pose.rotation;
    t.translation() = pose.translation;
    return t;
  }

  const fcl::Convexd* convex(const VertexList& v) {
    auto [it, inserted] = shapes_.try_emplace(v.get());
    if (inserted) {
      const Hull& hull = cached_hull(v);
      auto vertices = std::make_shared<std::vector<fcl::Vector3d>>();
      for (const Vec3<double>& p : hull.vertices) vertices->push_back(p);
      // FCL's face encoding: for each face its vertex count, then its vertex indices.
      auto faces = std::make_shared<std::vector<int>>();
      for (const std::vector<int>& f : hull.faces) {
        faces->push_back(int(f.size()));
        faces->insert(faces->end(), f.begin(), f.end());
      }
      it->second = std::make_unique<fcl::Convexd>(vertices, int(hull.faces.size()), faces);
    }
    return it->second.get();
  }

  fcl::DistanceRequestd request_;
  std::map<const void*, std::unique_ptr<fcl::Convexd>> shapes_;
  std::vector<Query> queries_;
};

// ---------------------------------------------------------------------------------------------
// Bullet

btTransform bt_transform(const Pose<double>& pose) {
  const Mat3<double>& r = pose.rotation;
  return btTransform(
      btMatrix3x3(r(0, 0), r(0, 1), r(0, 2), r(1, 0), r(1, 1), r(1, 2), r(2, 0), r(2, 1), r(2, 2)),
      btVector3(pose.translation.x(), pose.translation.y(), pose.translation.z()));
}

std::unique_ptr<btConvexHullShape> bt_hull(const std::vector<Vec3<double>>& v, double margin) {
  std::vector<btVector3> points;
  points.reserve(v.size());
  for (const Vec3<double>& p : v) points.emplace_back(p.x(), p.y(), p.z());
  auto shape = std::make_unique<btConvexHullShape>(&points[0].x(), int(points.size()),
                                                   int(sizeof(btVector3)));
  // The default margin (0.04) would round every shape; 0 gives the polytope itself, and a
  // positive radius is Bullet's margin exactly (a spherical extension, like eq. 5–8).
  shape->setMargin(margin);
  return shape;
}

class BulletRunner final : public Runner {
 public:
  BulletRunner(std::span<const PairInput> inputs, double threshold) {
    if (!std::isnan(threshold)) simplex_.setEqualVertexThreshold(btScalar(threshold));
    queries_.reserve(inputs.size());
    for (const PairInput& in : inputs)
      queries_.push_back({shape(in.a, in.radius_a), bt_transform(in.pose_a),
                          shape(in.b, in.radius_b), bt_transform(in.pose_b)});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    btGjkPairDetector detector(q.a, q.b, &simplex_, nullptr);
    btGjkPairDetector::ClosestPointInput input;
    input.m_transformA = q.ta;
    input.m_transformB = q.tb;
    btPointCollector result;
    detector.getClosestPoints(input, result, nullptr);
    // Without a penetration depth solver Bullet reports no point when it finds the origin in
    // the Minkowski difference (or |v|² below its REL_ERROR2 = 1e-6): that is its "intersecting".
    const double d = result.m_hasResult ? double(result.m_distance) : 0.0;
    out.intersecting = !(d > 0) && !std::isnan(d);
    out.distance = std::isnan(d) ? d : (d > 0 ? d : 0.0);
    out.iterations = detector.m_curIter;
    out.exit = Exit::unknown;
    out.code_a = detector.m_lastUsedMethod;
    out.code_b = detector.m_degenerateSimplex;
  }

 private:
  struct Query {
    const btConvexHullShape* a;
    btTransform ta;
    const btConvexHullShape* b;
    btTransform tb;
  };

  const btConvexHullShape* shape(const VertexList& v, double margin) {
    auto [it, inserted] = shapes_.try_emplace({v.get(), margin});
    if (inserted) it->second = bt_hull(*v, margin);
    return it->second.get();
  }

  btVoronoiSimplexSolver simplex_;
  std::map<std::pair<const void*, double>, std::unique_ptr<btConvexHullShape>> shapes_;
  std::vector<Query> queries_;
};

// ---------------------------------------------------------------------------------------------
// libccd

struct CcdObject {
  const Vec3<double>* vertices;
  std::size_t count;
  Mat3<double> rotation;
  Vec3<double> translation;
  double radius;
};

// s(d) = R·s_local(Rᵀd) + t (+ r·d/|d| for a rounded shape).
void ccd_support(const void* object, const ccd_vec3_t* direction, ccd_vec3_t* out) {
  const CcdObject& o = *static_cast<const CcdObject*>(object);
  const Vec3<double> d(direction->v[0], direction->v[1], direction->v[2]);
  const Vec3<double> local = o.rotation.transpose() * d;
  std::size_t best = 0;
  double best_value = o.vertices[0].dot(local);
  for (std::size_t k = 1; k < o.count; ++k) {
    const double value = o.vertices[k].dot(local);
    if (value > best_value) {
      best_value = value;
      best = k;
    }
  }
  Vec3<double> p = o.rotation * o.vertices[best] + o.translation;
  if (o.radius > 0) {
    const double n = d.norm();
    if (n > 0) p += (o.radius / n) * d;
  }
  out->v[0] = p.x();
  out->v[1] = p.y();
  out->v[2] = p.z();
}

class CcdRunner final : public Runner {
 public:
  explicit CcdRunner(std::span<const PairInput> inputs) {
    CCD_INIT(&ccd_);
    ccd_.support1 = ccd_support;
    ccd_.support2 = ccd_support;
    // The default is "unlimited" ((unsigned long)-1); a finite cap keeps a degenerate input
    // from hanging the run. 1000 is far above what the 6000 examples need.
    ccd_.max_iterations = 1000;
    objects_.reserve(inputs.size());
    for (const PairInput& in : inputs) {
      objects_.push_back(
          {{in.a->data(), in.a->size(), in.pose_a.rotation, in.pose_a.translation, in.radius_a},
           {in.b->data(), in.b->size(), in.pose_b.rotation, in.pose_b.translation, in.radius_b}});
    }
  }

  void run(std::size_t i, Outcome& out) override {
    const int hit = ccdGJKIntersect(&objects_[i].first, &objects_[i].second, &ccd_);
    out.intersecting = hit != 0;
    out.distance = kNaN;  // a yes/no answer only
    out.iterations = -1;
    out.exit = Exit::unknown;
  }

 private:
  ccd_t ccd_;
  std::vector<std::pair<CcdObject, CcdObject>> objects_;
};

}  // namespace

bool peers_available() {
  return true;
}

std::unique_ptr<Runner> make_peer_runner(Peer peer, std::span<const PairInput> inputs,
                                         const PeerSettings& settings, std::string* why) {
  switch (peer) {
    case Peer::fcl_libccd:
    case Peer::fcl_indep:
      for (const PairInput& in : inputs) {
        if (in.radius_a > 0 || in.radius_b > 0) {
          if (why) *why = "fcl::Convex has no radius (no rounded polytopes)";
          return nullptr;
        }
      }
      return std::make_unique<FclRunner>(
          inputs, peer == Peer::fcl_libccd ? fcl::GST_LIBCCD : fcl::GST_INDEP, settings.tolerance);
    case Peer::bullet:
      return std::make_unique<BulletRunner>(inputs, settings.tolerance);
    case Peer::ccd_intersect:
      return std::make_unique<CcdRunner>(inputs);
  }
  if (why) *why = "unknown peer";
  return nullptr;
}

std::string check_peer_builds() {
  // If the library were the single-precision build, btConvexHullShape would read our double
  // array as floats and the support point below would be garbage.
  const std::vector<Vec3<double>> points = {Vec3<double>(1, 2, 3), Vec3<double>(-4, 5, -6),
                                            Vec3<double>(0.1, -0.2, 7.5), Vec3<double>(-1, -1, -1)};
  const auto shape = bt_hull(points, 0);
  const btVector3 s = shape->localGetSupportingVertexWithoutMargin(btVector3(0.1, 0.2, 1.0));
  if (shape->getNumPoints() != 4 || s.x() != 0.1 || s.y() != -0.2 || s.z() != 7.5)
    return "Bullet: the linked library does not use the headers' btScalar (double)";
  return "";
}

}  // namespace nearpoint::bench
