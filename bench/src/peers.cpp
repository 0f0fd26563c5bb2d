// SPDX-License-Identifier: Apache-2.0
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
//               shape's frame and scans its vertices (FCL's own libccd glue does the same);
//   openGJK     (snapshot, bench/README.md) compute_minimum_distance on the vertex arrays, turned
//               into the world frame inside the timed call (as FCL and nearpoint apply poses in
//               theirs); scalar, double;
//   coal        (snapshot, bench/README.md) GJKSolver::shapeDistance on two
//               coal::Convex<coal::Triangle> built once from the CGAL hull (so that large hulls
//               climb their neighbours), GJK only (compute_penetration = false, no EPA), the
//               tolerance 1e-12 or its default 1e-6.
// openGJK and coal are compiled in when bench/cmake/source_peers.cmake found their snapshots
// (NEARPOINT_BENCH_HAVE_OPENGJK / _COAL); otherwise their runners decline with the reason.
#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/NarrowPhaseCollision/btGjkEpa2.h>
#include <BulletCollision/NarrowPhaseCollision/btGjkPairDetector.h>
#include <BulletCollision/NarrowPhaseCollision/btPointCollector.h>
#include <BulletCollision/NarrowPhaseCollision/btVoronoiSimplexSolver.h>
#include <ccd/ccd.h>

#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#if NEARPOINT_BENCH_HAVE_OPENGJK
#include <openGJK/openGJK.h>
#endif
#if NEARPOINT_BENCH_HAVE_COAL
#include <coal/internal/shape_shape_func.h>
#include <coal/narrowphase/narrowphase.h>
#include <coal/shape/convex.h>
#include <coal/shape/geometric_shapes.h>
#endif

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

fcl::Transform3d fcl_transform(const Pose<double>& pose) {
  fcl::Transform3d t = fcl::Transform3d::Identity();
  t.linear() = pose.rotation;
  t.translation() = pose.translation;
  return t;
}

std::unique_ptr<fcl::Convexd> fcl_convex(const VertexList& v) {
  const Hull& hull = cached_hull(v);
  auto vertices = std::make_shared<std::vector<fcl::Vector3d>>();
  for (const Vec3<double>& p : hull.vertices) vertices->push_back(p);
  auto faces = std::make_shared<std::vector<int>>();
  for (const std::vector<int>& f : hull.faces) {
    faces->push_back(int(f.size()));
    faces->insert(faces->end(), f.begin(), f.end());
  }
  return std::make_unique<fcl::Convexd>(vertices, int(hull.faces.size()), faces);
}

// The depth experiment: fcl::distance with signed distance (FCL's libccd-based GJK + EPA) or
// fcl::collide with contacts (libccd's MPR in FCL 0.7), on fcl::Convex from the hull.
class FclDepthRunner final : public Runner {
 public:
  FclDepthRunner(std::span<const PairInput> inputs, bool epa, double tolerance)
      : epa_(epa),
        distance_request_(/*enable_nearest_points=*/true, /*enable_signed_distance=*/true),
        collision_request_(/*num_max_contacts=*/1, /*enable_contact=*/true) {
    distance_request_.gjk_solver_type = fcl::GST_LIBCCD;
    collision_request_.gjk_solver_type = fcl::GST_LIBCCD;
    if (!std::isnan(tolerance)) {
      distance_request_.distance_tolerance = tolerance;
      collision_request_.gjk_tolerance = tolerance;
    }
    queries_.reserve(inputs.size());
    for (const PairInput& in : inputs)
      queries_.push_back(
          {convex(in.a), fcl_transform(in.pose_a), convex(in.b), fcl_transform(in.pose_b)});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    out.exit = Exit::unknown;
    if (epa_) {
      fcl::DistanceResultd result;
      // FCL's EPA throws std::logic_error on some inputs ("faceNormalPointingOutward(): Cannot
      // compute face normal for a degenerate (zero-area) triangle"): a failed query, NaN.
      try {
        fcl::distance(q.a, q.ta, q.b, q.tb, distance_request_, result);
      } catch (const std::exception&) {
        out.intersecting = false;
        out.depth = kNaN;
        out.exit = Exit::invalid_input;
        return;
      }
      const double d = result.min_distance;
      out.intersecting = d < 0;
      out.depth = d < 0 ? -d : (std::isnan(d) ? d : 0.0);
    } else {
      fcl::CollisionResultd result;
      fcl::collide(q.a, q.ta, q.b, q.tb, collision_request_, result);
      out.intersecting = result.isCollision();
      out.depth = out.intersecting && result.numContacts() > 0
                      ? result.getContact(0).penetration_depth
                      : 0.0;
    }
  }

