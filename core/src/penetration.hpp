// SPDX-License-Identifier: Apache-2.0
// Certified penetration depth: an expanding polytope (EPA, van den Bergen 2001) inside
// K = A − B, started from GJK's final simplex, with an interval that is proven to contain the
// depth of the shapes posed exactly as given. Internal to the core; distance.cpp calls it after
// the loop when `options.penetration_depth` is set and the verdict is "intersecting".
//
// The depth of K's interior point 0 is min over unit u of h_K(u) (the distance from 0 to ∂K).
//  - Upper end: h_K(u) for every direction u tried (a face normal), rounding added; the least.
//  - Lower end: the expanded polytope P is a closed triangulated surface whose vertices V are
//    computed support points of K. If P winds once around the origin, every ray from 0 leaves P
//    through a face crossed outwards, at or before the ray leaves co V; so the least signed
//    offset of P's face planes is at most the inradius of co V about 0, which is at most the
//    depth of K once the vertices' rounding (≤ the roundoff allowance, as for every support point
//    the engine forms) is taken off. This needs neither convexity of the computed P (rounding can
//    dent it) nor an exact history: the winding number is checked once at the end from the faces'
//    solid angles with their rounding bounded, and each face's offset is lowered by what rounding
//    of its cross-product normal and of its plane offset can have added (penetration_lower_bound's
//    bound, signed).
// Faces and vertices live in a per-thread buffer sized once for the largest cap asked: nothing
// is allocated per query.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <vector>

#include "gjk.hpp"
#include "nearpoint/options.hpp"
#include "nearpoint/result.hpp"

