// SPDX-License-Identifier: Apache-2.0
// The one model <-> nearpoint.v1 conversion (proto/convert): what the client writes, the server
// reads back field for field.
#include <gtest/gtest.h>

#include "nearpoint/proto/convert.hpp"

namespace nearpoint::proto {
namespace {

model::SceneInput sample_scene() {
  model::SceneInput scene;
  scene.name = "cell";
  scene.requested_id = "cell-1";
  model::ObjectInput& a = scene.objects.emplace_back();
  a.id = "a";
  a.geometry_id = "box";
  a.pose.rotation_wxyz = {0, 1, 0, 0};
  a.pose.translation = {1, 2, 3};
  a.group = 2;
  a.padding = 0.01;
  a.body = "arm";
  model::ObjectInput& b = scene.objects.emplace_back();
  b.id = "b";
  b.geometry_id = "box";
  b.mask = 5;
  b.self_padding = 0.02;
  scene.pair_selection.mode = model::PairSelectionInput::Mode::excluded_pairs;
  scene.pair_selection.pairs = {{"a", "b"}};
  scene.default_options.epsilon = 1e-12;
  scene.default_options.penetration = model::PenetrationMode::bound;
  scene.default_options.report_mode = model::ReportMode::nearest_per_object;
  scene.default_options.max_iterations = 64;
  scene.default_options.change_tolerance = 0.5;
  scene.thresholds.push_back({"near", 0.1, 0.01, "a", "", 3});
  return scene;
}

TEST(ProtoConvert, ASceneReadsBackFieldForField) {
  const model::SceneInput scene = sample_scene();
  v1::CreateSceneRequest request;
  to_proto(scene, request);
  const model::SceneInput back = from_proto(request);
  EXPECT_EQ(back.name, scene.name);
  EXPECT_EQ(back.requested_id, scene.requested_id);
  ASSERT_EQ(back.objects.size(), 2u);
  EXPECT_EQ(back.objects[0].pose.rotation_wxyz, scene.objects[0].pose.rotation_wxyz);
  EXPECT_EQ(back.objects[0].pose.translation, scene.objects[0].pose.translation);
  EXPECT_EQ(back.objects[0].group, 2u);
  EXPECT_FALSE(back.objects[0].mask);
  EXPECT_EQ(back.objects[0].padding, 0.01);
  EXPECT_EQ(back.objects[0].body, "arm");
  EXPECT_EQ(back.objects[1].mask, 5u);
  EXPECT_EQ(back.objects[1].self_padding, 0.02);
  EXPECT_EQ(back.pair_selection.mode, model::PairSelectionInput::Mode::excluded_pairs);
  EXPECT_EQ(back.pair_selection.pairs, scene.pair_selection.pairs);
  EXPECT_EQ(back.default_options.epsilon, 1e-12);
  EXPECT_EQ(back.default_options.penetration, model::PenetrationMode::bound);
  EXPECT_EQ(back.default_options.report_mode, model::ReportMode::nearest_per_object);
  EXPECT_EQ(back.default_options.max_iterations, 64u);
  EXPECT_EQ(back.default_options.change_tolerance, 0.5);
  EXPECT_FALSE(back.default_options.near_points);
  ASSERT_EQ(back.thresholds.size(), 1u);
  EXPECT_EQ(back.thresholds[0].name, "near");
  EXPECT_EQ(back.thresholds[0].groups, 3u);
  // Inline geometries are the sender's to add; the fingerprint the receiver's to compute.
  EXPECT_EQ(request.geometries_size(), 0);
  EXPECT_TRUE(back.fingerprint.empty());
}

TEST(ProtoConvert, UnsetEnumsStayUnsetAndIterationsAreCapped) {
  model::QueryOptionsInput options;
  options.max_iterations = std::uint64_t(1) << 40;
  v1::QueryOptions out;
  to_proto(options, out);
  EXPECT_EQ(out.penetration(), v1::PENETRATION_MODE_UNSPECIFIED);
  EXPECT_EQ(out.report_mode(), v1::REPORT_MODE_UNSPECIFIED);
  EXPECT_EQ(out.max_iterations(), 0xFFFFFFFFu);
  out.set_report_mode(v1::ReportMode(42));  // a newer client's value
  EXPECT_EQ(from_proto(out).report_mode, model::ReportMode::unknown);
}

TEST(ProtoConvert, EveryShapeOfAGeometryReadsBack) {
  model::GeometryInput geometry;
  geometry.name = "all";
  for (const auto& shape : std::vector<decltype(model::PieceInput::shape)>{
           model::PolytopeInput{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}, Point{},
           Segment<double>{{0, 0, 0}, {1, 0, 0}}, Box<double>{{1, 2, 3}}, Cylinder<double>{0.5, 1},
           Cone<double>{0.5, 1}, Ellipsoid<double>{{1, 2, 3}}, std::monostate{}}) {
    model::PieceInput& piece = geometry.pieces.emplace_back();
    piece.shape = shape;
    piece.radius = 0.1;
    piece.offset.translation = {0, 0, 1};
  }
  v1::Geometry message;
  to_proto(geometry, message);
  const model::GeometryInput back = from_proto(message);
  ASSERT_EQ(back.pieces.size(), geometry.pieces.size());
  for (std::size_t i = 0; i < back.pieces.size(); ++i) {
    EXPECT_EQ(back.pieces[i].shape.index(), geometry.pieces[i].shape.index()) << i;
    EXPECT_EQ(back.pieces[i].radius, 0.1);
    EXPECT_EQ(back.pieces[i].offset.translation, geometry.pieces[i].offset.translation);
  }
}

}  // namespace
}  // namespace nearpoint::proto