 private:
  struct Query {
    const fcl::Convexd* a;
    fcl::Transform3d ta;
    const fcl::Convexd* b;
    fcl::Transform3d tb;
  };
  const fcl::Convexd* convex(const VertexList& v) {
    auto [it, inserted] = shapes_.try_emplace(v.get());
    if (inserted) it->second = fcl_convex(v);
    return it->second.get();
  }
  bool epa_;
  fcl::DistanceRequestd distance_request_;
  fcl::CollisionRequestd collision_request_;
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

// The depth experiment: btGjkEpaSolver2::Penetration (GJK, then EPA when the origin is inside),
// the solver behind Bullet's btGjkEpaPenetrationDepthSolver, with its initial guess (the
// difference of the two origins).
class BulletDepthRunner final : public Runner {
 public:
  explicit BulletDepthRunner(std::span<const PairInput> inputs) {
    queries_.reserve(inputs.size());
    for (const PairInput& in : inputs) {
      const btTransform ta = bt_transform(in.pose_a), tb = bt_transform(in.pose_b);
      queries_.push_back({shape(in.a), ta, shape(in.b), tb, ta.getOrigin() - tb.getOrigin()});
    }
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    btGjkEpaSolver2::sResults result;
    const bool hit = btGjkEpaSolver2::Penetration(q.a, q.ta, q.b, q.tb, q.guess, result);
    out.intersecting = hit;
    const double d = double(result.distance);
    out.depth = hit ? -d : 0.0;
    out.exit = Exit::unknown;
    out.code_a = int(result.status);
  }

 private:
  struct Query {
    const btConvexHullShape* a;
    btTransform ta;
    const btConvexHullShape* b;
    btTransform tb;
    btVector3 guess;
  };
  const btConvexHullShape* shape(const VertexList& v) {
    auto [it, inserted] = shapes_.try_emplace(v.get());
    if (inserted) it->second = bt_hull(*v, 0);
    return it->second.get();
  }
  std::map<const void*, std::unique_ptr<btConvexHullShape>> shapes_;
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

// The depth experiment: libccd's own GJK + EPA (ccdGJKPenetration).
class CcdDepthRunner final : public Runner {
 public:
  CcdDepthRunner(std::span<const PairInput> inputs, double tolerance) {
    CCD_INIT(&ccd_);
    ccd_.support1 = ccd_support;
    ccd_.support2 = ccd_support;
    ccd_.max_iterations = 1000;  // as CcdRunner: a finite cap
    if (!std::isnan(tolerance)) ccd_.epa_tolerance = tolerance;
    objects_.reserve(inputs.size());
    for (const PairInput& in : inputs) {
      objects_.push_back(
          {{in.a->data(), in.a->size(), in.pose_a.rotation, in.pose_a.translation, 0},
           {in.b->data(), in.b->size(), in.pose_b.rotation, in.pose_b.translation, 0}});
    }
  }

  void run(std::size_t i, Outcome& out) override {
    ccd_real_t depth = 0;
    ccd_vec3_t dir, pos;
    const int rc =
        ccdGJKPenetration(&objects_[i].first, &objects_[i].second, &ccd_, &depth, &dir, &pos);
    out.intersecting = rc == 0;
    out.depth = rc == 0 ? double(depth) : 0.0;
    out.exit = Exit::unknown;
    out.code_a = rc;
  }

