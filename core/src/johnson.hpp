// SPDX-License-Identifier: Apache-2.0
// Johnson's distance subalgorithm (paper Section V, eq. 29–31) and the Backup Procedure (eq. 38).
// E. G. Gilbert, D. W. Johnson, S. S. Keerthi, "A Fast Procedure for Computing the Distance Between
// Complex Objects in Three-Dimensional Space", IEEE Journal of Robotics and Automation 4(2), 1988
// (equations as numbered there; docs/design.md has the paper by section).
//
// As the paper has it (inner products kept between iterations, subsets ordered as Section VI
// suggests), with the Δ's of every subset kept too; where roundoff defeats it, the loop falls back
// on the Backup Procedure as the paper does, or on signed volumes (options.hpp, Subalgorithm).
//
// The simplex V_k lives in four slots. Inner products y_i·y_j and the cofactors Δ_i(Y_s) of every
// subset Y_s (a 4-bit mask over the slots) are kept between iterations: when a support point
// replaces a slot, only the inner products of that slot and the Δ's of subsets containing it are
// recomputed (Section VI: "only (ν + 1) new inner products need to be calculated").
//
// Notation of the paper (with the equations its copy lost, written out in docs/design.md):
//   Δ_i({y_i}) = 1
//   Δ_j(Y_s ∪ {y_j}) = Σ_{i∈I_s} Δ_i(Y_s)·(y_i·y_k − y_i·y_j),  k = min I_s,  j ∉ I_s     (30)
//   Δ(Y_s) = Σ_{i∈I_s} Δ_i(Y_s)
//   ν(co Y) = Σ_{i∈I_s} λ_i y_i,  λ_i = Δ_i(Y_s)/Δ(Y_s)                                  (29),(31)
// valid for the subset with Δ(Y_s) > 0, Δ_i(Y_s) > 0 (i ∈ I_s) and Δ_j(Y_s ∪ {y_j}) ≤ 0 (j ∉ I_s).
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <limits>
#include <utility>

#include "nearpoint/pose.hpp"

