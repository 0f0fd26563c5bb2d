// SPDX-License-Identifier: Apache-2.0
#include "stiff/stiff_cases.hpp"

#include <cmath>
#include <cstdio>
#include <random>

namespace nearpoint::stiff {
namespace {

using V = Vec3<double>;
using Case = StiffCase<double>;

std::string fmt(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  std::string s(buf);
  for (char& c : s)
    if (c == '-' || c == '+' || c == '.') c = c == '.' ? 'p' : (c == '-' ? 'm' : 'p');
  return s;
}

std::vector<V> box(double hx, double hy, double hz) {
  std::vector<V> v;
  for (int i = 0; i < 8; ++i) v.emplace_back(i & 1 ? hx : -hx, i & 2 ? hy : -hy, i & 4 ? hz : -hz);
  return v;
}

Pose<double> at(const V& t, const Mat3<double>& r = Mat3<double>::Identity()) {
  Pose<double> p;
  p.rotation = r;
  p.translation = t;
  return p;
}

Mat3<double> rot(const V& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

// Points spread evenly on a sphere (Fibonacci lattice), then scaled to an ellipsoid.
std::vector<V> sphere_sampling(int n, const V& radii) {
  std::vector<V> v;
  const double golden = std::acos(-1.0) * (3 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1 - 2 * (i + 0.5) / n, r = std::sqrt(1 - z * z), t = golden * i;
    v.emplace_back(radii.x() * r * std::cos(t), radii.y() * r * std::sin(t), radii.z() * z);
  }
  return v;
}

Case make(std::string family, std::string name, std::vector<V> a, Pose<double> pa, std::vector<V> b,
          Pose<double> pb, double size, double ra = 0, double rb = 0) {
  Case c;
  c.family = family;
  c.name = family + "/" + name;
  c.a = std::move(a);
  c.b = std::move(b);
  c.pose_a = pa;
  c.pose_b = pb;
  c.size = size;
  c.radius_a = ra;
  c.radius_b = rb;
  return c;
}

void far_cases(std::vector<Case>& out) {
  // The same pairs moved far from the world origin together: the relative frame and eq. (34)
  // must keep the error at the shapes' scale, whatever the offset.
  const V direction = V(0.48, -0.6, 0.64);
  const Mat3<double> tilt = rot(V(1, 2, 3), 0.4);
  for (double offset : {0.0, 1e3, 1e6, 1e9}) {
    const V o = offset * direction;
    out.push_back(make("far", "boxes_gap_0p5_offset_" + fmt(offset), box(1, 1, 1), at(o),
                       box(1, 1, 1), at(o + V(2.5, 0.3, 0.2)), 1.0));
    out.push_back(make("far", "tilted_boxes_offset_" + fmt(offset), box(1, 0.5, 0.25), at(o, tilt),
                       box(0.5, 0.5, 1), at(o + V(1.1, 1.3, 0.9), rot(V(0, 1, 1), 1.0)), 1.0));
    out.push_back(make("far", "touching_faces_offset_" + fmt(offset), box(1, 1, 1), at(o),
                       box(1, 1, 1), at(o + V(0, 0, 2)), 1.0));
  }
}

void scale_cases(std::vector<Case>& out) {
  const Mat3<double> tilt = rot(V(1, 1, 0), 0.3);
  for (double s : {1e-6, 1e-3, 1e3, 1e6}) {
    out.push_back(make("scale", "boxes_size_" + fmt(s), box(s, s, s), at(V::Zero()),
                       box(s, 2 * s, 0.5 * s), at(V(2.7 * s, 0.4 * s, 0.1 * s), tilt), s));
    out.push_back(make("scale", "touching_size_" + fmt(s), box(s, s, s), at(V::Zero()),
                       box(s, s, s), at(V(2 * s, 0.5 * s, 0)), s));
  }
  // A 1e-4 object beside a 1e4 object: gaps at the small object's scale.
  for (double gap : {1e-4, 1e-8, 0.0}) {
    out.push_back(make("scale", "small_beside_big_gap_" + fmt(gap), box(1e4, 1e4, 1e4),
                       at(V::Zero()), box(1e-4, 1e-4, 1e-4), at(V(1e4 + 1e-4 + gap, 17.0, -3.0)),
                       1e4));
  }
}

void thin_cases(std::vector<Case>& out) {
  // Needles: aspect 1e6.
  const std::vector<V> needle = box(1, 1e-6, 1e-6);
  out.push_back(make("thin", "needle_vs_point", needle, at(V::Zero()), {V::Zero()},
                     at(V(0.3, 0.5, 0.2)), 1.0));
  out.push_back(make("thin", "needles_crossing_gap_1em3", needle, at(V::Zero()), needle,
                     at(V(0.2, -0.1, 1e-3 + 2e-6), rot(V(0, 0, 1), 1.2)), 1.0));
  out.push_back(make("thin", "needles_parallel_gap_1em6", needle, at(V::Zero()), needle,
                     at(V(0.5, 3e-6, 0)), 1.0));
  // Zero-thickness plates (coplanar vertex sets).
  const std::vector<V> plate = {V(-1, -1, 0), V(1, -1, 0), V(1, 1, 0), V(-1, 1, 0), V(0.2, 0.3, 0)};
  for (double h : {1.0, 1e-3, 1e-9, 0.0})
    out.push_back(make("thin", "plate_vs_point_height_" + fmt(h), plate, at(V::Zero()), {V::Zero()},
                       at(V(0.3, -0.2, h)), 1.0));
  out.push_back(make("thin", "plates_parallel_gap_1em9", plate, at(V::Zero()), plate,
                     at(V(0.5, 0.5, 1e-9)), 1.0));
  out.push_back(make("thin", "plates_crossing", plate, at(V::Zero()), plate,
                     at(V(0.1, 0.2, 0.3), rot(V(1, 0, 0), 1.5707963267948966)), 1.0));
  // Collinear vertex sets, a single point, duplicate and massively repeated vertices.
  std::vector<V> line;
  for (int i = 0; i < 10; ++i) line.emplace_back(-1 + 0.2 * i, 0.5 * (-1 + 0.2 * i), 0);
  out.push_back(make("thin", "collinear_vs_point", line, at(V::Zero()), {V::Zero()},
                     at(V(0.3, -0.4, 0.2)), 1.0));
  out.push_back(make("thin", "collinear_vs_collinear", line, at(V::Zero()), line,
                     at(V(0.1, 0.2, 0.5), rot(V(0, 0, 1), 0.9)), 1.0));
  out.push_back(make("thin", "point_vs_point", {V(0.1, 0.2, 0.3)}, at(V::Zero()), {V(-0.1, 0, 0.3)},
                     at(V(1, 1, 1)), 1.0));
  out.push_back(make("thin", "point_vs_same_point", {V(0.1, 0.2, 0.3)}, at(V::Zero()),
                     {V(0.1, 0.2, 0.3)}, at(V::Zero()), 1.0));
  std::vector<V> dup3, dup2000;
  for (int k = 0; k < 3; ++k)
    for (const V& v : box(1, 1, 1)) dup3.push_back(v);
  for (int k = 0; k < 2000; ++k)
    for (const V& v : box(1, 0.5, 0.25)) dup2000.push_back(v);
  out.push_back(make("thin", "duplicate_vertices_x3", dup3, at(V::Zero()), dup3,
                     at(V(2.2, 0.5, -0.3), rot(V(1, 1, 1), 0.5)), 1.0));
  out.push_back(make("thin", "repeated_vertices_x2000", dup2000, at(V::Zero()), box(1, 1, 1),
                     at(V(0.4, 1.8, 0.2), rot(V(0, 1, 0), 0.3)), 1.0));
}

void contact_cases(std::vector<Case>& out) {
  // Wedges with one horizontal edge each, exactly representable: edge–edge contact at right
  // angles with a gap g, vertex–face, edge–face and face–face.
  const std::vector<V> up_edge = {V(-1, 0, 1),  V(1, 0, 1),   V(-1, -1, -1),
                                  V(1, -1, -1), V(-1, 1, -1), V(1, 1, -1)};  // ridge on top along x
  const std::vector<V> down_edge = {V(0, -1, -1), V(0, 1, -1), V(-1, -1, 1), V(-1, 1, 1),
                                    V(1, -1, 1),  V(1, 1, 1)};  // ridge at the bottom along y
  const std::vector<V> down_vertex = {V(0, 0, -1), V(-1, -1, 1), V(1, -1, 1), V(0, 1.5, 1)};
  for (double g : {0.0, 1e-6, 1e-9, 1e-12, 1e-15}) {
    out.push_back(make("contact", "edge_edge_gap_" + fmt(g), up_edge, at(V::Zero()), down_edge,
                       at(V(0.25, 0.125, 2 + g)), 1.0));
    out.push_back(make("contact", "vertex_face_gap_" + fmt(g), box(1, 1, 1), at(V::Zero()),
                       down_vertex, at(V(0.25, -0.375, 2 + g)), 1.0));
    out.push_back(make("contact", "edge_face_gap_" + fmt(g), box(1, 1, 1), at(V::Zero()), down_edge,
                       at(V(0.5, 0.25, 2 + g)), 1.0));
    out.push_back(make("contact", "face_face_gap_" + fmt(g), box(1, 1, 1), at(V::Zero()),
                       box(0.5, 0.5, 0.5), at(V(0.25, 0.375, 1.5 + g)), 1.0));
  }
  // Tilted boxes kissing at an angle: B's lowest corner placed at height 1 + g above A's top.
  for (double angle : {1e-6, 1e-3, 0.3, 0.7}) {
    for (double g : {0.0, 1e-9}) {
      const Mat3<double> r = rot(V(1, 0.5, 0), angle);
      double lowest = 1e300;
      for (const V& v : box(0.5, 0.5, 0.5)) lowest = std::min(lowest, (r * v).z());
      out.push_back(make("contact", "tilted_kiss_angle_" + fmt(angle) + "_gap_" + fmt(g),
                         box(1, 1, 1), at(V::Zero()), box(0.5, 0.5, 0.5),
                         at(V(0.1, -0.2, 1 + g - lowest), r), 1.0));
    }
  }
  const Mat3<double> r = rot(V(3, -1, 2), 0.8);
  out.push_back(make("contact", "identical_shapes", box(1, 0.5, 0.3), at(V(1, 2, 3), r),
                     box(1, 0.5, 0.3), at(V(1, 2, 3), r), 1.0));
  out.back().deep_overlap = true;
  out.push_back(make("contact", "inside_other", box(2, 2, 2), at(V::Zero()), box(0.1, 0.2, 0.3),
                     at(V(0.5, -0.3, 0.2), r), 2.0));
  out.back().deep_overlap = true;
  out.push_back(make("contact", "parallel_faces_offset", box(1, 1, 1), at(V::Zero()), box(1, 1, 1),
                     at(V(0.7, -0.4, 2.001)), 1.0));
  out.push_back(make("contact", "deep_overlap", box(1, 1, 1), at(V::Zero()), box(1, 1, 1),
                     at(V(0.5, 0.4, 0.3), r), 1.0));
  out.back().deep_overlap = true;
}

void degenerate_cases(std::vector<Case>& out) {
  // The paper's pathological family (Section VII): K1 a point, K2's vertices clustered ever closer
  // to its near point, so GJK creeps along them. Vertices on a circle of radius R around
  // (0, R + d, 0), at angles ±θ0·q^i: the near point is on the chord of the two smallest angles.
  for (int m : {10, 100, 1000}) {
    std::vector<V> cluster;
    const double radius = 1, gap = 0.5, q = std::pow(1e-6, 1.0 / m);
    for (int i = 0; i < m; ++i) {
      const double t = 1.0 * std::pow(q, i);
      for (double sign : {-1.0, 1.0})
        cluster.emplace_back(radius * std::sin(sign * t), radius + gap - radius * std::cos(t), 0);
    }
    out.push_back(make("degenerate", "clustered_vertices_m_" + std::to_string(m), {V::Zero()},
                       at(V::Zero()), cluster, at(V::Zero()), 1.0));
  }
  // Nearly affinely dependent simplices: very flat tetrahedra and slivers.
  for (double h : {1e-6, 1e-12}) {
    const std::vector<V> flat = {V(-1, -1, 0), V(1, -1, 0), V(0, 1, 0), V(0.1, 0.1, h)};
    out.push_back(make("degenerate", "flat_tetrahedron_h_" + fmt(h) + "_vs_box", flat,
                       at(V::Zero()), box(0.5, 0.5, 0.5), at(V(0.2, 0.1, 0.5 + 0.3)), 1.0));
    const std::vector<V> sliver = {V(-1, 0, 0), V(1, 0, 0), V(0, h, 0), V(0, 0, h)};
    out.push_back(make("degenerate", "sliver_h_" + fmt(h) + "_vs_point", sliver, at(V::Zero()),
                       {V::Zero()}, at(V(0.3, 0.4, 0.5)), 1.0));
  }
}

void large_cases(std::vector<Case>& out) {
  for (int n : {10000, 100000}) {
    const std::vector<V> sphere = sphere_sampling(n, V(1, 1, 1));
    out.push_back(make("large", "sphere_" + std::to_string(n) + "_vs_point", sphere, at(V::Zero()),
                       {V::Zero()}, at(V(1.2, 1.5, -0.7)), 1.0));
    out.push_back(make("large", "sphere_" + std::to_string(n) + "_vs_box", sphere, at(V::Zero()),
                       box(0.5, 0.5, 0.5), at(V(0.9, 1.1, 0.4), rot(V(1, 1, 0), 0.6)), 1.0));
  }
  const std::vector<V> ellipsoid = sphere_sampling(10000, V(1, 2, 0.5));
  out.push_back(make("large", "ellipsoid_10000_vs_sphere_10000", ellipsoid, at(V::Zero()),
                     sphere_sampling(10000, V(1, 1, 1)), at(V(1.5, 2.2, 0.8), rot(V(0, 1, 1), 0.4)),
                     2.0));
  out.push_back(make("large", "ellipsoids_10000_touching_close", ellipsoid, at(V::Zero()),
                     ellipsoid, at(V(0, 0, 1.0 + 1e-7)), 2.0));
}

void rounded_cases(std::vector<Case>& out) {
  out.push_back(make("rounded", "radius_100_on_small_box", box(0.1, 0.1, 0.1), at(V::Zero()),
                     {V::Zero()}, at(V(150, 20, -10)), 100.0, 0.0, 100.0));
  out.push_back(make("rounded", "radii_larger_than_separation", box(1, 1, 1), at(V::Zero()),
                     {V::Zero()}, at(V(2, 0.1, 0.2)), 2.0, 0.5, 1.5));
  out.back().deep_overlap = true;
  for (double angle : {1e-8, 1e-4, 0.0}) {
    const std::vector<V> segment = {V(-1, 0, 0), V(1, 0, 0)};
    out.push_back(make("rounded", "capsules_nearly_parallel_" + fmt(angle), segment, at(V::Zero()),
                       segment, at(V(0.3, 0.5, 0.1), rot(V(0, 0, 1), angle)), 1.0, 0.1, 0.2));
  }
}

}  // namespace

std::vector<StiffCase<double>> make_stiff_cases() {
  std::vector<Case> out;
  far_cases(out);
  scale_cases(out);
  thin_cases(out);
  contact_cases(out);
  degenerate_cases(out);
  large_cases(out);
  rounded_cases(out);
  return out;
}

std::vector<StiffCase<float>> to_float(const std::vector<StiffCase<double>>& cases) {
  std::vector<StiffCase<float>> out;
  for (const Case& c : cases) {
    StiffCase<float> f;
    f.family = c.family;
    f.name = c.name;
    for (const V& v : c.a) f.a.push_back(v.cast<float>());
    for (const V& v : c.b) f.b.push_back(v.cast<float>());
    f.radius_a = float(c.radius_a);
    f.radius_b = float(c.radius_b);
    f.pose_a.rotation = c.pose_a.rotation.cast<float>();
    f.pose_a.translation = c.pose_a.translation.cast<float>();
    f.pose_b.rotation = c.pose_b.rotation.cast<float>();
    f.pose_b.translation = c.pose_b.translation.cast<float>();
    f.size = c.size;
    f.deep_overlap = c.deep_overlap;
    out.push_back(std::move(f));
  }
  return out;
}

}  // namespace nearpoint::stiff