 private:
  ccd_t ccd_;
  std::vector<std::pair<CcdObject, CcdObject>> objects_;
};

// ---------------------------------------------------------------------------------------------
// openGJK

#if NEARPOINT_BENCH_HAVE_OPENGJK
class OpenGjkRunner final : public Runner {
 public:
  explicit OpenGjkRunner(std::span<const PairInput> inputs) {
    std::size_t most = 1;
    for (const PairInput& in : inputs) most = std::max({most, in.a->size(), in.b->size()});
    // World-frame copies of the vertices, written by each query; openGJK reads them through an
    // array of row pointers (its gkPolytope::coord), set up once here.
    for (int k = 0; k < 2; ++k) {
      world_[k].resize(3 * most);
      rows_[k].resize(most);
      for (std::size_t i = 0; i < most; ++i) rows_[k][i] = &world_[k][3 * i];
    }
    queries_.reserve(inputs.size());
    for (const PairInput& in : inputs)
      queries_.push_back({in.a.get(), in.pose_a, in.b.get(), in.pose_b});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    gkPolytope bd[2];
    const std::vector<Vec3<double>>* v[2] = {q.a, q.b};
    const Pose<double>* pose[2] = {&q.pose_a, &q.pose_b};
    for (int k = 0; k < 2; ++k) {
      const Mat3<double>& r = pose[k]->rotation;
      const Vec3<double>& t = pose[k]->translation;
      double* w = world_[k].data();
      for (const Vec3<double>& p : *v[k]) {
        const Vec3<double> x = r * p + t;
        w[0] = x.x();
        w[1] = x.y();
        w[2] = x.z();
        w += 3;
      }
      bd[k].numpoints = int(v[k]->size());
      bd[k].coord = rows_[k].data();
    }
    gkSimplex simplex;
    simplex.nvrtx = 0;
    const double d = compute_minimum_distance(bd[0], bd[1], &simplex);
    // openGJK returns 0 for intersecting shapes (its witnesses are then not meaningful).
    out.intersecting = !(d > 0) && !std::isnan(d);
    out.distance = std::isnan(d) ? d : (d > 0 ? d : 0.0);
    out.iterations = -1;
    out.exit = Exit::unknown;
  }

 private:
  struct Query {
    const std::vector<Vec3<double>>* a;
    Pose<double> pose_a;
    const std::vector<Vec3<double>>* b;
    Pose<double> pose_b;
  };
  std::vector<double> world_[2];
  std::vector<double*> rows_[2];
  std::vector<Query> queries_;
};
#endif

// ---------------------------------------------------------------------------------------------
// coal

#if NEARPOINT_BENCH_HAVE_COAL
coal::Transform3s coal_transform(const Pose<double>& pose) {
  return coal::Transform3s(coal::Matrix3s(pose.rotation), coal::Vec3s(pose.translation));
}

class CoalRunner final : public Runner {
 public:
  CoalRunner(std::span<const PairInput> inputs, double tolerance) {
    if (!std::isnan(tolerance)) solver_.gjk_tolerance = tolerance;
    queries_.reserve(inputs.size());
    for (const PairInput& in : inputs)
      queries_.push_back(
          {convex(in.a), coal_transform(in.pose_a), convex(in.b), coal_transform(in.pose_b)});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    coal::Vec3s p1, p2, normal;
    const double d = solver_.shapeDistance(*q.a, q.ta, *q.b, q.tb, /*compute_penetration=*/false,
                                           p1, p2, normal);
    // Without EPA coal reports a collision as a distance ≤ 0 (or below its tolerance, with
    // status Collision).
    const bool hit = solver_.gjk.status == coal::details::GJK::Collision ||
                     solver_.gjk.status == coal::details::GJK::CollisionWithPenetrationInformation;
    out.intersecting = hit || (!(d > 0) && !std::isnan(d));
    out.distance = std::isnan(d) ? d : (out.intersecting ? 0.0 : d);
    out.iterations = int(solver_.gjk.getNumIterations());
    out.exit = Exit::unknown;
  }

 private:
  using Convex = coal::Convex<coal::Triangle>;
  struct Query {
    const Convex* a;
    coal::Transform3s ta;
    const Convex* b;
    coal::Transform3s tb;
  };

  const Convex* convex(const VertexList& v) {
    auto [it, inserted] = shapes_.try_emplace(v.get());
    if (inserted) {
      const Hull& hull = cached_hull(v);
      auto points = std::make_shared<std::vector<coal::Vec3s>>();
      for (const Vec3<double>& p : hull.vertices) points->push_back(p);
      // Hull faces fanned into triangles: coal::Convex derives each vertex's neighbours from
      // them, which its support function climbs on large hulls.
      auto triangles = std::make_shared<std::vector<coal::Triangle>>();
      for (const std::vector<int>& f : hull.faces)
        for (std::size_t k = 1; k + 1 < f.size(); ++k)
          triangles->emplace_back(std::size_t(f[0]), std::size_t(f[k]), std::size_t(f[k + 1]));
      it->second = std::make_unique<Convex>(points, unsigned(points->size()), triangles,
                                            unsigned(triangles->size()));
    }
    return it->second.get();
  }