namespace nearpoint::detail {

/// The number of points in a subset of the 4 simplex slots. A table rather than std::popcount,
/// which compiles to a libgcc call on x86-64 builds without -mpopcnt (measured: 10% of a warm
/// query's time).
inline int subset_size(unsigned subset) {
  static constexpr unsigned char kBits[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
  return kBits[subset & 15u];
}

template <class S>
inline bool same_sign(S a, S b) {
  // Zero and NaN are never "the same sign". Bitwise rather than short-circuit: the signs are
  // data, and a branch on each would mispredict.
  return ((a > 0) & (b > 0)) | ((a < 0) & (b < 0));
}

template <class S>
inline S det3(const Vec3<S>& a, const Vec3<S>& b, const Vec3<S>& c) {
  return a.dot(b.cross(c));
}

/// det(p1, p2, p3): the signed volume of the tetrahedron (0, p1, p2, p3), formed as
/// p1·((p2 − p1) × (p3 − p1)) (equal in exact arithmetic). The cross product of the points
/// themselves, p2 × p3, cancels terms of size |p|² when the tetrahedron lies far from the origin
/// (an error of ε|p|³ against a volume of h·|n|, with h the origin's distance from the face's
/// plane): the sign then came out at random, and a tetrahedron 10⁶ of its sizes away was taken to
/// enclose the origin. With edge vectors the error is ε|p|·|n|, i.e. h is resolved to a few ulps
/// of |p|, as the other three volumes (each formed about a vertex) already resolve theirs.
template <class S>
inline S volume_with_origin(const Vec3<S>& p1, const Vec3<S>& p2, const Vec3<S>& p3) {
  return p1.dot((p2 - p1).cross(p3 - p1));
}

/// Whether the origin lies strictly inside the tetrahedron (p0, p1, p2, p3), from the signs of
/// signed volumes formed directly from coordinates: with one vertex moved to the origin, each
/// volume must have the sign of the whole. Robust where the Δ's of a flat tetrahedron are not.
template <class S>
inline bool tetrahedron_encloses_origin(const Vec3<S>& p0, const Vec3<S>& p1, const Vec3<S>& p2,
                                        const Vec3<S>& p3) {
  const Vec3<S> zero = Vec3<S>::Zero();
  const S whole = det3<S>(p1 - p0, p2 - p0, p3 - p0);
  return same_sign(whole, volume_with_origin(p1, p2, p3)) &&
         same_sign(whole, det3<S>(zero - p0, p2 - p0, p3 - p0)) &&
         same_sign(whole, det3<S>(p1 - p0, zero - p0, p3 - p0)) &&
         same_sign(whole, det3<S>(p1 - p0, p2 - p0, zero - p0));
}

/// One Δ of eq. (30) to compute: Δ_m(Y_s) from the Δ's of Y_rest = Y_s \ {m}, k = min I_rest
/// (a singleton when `count` is 0: Δ = 1).
struct DeltaStep {
  unsigned char s, m, rest, k;
  unsigned char count;          // |Y_rest|
  unsigned char rest_slots[3];  // I_rest, increasing
};

/// The Δ's a point in one slot changes, in an order where each Y_rest is done before the Y_s
/// that needs it (smallest subsets first).
struct DeltaPlan {
  int count = 0;
  DeltaStep steps[20] = {};  // at most 1 + 6 + 9 + 4: the subsets with the slot, by size
};

/// The Δ's of the subsets of `used` that contain `slot`, smallest first.
constexpr DeltaPlan make_delta_plan(unsigned used, unsigned slot) {
  DeltaPlan plan;
  const unsigned required = 1u << slot;
  for (int size = 1; size <= 4; ++size) {
    for (unsigned s = 1; s < 16; ++s) {
      if (!(s & required) || (s & ~used) || std::popcount(s) != size) continue;
      for (int m = 0; m < 4; ++m) {
        if (!(s & (1u << m))) continue;
        const unsigned rest = s & ~(1u << m);
        DeltaStep step{};
        step.s = static_cast<unsigned char>(s);
        step.m = static_cast<unsigned char>(m);
        step.rest = static_cast<unsigned char>(rest);
        step.k = static_cast<unsigned char>(rest ? std::countr_zero(rest) : 0);
        for (int i = 0; i < 4; ++i)
          if (rest & (1u << i)) step.rest_slots[step.count++] = static_cast<unsigned char>(i);
        plan.steps[plan.count++] = step;
      }
    }
  }
  return plan;
}

template <class S>
struct Simplex {
  /// Points of K = A − B (shifted frame), and the support points on A and on B they came from
  /// (both relative to A's centroid, in A's frame: y = a − b − δ).
  Vec3<S> y[4];
  Vec3<S> a[4];
  Vec3<S> b[4];
  std::int32_t index_a[4];
  std::int32_t index_b[4];
  /// y_i·y_j for occupied slots.
  S dot[4][4];
  /// delta[s][i] = Δ_i(Y_s) for subset mask s and slot i ∈ s.
  S delta[16][4];
  /// V_k: occupied slots.
  unsigned used = 0;
  /// The slot added last (the newest support point), or -1 after initialisation.
  int newest = -1;
  /// `dot` and `delta` are up to date for every subset of `used`.
  bool tables_valid = true;

  int size() const { return subset_size(used); }

  /// Places a point in a free slot (there must be one: |used| ≤ 3). With `update_tables`, also
  /// updates the inner products and the Δ's of every subset that contains it (Johnson's method
  /// needs them every step; signed volumes only if the Backup Procedure runs, see
  /// rebuild_tables). Returns the slot.
  int add(const Vec3<S>& point, const Vec3<S>& on_a, const Vec3<S>& on_b, std::int32_t ia,
          std::int32_t ib, bool update_tables = true) {
    const int slot = std::countr_one(used);  // lowest free slot
    const unsigned bit = 1u << slot;
    y[slot] = point;
    a[slot] = on_a;
    b[slot] = on_b;
    index_a[slot] = ia;
    index_b[slot] = ib;
    used |= bit;
    newest = slot;
    tables_valid = update_tables && tables_valid;
    if (update_tables) update_tables_for(slot);
    return slot;
  }

  /// The inner products and Δ's that involve a newly added slot. Out of line, so that `add`
  /// itself stays small enough to inline into the loop (signed volumes never needs the tables).
  [[gnu::noinline]] void update_tables_for(int slot) {
    for (int i = 0; i < 4; ++i)
      if (used & (1u << i)) dot[slot][i] = dot[i][slot] = y[i].dot(y[slot]);
    // Subsets without the new slot keep their Δ's: their points have not changed.
    (this->*kFixedUpdates[(used & 15u) << 2 | unsigned(slot)])();
  }

  /// The Δ's that a point added to slot `Slot` of the occupied slots `Used` changes (those of the
  /// 1 + 3 + 3 + 1 subsets that contain it at most: 1 + 6 + 9 + 4 Δ's), unrolled at compile time
  /// into straight-line code with the slots as constants. One function per (Used, Slot), called
  /// through kFixedUpdates. (Read from a table of steps at run time, the same plan cost 10–15% more
  /// per query with Johnson's method; walking all 15 masks per subset size to find the steps, a
  /// fifth of a query.)
  template <unsigned Used, unsigned Slot>
  void update_deltas_fixed() {
    static constexpr DeltaPlan kPlan = make_delta_plan(Used, Slot);
    [&]<std::size_t... P>(std::index_sequence<P...>) {
      (apply_step<kPlan.steps[P]>(), ...);
    }
    (std::make_index_sequence<kPlan.count>{});
  }
  /// eq. (30), its terms in increasing slot order. (Summed from the first term rather than from 0:
  /// the two differ only in the sign of a zero Δ, which no test of Δ > 0 or Δ ≤ 0 sees.)
  template <DeltaStep St>
  void apply_step() {
    if constexpr (St.count == 0)
      delta[St.s][St.m] = 1;
    else if constexpr (St.count == 1)
      delta[St.s][St.m] = term(St, 0);
    else if constexpr (St.count == 2)
      delta[St.s][St.m] = term(St, 0) + term(St, 1);
    else
      delta[St.s][St.m] = (term(St, 0) + term(St, 1)) + term(St, 2);
  }
  /// Δ_i(Y_rest)·(y_i·y_k − y_i·y_m) for the j-th slot i of Y_rest.
  S term(const DeltaStep& st, int j) const {
    const int i = st.rest_slots[j];
    return delta[st.rest][i] * (dot[i][st.k] - dot[i][st.m]);
  }
  using FixedUpdate = void (Simplex::*)();
  template <std::size_t... Key>
  static constexpr std::array<FixedUpdate, 64> fixed_updates(std::index_sequence<Key...>) {
    return {&Simplex::update_deltas_fixed<unsigned(Key >> 2), unsigned(Key & 3)>...};
  }
  static constexpr std::array<FixedUpdate, 64> kFixedUpdates =
      fixed_updates(std::make_index_sequence<64>{});

  /// Recomputes every inner product and Δ of the occupied slots (after adds without tables): the
  /// slots taken in increasing order, as if added one by one, so each update finds the Δ's of the
  /// subsets without its slot already done.
  void rebuild_tables() {
    if (tables_valid) return;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j <= i; ++j)
        if ((used & (1u << i)) && (used & (1u << j))) dot[i][j] = dot[j][i] = y[i].dot(y[j]);
    for (unsigned i = 0; i < 4; ++i)
      if (used & (1u << i)) (this->*kFixedUpdates[(used & ((2u << i) - 1u)) << 2 | i])();
    tables_valid = true;
  }

  /// Keeps only the slots in `mask` (V̂_k). Their inner products and Δ's stay valid.
  void keep(unsigned mask) { used &= mask; }

  S det(unsigned s) const {
    S sum = 0;
    for (int i = 0; i < 4; ++i)
      if (s & (1u << i)) sum += delta[s][i];
    return sum;
  }

  /// Step 2 of the Distance Subalgorithm for subset s of V_k: Δ_i(Y_s) > 0 for i ∈ I_s and
  /// Δ_j(Y_s ∪ {y_j}) ≤ 0 for j ∈ I'_s. (Δ(Y_s) > 0 follows from the first.) Written so that a
  /// NaN fails the test.
  bool is_answer(unsigned s) const {
    for (int i = 0; i < 4; ++i) {
      const unsigned bit = 1u << i;
      if (s & bit) {
        if (!(delta[s][i] > 0)) return false;
      } else if (used & bit) {
        if (!(delta[s | bit][i] <= 0)) return false;
      }
    }
    return subset_size(s) < 4 || encloses_origin();
  }

  /// The claim "the origin is inside the full tetrahedron" decides the verdict "intersecting", so
  /// it is checked by signed volumes: on a flat tetrahedron the Δ's are differences of nearly
  /// equal products and can all come out positive when the origin is outside.
  bool encloses_origin() const {
    return used == 0xF && tetrahedron_encloses_origin(y[0], y[1], y[2], y[3]);
  }

  /// |ν(aff Y_s)|², eq. (33), for a subset with Δ(Y_s) > 0.
  S aff_norm2(unsigned s) const {
    const int k = std::countr_zero(s);
    S sum = 0;
    for (int i = 0; i < 4; ++i)
      if (s & (1u << i)) sum += delta[s][i] * dot[i][k];
    return sum / det(s);
  }
};

/// The outcome of the subalgorithm: the subset Y_s (V̂_k), its weights and ν(co Y). Every
/// subalgorithm writes all of it, so a declared `Nearest` is left uninitialised: the loop and
/// signed volumes keep scratch copies, and zeroing each one showed up as stores on every call.
template <class S>
struct Nearest {
  unsigned subset;
  S lambda[4];
  Vec3<S> nu;
  S nu_norm2;
};

template <class S>
void evaluate(const Simplex<S>& simplex, unsigned s, Nearest<S>& out) {
  // Formed in locals and written once: `out` holds doubles like `simplex`, so the compiler had to
  // store into it and reload the simplex after every term (measured: 1–2% of a query with
  // Johnson's method).
  const S total = simplex.det(s);
  S lambda[4] = {0, 0, 0, 0};
  Vec3<S> nu = Vec3<S>::Zero();
  for (int i = 0; i < 4; ++i) {
    if (!(s & (1u << i))) continue;
    lambda[i] = simplex.delta[s][i] / total;  // eq. (31)
    nu += lambda[i] * simplex.y[i];           // eq. (29)
  }
  // A full simplex in R³ that passes the test holds the origin in its interior: ν = 0 exactly
  // (Section V), not the roundoff of Σλy.
  if (subset_size(s) == 4) nu.setZero();
  if (subset_size(s) == 1) nu = simplex.y[std::countr_zero(s)];
  out.subset = s;
  for (int i = 0; i < 4; ++i) out.lambda[i] = lambda[i];
  out.nu = nu;
  out.nu_norm2 = nu.squaredNorm();
}

/// The subsets of V_k in the order they are tried by the Distance Subalgorithm.
struct SubsetOrder {
  int count = 0;
  unsigned char subsets[15] = {};
};

/// Section VI, "ordering subsets": those that contain the newest point (slot `newest`) first, led
/// by the face most likely to hold ν(co V_k) (for a tetrahedron the face without slot `drop`);
/// then the rest, which the previous iteration already ruled out and are only a numerical safety
/// net. Without a newest point (`newest` < 0: an initial simplex, cold or warm) the largest
/// subsets first.
constexpr SubsetOrder make_subset_order(unsigned used, int newest, int drop) {
  SubsetOrder order;
  auto push = [&](unsigned s) {
    for (int i = 0; i < order.count; ++i)
      if (order.subsets[i] == s) return;
    order.subsets[order.count++] = static_cast<unsigned char>(s);
  };
  if (newest < 0) {
    for (int size = std::popcount(used); size >= 1; --size)
      for (unsigned s = 1; s < 16; ++s)
        if (!(s & ~used) && std::popcount(s) == size) push(s);
    return order;
  }
  const unsigned w = 1u << newest;
  const unsigned old = used & ~w;
  if (std::popcount(used) == 4) {
    push(used & ~(1u << drop));
    for (int i = 0; i < 4; ++i)
      if (old & (1u << i)) push(used & ~(1u << i));  // the other faces with w
    push(used);                                      // the tetrahedron: origin enclosed
  } else {
    push(used);  // a new edge or triangle most often holds the nearest point
  }
  for (int size = std::popcount(used) - 1; size >= 2; --size)
    for (unsigned s = 1; s < 16; ++s)
      if ((s & w) && !(s & ~used) && std::popcount(s) == size) push(s);
  push(w);
  for (int size = std::popcount(old); size >= 1; --size)
    for (unsigned s = 1; s < 16; ++s)
      if (!(s & ~old) && std::popcount(s) == size) push(s);
  return order;
}

// Every order the loop can ask for, built at compile time: per occupancy for an initial simplex,
// per occupancy and newest slot after a step, and per newest and dropped slot for a tetrahedron.
// (Built per call, with a duplicate check per entry, the orders were a fifth of a query with
// Johnson's method.)
inline constexpr auto kInitialOrders = [] {
  std::array<SubsetOrder, 16> table{};
  for (unsigned used = 1; used < 16; ++used) table[used] = make_subset_order(used, -1, -1);
  return table;
}();
inline constexpr auto kStepOrders = [] {
  std::array<std::array<SubsetOrder, 4>, 16> table{};
  for (unsigned used = 1; used < 15; ++used)
    for (int newest = 0; newest < 4; ++newest)
      if (used & (1u << newest)) table[used][newest] = make_subset_order(used, newest, -1);
  return table;
}();
inline constexpr auto kTetrahedronOrders = [] {
  std::array<std::array<SubsetOrder, 4>, 4> table{};
  for (int newest = 0; newest < 4; ++newest)
    for (int drop = 0; drop < 4; ++drop)
      if (drop != newest) table[newest][drop] = make_subset_order(15u, newest, drop);
  return table;
}();

/// The order for the current simplex. For a tetrahedron, the paper's rule: Y_1 = V_k \ {y}, y the
/// old vertex maximising y·s_K(−ν_{k−1}) (`newest_point` is s_K(−ν_{k−1})).
template <class S>
const SubsetOrder& subset_order(const Simplex<S>& simplex, const Vec3<S>& newest_point) {
  const unsigned used = simplex.used & 15u;
  // No newest point, or (never formed by the loop) one whose slot is not occupied: no history.
  if (simplex.newest < 0 || !((used >> simplex.newest) & 1u)) return kInitialOrders[used];
  if (used != 15u) return kStepOrders[used][simplex.newest];
  const unsigned old = used & ~(1u << simplex.newest);
  int drop = -1;
  S best = -std::numeric_limits<S>::infinity();
  for (int i = 0; i < 4; ++i) {
    if (!(old & (1u << i))) continue;
    const S value = simplex.y[i].dot(newest_point);
    if (drop < 0 || value > best) {
      best = value;
      drop = i;
    }
  }
  return kTetrahedronOrders[simplex.newest][drop];
}

/// The Distance Subalgorithm: the first subset in `order` that satisfies step 2. False on failure
/// (step 4), which only roundoff can cause.
template <class S>
bool distance_subalgorithm(const Simplex<S>& simplex, const SubsetOrder& order, Nearest<S>& out) {
  for (int i = 0; i < order.count; ++i) {
    if (simplex.is_answer(order.subsets[i])) {
      evaluate(simplex, order.subsets[i], out);
      return true;
    }
  }
  return false;
}

/// The Backup Procedure, eq. (38): among all subsets with Δ_i(Y_s) > 0 for i ∈ I_s, the one whose
/// affine hull comes nearest the origin (|ν(aff Y_s)| by eq. 33). Always succeeds: singletons
/// qualify.
template <class S>
void backup_procedure(Simplex<S>& simplex, Nearest<S>& out) {
  simplex.rebuild_tables();
  unsigned best = 0;
  S best_norm2 = std::numeric_limits<S>::infinity();
  for (unsigned s = 1; s < 16; ++s) {
    if (s & ~simplex.used) continue;
    bool positive = true;
    for (int i = 0; i < 4; ++i)
      if ((s & (1u << i)) && !(simplex.delta[s][i] > 0)) positive = false;
    if (!positive) continue;
    if (subset_size(s) == 4 && !simplex.encloses_origin()) continue;  // see encloses_origin
    S norm2 = subset_size(s) == 1 ? simplex.dot[std::countr_zero(s)][std::countr_zero(s)]
                                  : simplex.aff_norm2(s);
    if (!(norm2 >= 0)) norm2 = 0;  // roundoff (or NaN) in eq. (33): treat as touching the origin
    if (best == 0 || norm2 < best_norm2) {
      best = s;
      best_norm2 = norm2;
    }
  }
  if (best == 0) best = 1u << std::countr_zero(simplex.used);  // unreachable unless y is NaN
  evaluate(simplex, best, out);
}

/// The plane through (p, q, r) with normal n = (q − p) × (r − p), certified: n·p as computed, what
/// rounding may have added to it (`excess`), and whether the normal's orientation survived
/// rounding. n is off by at most 8u·Σ|products| per component (u = ε/2: the differences, the
/// products and their difference), n·p by 4u·|n||p| more; so for a computed numerator
/// N ≤ exact |n·p| (or exact n·p), the exact distance is at least N / (|n| + |Δn|), lowered by
/// 8u for the division's own rounding (`lower`). Shared by d⁻ here and by the depth's faces
/// (penetration.hpp).
template <class S>
struct CertifiedPlane {
  S dot;          // n·p as computed
  S excess;       // a bound on its rounding and on the normal's
  S denominator;  // |n| + |Δn|
  bool oriented;  // |n| > |Δn|: the normal's direction is known
  S lower(S numerator) const {
    constexpr S u = std::numeric_limits<S>::epsilon() / 2;
    return numerator > 0 ? numerator / denominator * (S(1) - S(8) * u) : S(0);
  }
};
template <class S>
CertifiedPlane<S> certify_plane(const Vec3<S>& p, const Vec3<S>& q, const Vec3<S>& r) {
  using std::abs;
  constexpr S u = std::numeric_limits<S>::epsilon() / 2;
  const Vec3<S> a = q - p, b = r - p;
  const Vec3<S> n = a.cross(b);
  const Vec3<S> products(abs(a.y() * b.z()) + abs(a.z() * b.y()),
                         abs(a.z() * b.x()) + abs(a.x() * b.z()),
                         abs(a.x() * b.y()) + abs(a.y() * b.x()));
  const S length = n.norm();
  const S normal_error = S(8) * u * products.norm();
  return {n.dot(p), (S(4) * u * length + normal_error) * p.norm(), length + normal_error,
          length > normal_error};
}

/// d⁻ of eq. (32): for a tetrahedron around the origin, the distance from the origin to the
/// nearest face plane, min |ν(aff Y_s)| over its faces. Computed from the face normals rather than
/// by eq. (33): the same quantity, but without the Δ's loss of precision on flat tetrahedra, where
/// an overstated bound would claim more penetration than there is. 0 for fewer than 4 points.
///
/// Certified for the points as given: each face's computed distance is lowered by what rounding
/// can have added to it. n = (y₂ − p) × (y₃ − p) is off by at most 8u·Σ|products| per component
/// (u = ε/2: the differences, the products and their difference), n·p by 4u·|n||p| more; so the
/// exact distance is at least (|n·p| − (4u|n| + |Δn|)|p|) / (|n| + |Δn|). That costs a few ulps
/// of |p| on a well-shaped tetrahedron; on a sliver, whose normal is mostly rounding (a
/// fuzzer's tetrahedron 1e109 long and 1e95 wide had its d⁻ overstated 3.5×), the face gives 0.
template <class S>
S penetration_lower_bound(const Simplex<S>& simplex, unsigned subset) {
  if (subset_size(subset) != 4) return 0;
  using std::abs;
  S smallest = std::numeric_limits<S>::infinity();
  for (int drop = 0; drop < 4; ++drop) {
    const CertifiedPlane<S> plane = certify_plane(
        simplex.y[(drop + 1) % 4], simplex.y[(drop + 2) % 4], simplex.y[(drop + 3) % 4]);
    if (!plane.oriented) return 0;  // the face's orientation is lost to rounding
    smallest = std::min(smallest, plane.lower(abs(plane.dot) - plane.excess));
  }
  return smallest;
}

}  // namespace nearpoint::detail