namespace nearpoint::detail {

template <class S>
struct EpaVertex {
  Vec3<S> y, a, b;  // the point of K and its support points on A and B (gjk.hpp's frame)
  std::int32_t ia, ib;
};

template <class S>
struct EpaFace {
  int v[3];     // vertex indices, counter-clockwise seen from outside
  int adj[3];   // the face across edge (v[i], v[i+1])
  int edge[3];  // that edge's index in adj[i]
  Vec3<S> normal;
  S offset;  // estimate of the plane's signed distance from 0 (positive: 0 inside)
  bool alive;
};

/// The per-thread working storage, grown (once) to the largest cap a query asked for.
template <class S>
struct EpaBuffer {
  std::vector<EpaVertex<S>> vertices;
  std::vector<EpaFace<S>> faces;
  std::vector<int> removed, horizon_face, horizon_edge, slot_of_vertex;
  void reserve(int iterations) {
    const std::size_t v = std::size_t(iterations) + 8, f = 2 * std::size_t(iterations) + 16;
    if (vertices.size() < v) {
      vertices.resize(v);
      slot_of_vertex.assign(v, -1);
    }
    if (faces.size() < f) {
      faces.resize(f);
      removed.reserve(f);
      horizon_face.reserve(3 * f);  // a horizon edge is an edge of a kept face
      horizon_edge.reserve(3 * f);
    }
  }
};

template <class S>
EpaBuffer<S>& epa_buffer() {
  thread_local EpaBuffer<S> buffer;
  return buffer;
}

/// What the expansion proves about the cores (gjk.hpp's frame: A's frame, origin shifted).
template <class S>
struct DepthOutcome {
  S lower = 0, upper = std::numeric_limits<S>::infinity(), estimate = 0;
  Vec3<S> direction = Vec3<S>::Zero();  // unit, K's outward normal: A → B
  Vec3<S> on_a = Vec3<S>::Zero(), on_b = Vec3<S>::Zero();
  DepthTermination termination = DepthTermination::tolerance;
  int iterations = 0;
  int support_calls = 0;
};

/// A certified lower bound on the exact signed offset of the plane through (p, q, r), oriented by
/// (q − p) × (r − p), from the origin; −∞ when rounding leaves its sign open. The rounding of
/// the normal (8u·Σ|products| per component) and of n·p (4u·|n||p|) is taken off as in
/// penetration_lower_bound (johnson.hpp, certify_plane).
template <class S>
S certified_face_offset(const Vec3<S>& p, const Vec3<S>& q, const Vec3<S>& r) {
  const CertifiedPlane<S> plane = certify_plane(p, q, r);
  const S numerator = plane.dot - plane.excess;
  if (!plane.oriented || !(numerator > 0)) return -std::numeric_limits<S>::infinity();
  return plane.lower(numerator);
}

/// Whether the closed surface of the alive faces winds exactly once around the origin, from the
/// sum of the faces' solid angles (Van Oosterom & Strackee) with each one's rounding bounded: an
/// error η in the atan2 arguments moves the angle by at most η/|(num, den)|.
template <class S>
bool winds_once(const EpaBuffer<S>& buffer, int face_count) {
  using std::abs;
  constexpr S u = std::numeric_limits<S>::epsilon() / 2;
  S total = 0, error = 0;
  for (int i = 0; i < face_count; ++i) {
    const EpaFace<S>& f = buffer.faces[std::size_t(i)];
    if (!f.alive) continue;
    const Vec3<S>& a = buffer.vertices[std::size_t(f.v[0])].y;
    const Vec3<S>& b = buffer.vertices[std::size_t(f.v[1])].y;
    const Vec3<S>& c = buffer.vertices[std::size_t(f.v[2])].y;
    const S la = a.norm(), lb = b.norm(), lc = c.norm();
    const S num = a.dot(b.cross(c));
    const S den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    const S size = std::hypot(num, den);
    const S eta = S(32) * u * la * lb * lc;
    if (!(size > S(4) * eta)) return false;
    total += S(2) * std::atan2(num, den);
    error += S(2) * eta / (size - eta) + S(16) * u;
  }
  constexpr S four_pi = S(4) * std::numbers::pi_v<S>;
  return abs(total - four_pi) + error < S(0.5) * four_pi;
}

/// EPA on K from the loop's final simplex, whose origin is enclosed (ν = 0). `slack` is what a
/// computed support point may be from a true point of K (the roundoff allowance plus pose A's
/// rotation defect): it comes off the lower end and onto the upper one. `target` is the width the
/// expansion stops at; `proven_above` ends it as soon as the nearest face is that far from the
/// origin (the verdict's use: an overlap needs only a positive lower end, not a converged one).
template <class S, class K>
void expand_polytope(const K& k_set, const LoopOutcome<S>& loop, S magnitude, S slack, S target,
                     int max_iterations, DepthOutcome<S>& out,
                     S proven_above = std::numeric_limits<S>::infinity()) {
  using std::abs;
  constexpr S u = std::numeric_limits<S>::epsilon() / 2;
  const S tiny = distance_roundoff(magnitude);
  EpaBuffer<S>& buffer = epa_buffer<S>();
  max_iterations = std::clamp(max_iterations, 0, kLargestDepthMaxIterations);
  buffer.reserve(max_iterations);
  auto& vertices = buffer.vertices;
  auto& faces = buffer.faces;
  const int face_capacity = int(faces.size());
  int vertex_count = 0, face_count = 0;

  // The best upper bound: h_K(d̂) ≤ d̂·w rounded up, for each direction tried.
  S best_upper = std::numeric_limits<S>::infinity();
  Vec3<S> best_direction = Vec3<S>::Zero();
  const auto support = [&](const Vec3<S>& direction, EpaVertex<S>& v) {
    k_set.support(direction, v.y, v.a, v.b, v.ia, v.ib);
    ++out.support_calls;
    const S length = direction.norm();
    if (!(length > 0)) return;
    const Vec3<S> unit = direction / length;
    const S value = unit.dot(v.y);
    const S upper = value + S(8) * u * (abs(value) + v.y.norm()) + slack + tiny;
    if (upper < best_upper) {
      best_upper = upper;
      best_direction = unit;
    }
  };

  // The start: the final simplex's points, grown to a tetrahedron when GJK ended on a point, a
  // segment or a triangle through the origin (exact contact, coincident shapes). The origin need
  // not be inside (a loop that ended at its numerical limit with |ν| ≈ 0): faces it lies beyond
  // have negative offsets and are expanded first, and the certificate checks the enclosure.
  const Simplex<S>& simplex = loop.simplex;
  for (int i = 0; i < 4; ++i) {
    if (!(simplex.used & (1u << i))) continue;
    bool repeated = false;
    for (int j = 0; j < vertex_count; ++j) repeated |= vertices[std::size_t(j)].y == simplex.y[i];
    if (repeated) continue;
    vertices[std::size_t(vertex_count++)] = {simplex.y[i], simplex.a[i], simplex.b[i],
                                             simplex.index_a[i], simplex.index_b[i]};
  }
  const auto finish_flat = [&]() {
    // K has no interior near the origin to this precision: the depth is in [0, best upper].
    out.termination = DepthTermination::degenerate;
    out.lower = 0;
    out.upper = std::max(S(0), best_upper);
    out.estimate = 0;
    out.direction = best_direction;
    // The witnesses: the cores' common point the loop found (ν = Σλy = 0).
    out.on_a.setZero();
    out.on_b.setZero();
    for (int i = 0; i < 4; ++i) {
      if (!(loop.nearest.subset & (1u << i))) continue;
      out.on_a += loop.nearest.lambda[i] * loop.simplex.a[i];
      out.on_b += loop.nearest.lambda[i] * loop.simplex.b[i];
    }
  };
  if (vertex_count == 1) {
    const Vec3<S> axes[6] = {Vec3<S>(1, 0, 0),  Vec3<S>(-1, 0, 0), Vec3<S>(0, 1, 0),
                             Vec3<S>(0, -1, 0), Vec3<S>(0, 0, 1),  Vec3<S>(0, 0, -1)};
    for (const Vec3<S>& d : axes) {
      EpaVertex<S>& w = vertices[1];
      support(d, w);
      if ((w.y - vertices[0].y).norm() > tiny) {
        vertex_count = 2;
        break;
      }
    }
    if (vertex_count == 1) return finish_flat();
  }
  if (vertex_count == 2) {
    const Vec3<S> e = vertices[1].y - vertices[0].y;
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (abs(e[k]) < abs(e[axis])) axis = k;
    const Vec3<S> d1 = e.cross(Vec3<S>::Unit(axis)).normalized();
    const Vec3<S> d2 = e.cross(d1).normalized();
    const Vec3<S> tries[4] = {d1, -d1, d2, -d2};
    const S e_length = e.norm();
    for (const Vec3<S>& d : tries) {
      EpaVertex<S>& w = vertices[2];
      support(d, w);
      if ((w.y - vertices[0].y).cross(e).norm() > tiny * e_length) {
        vertex_count = 3;
        break;
      }
    }
    if (vertex_count == 2) return finish_flat();
  }
  if (vertex_count == 3) {
    const Vec3<S> n =
        (vertices[1].y - vertices[0].y).cross(vertices[2].y - vertices[0].y).normalized();
    EpaVertex<S> plus, minus;
    support(n, plus);
    support(-n, minus);
    const S h_plus = n.dot(plus.y - vertices[0].y), h_minus = -n.dot(minus.y - vertices[0].y);
    if (!(std::max(h_plus, h_minus) > tiny)) return finish_flat();
    vertices[3] = h_plus >= h_minus ? plus : minus;
    vertex_count = 4;
  }
  if (vertex_count != 4) return finish_flat();

  const auto make_face = [&](int slot, int i0, int i1, int i2) {
    EpaFace<S>& f = faces[std::size_t(slot)];
    f.v[0] = i0;
    f.v[1] = i1;
    f.v[2] = i2;
    f.alive = true;
    const Vec3<S>& p = vertices[std::size_t(i0)].y;
    const Vec3<S> n = (vertices[std::size_t(i1)].y - p).cross(vertices[std::size_t(i2)].y - p);
    const S length = n.norm();
    if (length > 0) {
      f.normal = n / length;
      f.offset = f.normal.dot(p);
    } else {
      f.normal.setZero();
      f.offset = std::numeric_limits<S>::infinity();  // never expanded; certified as 0 below
    }
  };
  {
    const Vec3<S>& p0 = vertices[0].y;
    const S volume = (vertices[1].y - p0).dot((vertices[2].y - p0).cross(vertices[3].y - p0));
    if (!(abs(volume) > 0)) return finish_flat();
    if (volume < 0) std::swap(vertices[1], vertices[2]);
    const int tet[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (int f = 0; f < 4; ++f) make_face(f, tet[f][0], tet[f][1], tet[f][2]);
    face_count = 4;
    // Adjacency by matching each directed edge with its reverse.
    for (int f = 0; f < 4; ++f)
      for (int i = 0; i < 3; ++i) {
        const int from = faces[std::size_t(f)].v[i], to = faces[std::size_t(f)].v[(i + 1) % 3];
        for (int g = 0; g < 4; ++g)
          for (int j = 0; j < 3; ++j)
            if (faces[std::size_t(g)].v[j] == to && faces[std::size_t(g)].v[(j + 1) % 3] == from) {
              faces[std::size_t(f)].adj[i] = g;
              faces[std::size_t(f)].edge[i] = j;
            }
      }
  }

  // The horizon seen from w: the faces w is above are removed (depth first, so that the horizon's
  // edges come out in order around it).
  // Faces w lies in the plane of (to rounding) go too: kept, they leave a reflex edge that a
  // later support point can sit above (coplanar facets of K, faces through the origin).
  const auto visible = [&](const EpaFace<S>& f, const Vec3<S>& w) {
    return f.normal.dot(w - vertices[std::size_t(f.v[0])].y) > -tiny;
  };
  const auto silhouette = [&](auto&& self, int g, int edge, const Vec3<S>& w) -> void {
    EpaFace<S>& f = faces[std::size_t(g)];
    if (!f.alive) return;
    if (!visible(f, w)) {
      buffer.horizon_face.push_back(g);
      buffer.horizon_edge.push_back(edge);
      return;
    }
    f.alive = false;
    buffer.removed.push_back(g);
    self(self, f.adj[(edge + 1) % 3], f.edge[(edge + 1) % 3], w);
    self(self, f.adj[(edge + 2) % 3], f.edge[(edge + 2) % 3], w);
  };

  int nearest = 0;
  out.termination = DepthTermination::iteration_limit;
  for (int iteration = 0;; ++iteration) {
    nearest = -1;
    for (int i = 0; i < face_count; ++i) {
      const EpaFace<S>& f = faces[std::size_t(i)];
      if (f.alive && (nearest < 0 || f.offset < faces[std::size_t(nearest)].offset)) nearest = i;
    }
    if (nearest < 0 || !std::isfinite(faces[std::size_t(nearest)].offset)) {
      out.termination = DepthTermination::degenerate;
      break;
    }
    const EpaFace<S> face = faces[std::size_t(nearest)];
    if (best_upper - face.offset <= target || face.offset > proven_above) {
      out.termination = DepthTermination::tolerance;
      break;
    }
    if (iteration >= max_iterations || vertex_count >= int(vertices.size())) {
      out.termination = DepthTermination::iteration_limit;
      break;
    }
    EpaVertex<S>& w = vertices[std::size_t(vertex_count)];
    support(face.normal, w);
    out.iterations = iteration + 1;
    if (best_upper - face.offset <= target) {
      out.termination = DepthTermination::tolerance;
      break;
    }
    // No progress possible: w is not above the face by more than rounding (the face is one of
    // K's to this precision), or w repeats a vertex of the polytope.
    bool repeated = false;
    if (w.ia >= 0 && w.ib >= 0)
      for (int j = 0; j < vertex_count; ++j)
        repeated |= vertices[std::size_t(j)].ia == w.ia && vertices[std::size_t(j)].ib == w.ib;
    if (repeated || !(face.normal.dot(w.y) - face.offset > tiny)) {
      out.termination = DepthTermination::tolerance;
      if (best_upper - face.offset > S(4) * (target + slack + tiny))
        out.termination = DepthTermination::degenerate;
      break;
    }
    buffer.removed.clear();
    buffer.horizon_face.clear();
    buffer.horizon_edge.clear();
    faces[std::size_t(nearest)].alive = false;
    buffer.removed.push_back(nearest);
    for (int i = 0; i < 3; ++i) silhouette(silhouette, face.adj[i], face.edge[i], w.y);
    const int h = int(buffer.horizon_face.size());
    const int needed = h - int(buffer.removed.size());
    bool ok = h >= 3 && face_count + needed <= face_capacity;
    // The horizon must be one simple loop: each vertex starts exactly one of its edges.
    for (int k = 0; ok && k < h; ++k) {
      const EpaFace<S>& g = faces[std::size_t(buffer.horizon_face[std::size_t(k)])];
      const int start = g.v[(buffer.horizon_edge[std::size_t(k)] + 1) % 3];
      if (buffer.slot_of_vertex[std::size_t(start)] >= 0) ok = false;
      buffer.slot_of_vertex[std::size_t(start)] = k;
    }
    for (int k = 0; ok && k < h; ++k) {
      const EpaFace<S>& g = faces[std::size_t(buffer.horizon_face[std::size_t(k)])];
      if (buffer.slot_of_vertex[std::size_t(g.v[buffer.horizon_edge[std::size_t(k)]])] < 0)
        ok = false;
    }
    if (!ok) {
      for (int k = 0; k < h; ++k) {
        const EpaFace<S>& g = faces[std::size_t(buffer.horizon_face[std::size_t(k)])];
        buffer.slot_of_vertex[std::size_t(g.v[(buffer.horizon_edge[std::size_t(k)] + 1) % 3])] = -1;
      }
      for (int r : buffer.removed) faces[std::size_t(r)].alive = true;
      out.termination = h >= 3 && face_count + needed > face_capacity
                            ? DepthTermination::iteration_limit
                            : DepthTermination::degenerate;
      break;
    }
    // New faces (b, a, w) over each horizon edge a → b of a kept face g: removed slots first.
    const int wi = vertex_count++;
    const auto slot_for = [&](int k) {
      return k < int(buffer.removed.size()) ? buffer.removed[std::size_t(k)]
                                            : face_count + (k - int(buffer.removed.size()));
    };
    for (int k = 0; k < h; ++k) {
      const int g = buffer.horizon_face[std::size_t(k)], j = buffer.horizon_edge[std::size_t(k)];
      const int slot = slot_for(k);
      const int b = faces[std::size_t(g)].v[(j + 1) % 3], a = faces[std::size_t(g)].v[j];
      make_face(slot, b, a, wi);
      EpaFace<S>& f = faces[std::size_t(slot)];
      f.adj[0] = g;
      f.edge[0] = j;
      faces[std::size_t(g)].adj[j] = slot;
      faces[std::size_t(g)].edge[j] = 0;
    }
    // Edge a → w of the face over (b, a) meets edge w → a of the face that starts at a.
    for (int k = 0; k < h; ++k) {
      const int slot = slot_for(k);
      const int a = faces[std::size_t(slot)].v[1];
      const int next = slot_for(buffer.slot_of_vertex[std::size_t(a)]);
      faces[std::size_t(slot)].adj[1] = next;
      faces[std::size_t(slot)].edge[1] = 2;
      faces[std::size_t(next)].adj[2] = slot;
      faces[std::size_t(next)].edge[2] = 1;
    }
    for (int k = 0; k < h; ++k) {
      const EpaFace<S>& f = faces[std::size_t(slot_for(k))];
      buffer.slot_of_vertex[std::size_t(f.v[0])] = -1;
    }
    face_count += std::max(0, needed);
  }

  // The certificate (see the top of this file).
  S lowest = std::numeric_limits<S>::infinity();
  for (int i = 0; i < face_count; ++i) {
    const EpaFace<S>& f = faces[std::size_t(i)];
    if (!f.alive) continue;
    lowest = std::min(lowest, certified_face_offset(vertices[std::size_t(f.v[0])].y,
                                                    vertices[std::size_t(f.v[1])].y,
                                                    vertices[std::size_t(f.v[2])].y));
    if (!(lowest > 0)) break;
  }
  if (!(lowest > 0) || !winds_once(buffer, face_count)) lowest = 0;
  out.lower = std::max(S(0), lowest - slack);
  out.upper = std::max(out.lower, best_upper);

  // The estimate and the witnesses from the nearest face: the origin's projection on its plane,
  // as a convex combination of its corners. A facet of K is split into several coplanar
  // triangles whose offsets tie to rounding; the witness comes from the one among them that
  // holds the projection (the others' clamped weights would give points off the contact).
  if (nearest >= 0 && std::isfinite(faces[std::size_t(nearest)].offset)) {
    const S tie = faces[std::size_t(nearest)].offset + target;
    int chosen = nearest;
    S chosen_outside = std::numeric_limits<S>::infinity();
    S lambda[3], sum = 0;
    for (int i = 0; i < face_count; ++i) {
      const EpaFace<S>& g = faces[std::size_t(i)];
      if (!g.alive || !(g.offset <= tie)) continue;
      const Vec3<S> q = g.offset * g.normal;
      S l[3], total = 0, outside = 0;
      for (int k = 0; k < 3; ++k) {
        const Vec3<S> e1 = vertices[std::size_t(g.v[(k + 1) % 3])].y - q;
        const Vec3<S> e2 = vertices[std::size_t(g.v[(k + 2) % 3])].y - q;
        l[k] = g.normal.dot(e1.cross(e2));
        total += l[k];
        outside = std::max(outside, -l[k]);
      }
      if (!(total > 0)) continue;
      outside /= total;
      if (outside < chosen_outside) {
        chosen_outside = outside;
        chosen = i;
        sum = 0;
        for (int k = 0; k < 3; ++k) sum += (lambda[k] = std::max(S(0), l[k]));
      }
    }
    const EpaFace<S>& f = faces[std::size_t(chosen)];
    const EpaVertex<S>* v[3] = {&vertices[std::size_t(f.v[0])], &vertices[std::size_t(f.v[1])],
                                &vertices[std::size_t(f.v[2])]};
    if (!(sum > 0)) lambda[0] = lambda[1] = lambda[2] = sum = S(1);
    out.on_a.setZero();
    out.on_b.setZero();
    for (int i = 0; i < 3; ++i) {
      out.on_a += (lambda[i] / sum) * v[i]->a;
      out.on_b += (lambda[i] / sum) * v[i]->b;
    }
    out.direction = f.normal;
    out.estimate = std::clamp(f.offset, out.lower, out.upper);
  } else {
    out.direction = best_direction;
    out.estimate = out.lower;
    out.on_a = vertices[0].a;
    out.on_b = vertices[0].b;
  }
}

/// The verdict for cores whose loop ended with the origin enclosed (ν = 0) but without a proof of
/// overlap: a point, segment or triangle through the origin (coincident or axis-aligned shapes:
/// the centroids' start is the origin itself), or a tetrahedron with a face within the bound of
/// it. A few steps of the expansion tell an overlap from a touch: stopped as soon as the nearest
/// face is clearly away from the origin, certified as the depth's lower end is. Returns whether
/// the overlap is proven; `support_calls` counts what it cost.
template <class S, class K>
[[gnu::noinline, gnu::cold]] bool overlap_proven_by_expansion(const K& k_set,
                                                              const LoopOutcome<S>& loop,
                                                              S magnitude, S slack,
                                                              int& support_calls) {
  constexpr int kVerdictIterations = 32;  // a touch ends at once (no progress); overlaps in a few
  const S margin = S(4) * (slack + distance_roundoff(magnitude));
  // The common touch first, for a support call or two: the loop ended on a triangle of K's points
  // through the origin, or a tetrahedron with a face through it (two faces in contact). Any unit
  // u bounds the depth from above, depth ≤ h_K(u); when that is within the margin for the
  // triangle's normal (either side) or for the outward normal of a face at the origin, no
  // overlap can be proven at this precision: the pair touches.
  const auto touch_along = [&](const Vec3<S>& u) {
    Vec3<S> w, on_a, on_b;
    std::int32_t ia, ib;
    k_set.support(u, w, on_a, on_b, ia, ib);
    ++support_calls;
    return u.dot(w) <= margin;
  };
  const unsigned subset = loop.nearest.subset;
  int idx[4], n = 0;
  for (int i = 0; i < 4; ++i)
    if (subset & (1u << i)) idx[n++] = i;
  const Vec3<S>* y = loop.simplex.y;
  if (n == 3) {
    Vec3<S> normal = (y[idx[1]] - y[idx[0]]).cross(y[idx[2]] - y[idx[0]]);
    const S length = normal.norm();
    if (length > 0) {
      normal /= length;
      if (touch_along(normal) || touch_along(-normal)) return false;
    }
  } else if (n == 4) {
    for (int drop = 0; drop < 4; ++drop) {
      const Vec3<S>& p = y[idx[(drop + 1) % 4]];
      Vec3<S> normal = (y[idx[(drop + 2) % 4]] - p).cross(y[idx[(drop + 3) % 4]] - p);
      const S length = normal.norm();
      if (!(length > 0)) continue;
      normal /= length;
      if (normal.dot(y[idx[drop]] - p) > 0) normal = -normal;  // outward: away from the 4th
      if (normal.dot(p) <= margin && touch_along(normal)) return false;
    }
  }
  DepthOutcome<S> depth;
  expand_polytope(k_set, loop, magnitude, slack, S(0), kVerdictIterations, depth, margin);
  support_calls += depth.support_calls;
  return depth.lower > 0;
}

/// What a query needs to place the depth's answer in the world (as write_near_points does).
template <class S>
struct DepthPlacement {
  const Pose<S>& pose_a;
  const Pose<S>& pose_b;
  bool far_centers;
  S radius_a, radius_b;
  /// The working magnitude M, the roundoff allowance (distance_roundoff(M)) and pose A's
  /// rotation defect allowance, as the distance's bound uses them; D(K).
  S magnitude, roundoff, defect_allowance, diameter;
};

/// The penetration depth and the signed distance into `result`, after the loop and certify().
/// Separated: φ is the distance with its bound, the depth 0. Intersecting cores (ν = 0): EPA.
/// Cores apart (only the rounded shells overlap, or the cores are within the bound of touching):
/// from the cores' distance interval, and one support call when it reaches 0.
template <class S, class K>
[[gnu::noinline, gnu::cold]] void write_penetration_depth(const K& k_set,
                                                          const LoopOutcome<S>& loop,
                                                          const DepthPlacement<S>& in,
                                                          const DistanceOptions<S>& options,
                                                          DistanceResult<S>& result) {
  using std::abs;
  using std::sqrt;
  constexpr S u = std::numeric_limits<S>::epsilon() / 2;
  if (result.status == Status::separated) {
    result.has_signed_distance = result.has_penetration_depth = true;
    result.signed_distance = result.distance;
    result.signed_distance_lower = std::max(S(0), result.distance - result.error_bound);
    result.signed_distance_upper = result.distance + result.error_bound;
    result.depth = result.depth_lower = result.depth_upper = 0;
    result.depth_termination = DepthTermination::closed_form;
    if (result.has_near_points) {
      result.depth_point_a = result.point_a;
      result.depth_point_b = result.point_b;
      result.depth_direction = result.normal;
    }
    return;
  }
  if (!result.in_contact()) return;
  const S radii = in.radius_a + in.radius_b;
  const S slack = in.roundoff + in.defect_allowance;
  const Nearest<S>& nearest = loop.nearest;
  S phi_lower, phi_upper, phi;  // the cores' signed distance
  Vec3<S> direction, on_a = Vec3<S>::Zero(), on_b = Vec3<S>::Zero();
  const bool enclosed = !(nearest.nu_norm2 > 0);
  if (enclosed) {
    phi_upper = sqrt(loop.gap) + slack;  // the enclosure's residual (certify's bound)
    phi_lower = 0;                       // replaced by the expansion's bound below
    phi = 0;
    direction.setZero();
  } else {
    // The cores' distance interval, as certify() bounds it.
    const S length = loop.nu_length;
    const S core_error =
        std::min(sqrt(loop.gap), std::max(S(0), length - loop.lower_bound)) + slack;
    phi_upper = length + core_error;
    phi_lower = length - core_error;
    phi = length;
    direction = -nearest.nu / length;
    for (int i = 0; i < 4; ++i) {
      if (!(nearest.subset & (1u << i))) continue;
      on_a += nearest.lambda[i] * loop.simplex.a[i];
      on_b += nearest.lambda[i] * loop.simplex.b[i];
    }
  }
  result.depth_termination = DepthTermination::closed_form;
  if (!(phi_lower > 0)) {
    // The cores may overlap: expand a polytope inside K.
    DepthOutcome<S> depth;
    const S target = std::max(std::max(S(0), options.depth_tolerance) * in.diameter,
                              S(4) * (slack + in.roundoff));
    expand_polytope(k_set, loop, in.magnitude, slack, target, options.depth_max_iterations, depth);
    result.support_calls += depth.support_calls;
    result.depth_iterations = depth.iterations;
    result.depth_termination = depth.termination;
    // |ν| − e bounds the distance, not φ: below 0 only the expansion's upper end bounds −φ.
    // Every point of K lies within D(K) of the origin (eq. 37), so the depth never exceeds it: the
    // cap when the expansion ended before any support plane bounded it (found by fuzz_engine: a
    // float box and polytope, depth_upper = inf, answered "not representable").
    const S cap = in.diameter * (S(1) + S(16) * u) + slack;
    phi_lower = -(depth.upper <= cap ? depth.upper : cap);
    if (depth.lower > 0) phi_upper = std::min(phi_upper, -depth.lower);
    if (enclosed || depth.estimate > 0) {
      phi = -depth.estimate;
      direction = depth.direction;
      on_a = depth.on_a;
      on_b = depth.on_b;
    }
    phi = std::clamp(phi, phi_lower, phi_upper);
  }
  // The rounded shapes: φ = φ_cores − r_A − r_B, each end rounded outwards.
  const S widen = S(4) * u * radii;
  phi_lower = phi_lower - radii - (widen + S(4) * u * abs(phi_lower));
  phi_upper = phi_upper - radii + (widen + S(4) * u * abs(phi_upper));
  phi = std::clamp(phi - radii, phi_lower, phi_upper);
  result.has_signed_distance = result.has_penetration_depth = true;
  result.signed_distance_lower = phi_lower;
  result.signed_distance_upper = phi_upper;
  result.depth_lower = std::max(S(0), -phi_upper);
  result.depth_upper = std::max(S(0), -phi_lower);
  result.signed_distance = phi;
  result.depth = std::clamp(std::max(S(0), -phi), result.depth_lower, result.depth_upper);
  // The verdict from the interval's sign (issue: touching vs intersecting). An overlap the
  // distance query proved already (d⁻, or the radii) stands; the interval settles the rest.
  if (phi_upper < 0) result.status = Status::intersecting;

  // The witnesses, world frame (as write_near_points places near points): each shape's deepest
  // point along the direction, a radius out from its core's.
  Vec3<S> base = k_set.a_center, origin = in.pose_a.translation;
  if (in.far_centers) {
    base = Vec3<S>::Zero();
    origin = compensated_difference(in.pose_a, k_set.a_center, static_cast<const Pose<S>*>(nullptr),
                                    base);
  }
  const Vec3<S> point_a = base + on_a + in.radius_a * direction;
  const Vec3<S> point_b = base + k_set.offset + on_b - in.radius_b * direction;
  result.depth_point_a = rotate(in.pose_a.rotation, point_a) + origin;
  result.depth_point_b = rotate(in.pose_a.rotation, point_b) + origin;
  result.depth_direction = rotate(in.pose_a.rotation, direction).stableNormalized();
}

}  // namespace nearpoint::detail