  coal::GJKSolver solver_;
  std::map<const void*, std::unique_ptr<Convex>> shapes_;
  std::vector<Query> queries_;
};
#endif

#if NEARPOINT_BENCH_HAVE_COAL
// The depth experiment: coal's GJK + EPA on coal::Convex, gjk_tolerance = epa_tolerance = the
// knob, EPA's default iteration cap (64).
class CoalDepthRunner final : public Runner {
 public:
  CoalDepthRunner(std::span<const PairInput> inputs, double tolerance) {
    if (!std::isnan(tolerance)) {
      solver_.gjk_tolerance = tolerance;
      solver_.epa_tolerance = tolerance;
    }
    queries_.reserve(inputs.size());
    for (const PairInput& in : inputs)
      queries_.push_back(
          {convex(in.a), coal_transform(in.pose_a), convex(in.b), coal_transform(in.pose_b)});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    coal::Vec3s p1, p2, normal;
    const double d =
        solver_.shapeDistance(*q.a, q.ta, *q.b, q.tb, /*compute_penetration=*/true, p1, p2, normal);
    // A negative distance is −depth (EPA); a collision found by GJK within its tolerance
    // without EPA reports a small distance ≥ 0: depth 0.
    const bool hit = solver_.gjk.status == coal::details::GJK::Collision ||
                     solver_.gjk.status == coal::details::GJK::CollisionWithPenetrationInformation;
    out.intersecting = hit;
    out.depth = std::isnan(d) ? d : (d < 0 ? -d : 0.0);
    out.exit =
        solver_.epa.status == coal::details::EPA::Failed ? Exit::iteration_cap : Exit::unknown;
    out.code_a = int(solver_.gjk.status);
    out.code_b = int(solver_.epa.status);
  }

 private:
  using Convex = coal::Convex<coal::Triangle>;
  struct Query {
    const Convex* a;
    coal::Transform3s ta;
    const Convex* b;
    coal::Transform3s tb;
  };
  const Convex* convex(const VertexList& v) {
    auto [it, inserted] = shapes_.try_emplace(v.get());
    if (inserted) {
      const Hull& hull = cached_hull(v);
      auto points = std::make_shared<std::vector<coal::Vec3s>>();
      for (const Vec3<double>& p : hull.vertices) points->push_back(p);
      auto triangles = std::make_shared<std::vector<coal::Triangle>>();
      for (const std::vector<int>& f : hull.faces)
        for (std::size_t k = 1; k + 1 < f.size(); ++k)
          triangles->emplace_back(std::size_t(f[0]), std::size_t(f[k]), std::size_t(f[k + 1]));
      it->second = std::make_unique<Convex>(points, unsigned(points->size()), triangles,
                                            unsigned(triangles->size()));
    }
    return it->second.get();
  }
  coal::GJKSolver solver_;
  std::map<const void*, std::unique_ptr<Convex>> shapes_;
  std::vector<Query> queries_;
};
#endif

// ---------------------------------------------------------------------------------------------
// Primitives (issue 25, item 3): the peers' own shape types and their best path.

class FclPrimitiveRunner final : public Runner {
 public:
  FclPrimitiveRunner(std::span<const PrimitiveInput> inputs, fcl::GJKSolverType solver)
      : request_(/*enable_nearest_points=*/true) {
    request_.gjk_solver_type = solver;
    queries_.reserve(inputs.size());
    for (const PrimitiveInput& in : inputs)
      queries_.push_back({shape(in.a), transform(in.pose_a), shape(in.b), transform(in.pose_b)});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    fcl::DistanceResultd result;
    fcl::distance(q.a, q.ta, q.b, q.tb, request_, result);
    const double d = result.min_distance;
    out.intersecting = d <= 0;
    out.distance = d <= 0 ? 0.0 : d;
    out.exit = Exit::unknown;
  }

 private:
  struct Query {
    const fcl::CollisionGeometryd* a;
    fcl::Transform3d ta;
    const fcl::CollisionGeometryd* b;
    fcl::Transform3d tb;
  };
  static fcl::Transform3d transform(const Pose<double>& pose) {
    fcl::Transform3d t = fcl::Transform3d::Identity();
    t.linear() = pose.rotation;
    t.translation() = pose.translation;
    return t;
  }
  const fcl::CollisionGeometryd* shape(const Primitive* p) {
    auto [it, inserted] = shapes_.try_emplace(p);
    if (inserted) {
      switch (p->kind) {
        case Primitive::Kind::sphere:
          it->second = std::make_unique<fcl::Sphered>(p->radius);
          break;
        case Primitive::Kind::capsule:
          it->second = std::make_unique<fcl::Capsuled>(p->radius, 2 * p->half_length);
          break;
        case Primitive::Kind::box:
          it->second = std::make_unique<fcl::Boxd>(2 * p->half_extents);
          break;
        case Primitive::Kind::hull: {
          const Hull& hull = cached_hull(p->hull);
          auto vertices = std::make_shared<std::vector<fcl::Vector3d>>();
          for (const Vec3<double>& v : hull.vertices) vertices->push_back(v);
          auto faces = std::make_shared<std::vector<int>>();
          for (const std::vector<int>& f : hull.faces) {
            faces->push_back(int(f.size()));
            faces->insert(faces->end(), f.begin(), f.end());
          }
          it->second = std::make_unique<fcl::Convexd>(vertices, int(hull.faces.size()), faces);
          break;
        }
      }
    }
    return it->second.get();
  }
  fcl::DistanceRequestd request_;
  std::map<const void*, std::unique_ptr<fcl::CollisionGeometryd>> shapes_;
  std::vector<Query> queries_;
};

#if NEARPOINT_BENCH_HAVE_COAL
class CoalPrimitiveRunner final : public Runner {
 public:
  CoalPrimitiveRunner(std::span<const PrimitiveInput> inputs, double tolerance) {
    solver_.gjk_tolerance = tolerance;
    queries_.reserve(inputs.size());
    for (const PrimitiveInput& in : inputs)
      queries_.push_back({shape(in.a), coal_transform(in.pose_a), shape(in.b),
                          coal_transform(in.pose_b), dispatch(in.a->kind, in.b->kind)});
  }

  void run(std::size_t i, Outcome& out) override {
    const Query& q = queries_[i];
    coal::Vec3s p1, p2, normal;
    const double d = q.call(q.a, q.ta, q.b, q.tb, &solver_, false, p1, p2, normal);
    out.intersecting = !(d > 0) && !std::isnan(d);
    out.distance = std::isnan(d) ? d : (d > 0 ? d : 0.0);
    out.exit = Exit::unknown;
  }

 private:
  using Call = coal::CoalScalar (*)(const coal::CollisionGeometry*, const coal::Transform3s&,
                                    const coal::CollisionGeometry*, const coal::Transform3s&,
                                    const coal::GJKSolver*, bool, coal::Vec3s&, coal::Vec3s&,
                                    coal::Vec3s&);
  using Convex = coal::Convex<coal::Triangle>;
  struct Query {
    const coal::CollisionGeometry* a;
    coal::Transform3s ta;
    const coal::CollisionGeometry* b;
    coal::Transform3s tb;
    Call call;
  };

  // coal's own dispatch (its distance function matrix) picks internal::ShapeShapeDistance<T1, T2>
  // by the node types; here it is picked once per query when the inputs are prepared.
  template <class T1>
  static Call second(Primitive::Kind b) {
    switch (b) {
      case Primitive::Kind::sphere:
        return &coal::internal::ShapeShapeDistance<T1, coal::Sphere>;
      case Primitive::Kind::capsule:
        return &coal::internal::ShapeShapeDistance<T1, coal::Capsule>;
      case Primitive::Kind::box:
        return &coal::internal::ShapeShapeDistance<T1, coal::Box>;
      case Primitive::Kind::hull:
        return &coal::internal::ShapeShapeDistance<T1, Convex>;
    }
    return nullptr;
  }
  static Call dispatch(Primitive::Kind a, Primitive::Kind b) {
    switch (a) {
      case Primitive::Kind::sphere:
        return second<coal::Sphere>(b);
      case Primitive::Kind::capsule:
        return second<coal::Capsule>(b);
      case Primitive::Kind::box:
        return second<coal::Box>(b);
      case Primitive::Kind::hull:
        return second<Convex>(b);
    }
    return nullptr;
  }

  const coal::CollisionGeometry* shape(const Primitive* p) {
    auto [it, inserted] = shapes_.try_emplace(p);
    if (inserted) {
      switch (p->kind) {
        case Primitive::Kind::sphere:
          it->second = std::make_unique<coal::Sphere>(p->radius);
          break;
        case Primitive::Kind::capsule:
          it->second = std::make_unique<coal::Capsule>(p->radius, 2 * p->half_length);
          break;
        case Primitive::Kind::box:
          it->second = std::make_unique<coal::Box>(coal::Vec3s(2 * p->half_extents));
          break;
        case Primitive::Kind::hull: {
          const Hull& hull = cached_hull(p->hull);
          auto points = std::make_shared<std::vector<coal::Vec3s>>();
          for (const Vec3<double>& v : hull.vertices) points->push_back(v);
          auto triangles = std::make_shared<std::vector<coal::Triangle>>();
          for (const std::vector<int>& f : hull.faces)
            for (std::size_t k = 1; k + 1 < f.size(); ++k)
              triangles->emplace_back(std::size_t(f[0]), std::size_t(f[k]), std::size_t(f[k + 1]));
          it->second = std::make_unique<Convex>(points, unsigned(points->size()), triangles,
                                                unsigned(triangles->size()));
          break;
        }
      }
    }
    return it->second.get();
  }

  coal::GJKSolver solver_;
  std::map<const void*, std::unique_ptr<coal::CollisionGeometry>> shapes_;
  std::vector<Query> queries_;
};
#endif

}  // namespace

std::unique_ptr<Runner> make_primitive_peer_runner(PrimitivePeer peer,
                                                   std::span<const PrimitiveInput> inputs,
                                                   std::string* why) {
  switch (peer) {
    case PrimitivePeer::fcl_libccd:
      return std::make_unique<FclPrimitiveRunner>(inputs, fcl::GST_LIBCCD);
    case PrimitivePeer::fcl_indep:
      return std::make_unique<FclPrimitiveRunner>(inputs, fcl::GST_INDEP);
    case PrimitivePeer::coal_1e12:
    case PrimitivePeer::coal_1e6:
#if NEARPOINT_BENCH_HAVE_COAL
      return std::make_unique<CoalPrimitiveRunner>(inputs,
                                                   peer == PrimitivePeer::coal_1e12 ? 1e-12 : 1e-6);
#else
      if (why) *why = "coal's snapshot was not found (NEARPOINT_PEERS_DIR, bench/run.sh --peers)";
      return nullptr;
#endif
  }
  if (why) *why = "unknown peer";
  return nullptr;
}

std::unique_ptr<Runner> make_depth_peer_runner(DepthPeer peer, std::span<const PairInput> inputs,
                                               const PeerSettings& settings, std::string* why) {
  for (const PairInput& in : inputs) {
    if (in.radius_a > 0 || in.radius_b > 0) {
      if (why) *why = "the depth experiment's peers take polytopes only";
      return nullptr;
    }
  }
  switch (peer) {
    case DepthPeer::coal:
#if NEARPOINT_BENCH_HAVE_COAL
      return std::make_unique<CoalDepthRunner>(inputs, settings.tolerance);
#else
      if (why) *why = "coal's snapshot was not found (NEARPOINT_PEERS_DIR, bench/run.sh --peers)";
      return nullptr;
#endif
    case DepthPeer::fcl_epa:
    case DepthPeer::fcl_mpr:
      return std::make_unique<FclDepthRunner>(inputs, peer == DepthPeer::fcl_epa,
                                              settings.tolerance);
    case DepthPeer::libccd_epa:
      return std::make_unique<CcdDepthRunner>(inputs, settings.tolerance);
    case DepthPeer::bullet:
      return std::make_unique<BulletDepthRunner>(inputs);
  }
  if (why) *why = "unknown peer";
  return nullptr;
}

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
    case Peer::opengjk:
#if NEARPOINT_BENCH_HAVE_OPENGJK
      for (const PairInput& in : inputs) {
        if (in.radius_a > 0 || in.radius_b > 0) {
          if (why) *why = "openGJK takes vertex lists only (no rounded polytopes)";
          return nullptr;
        }
      }
      return std::make_unique<OpenGjkRunner>(inputs);
#else
      if (why)
        *why = "openGJK's snapshot was not found (NEARPOINT_PEERS_DIR, bench/run.sh --peers)";
      return nullptr;
#endif
    case Peer::coal:
#if NEARPOINT_BENCH_HAVE_COAL
      for (const PairInput& in : inputs) {
        if (in.radius_a > 0 || in.radius_b > 0) {
          if (why) *why = "coal::Convex is used without its swept-sphere radius here";
          return nullptr;
        }
      }
      return std::make_unique<CoalRunner>(inputs, settings.tolerance);
#else
      if (why) *why = "coal's snapshot was not found (NEARPOINT_PEERS_DIR, bench/run.sh --peers)";
      return nullptr;
#endif
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
