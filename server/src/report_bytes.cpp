// SPDX-License-Identifier: Apache-2.0
#include "report_bytes.hpp"

#include <algorithm>
#include <cmath>

#include "nearpoint/model/vocabulary.hpp"
#include "report_size.hpp"
#include "robot_scene.hpp"

namespace nearpoint::server {
namespace {

/// The most one report of `scene` with `options` can take on the wire in report mode `mode`
/// (see report_size.hpp): every pair (all pairs; changed, whose first report carries every
/// pair; within the cutoff with no cutoff), one per object at most (nearest per object), one
/// (global minimum). A within-cutoff report under a finite cutoff has no bound from the scene:
/// it holds what is near (counted as the envelope here; the transport checks it when sending).
std::size_t report_bytes_bound(const SceneDefinition& scene, const DistanceOptions<double>& options,
                               model::ReportMode mode) {
  // A robot scene's reports add joint gradients per pair and limit violations once.
  const std::size_t extra =
      report_size::pair_options(options.near_points, options.penetration_bound, options.gradient,
                                options.penetration_depth) +
      (scene.robot && options.gradient ? scene.robot->gradient_bytes_per_pair : 0);
  const std::size_t envelope =
      report_size::kReportEnvelope + (scene.robot ? scene.robot->violation_bytes : 0);
  const std::size_t longest_entry =
      report_size::kPairEntryOverhead + report_size::kPairFixed +
      report_size::pair_ids(scene.longest_object_id, scene.longest_object_id) + extra;
  switch (mode) {
    case model::ReportMode::nearest_per_object:
      return envelope + std::min(scene.pairs.size(), scene.objects.size()) * longest_entry;
    case model::ReportMode::global_minimum:
      return envelope + std::min<std::size_t>(scene.pairs.size(), 1) * longest_entry;
    case model::ReportMode::within_cutoff:
      if (std::isfinite(options.distance_cutoff)) return envelope;
      [[fallthrough]];
    default:
      return scene.report_bytes_base + (envelope - report_size::kReportEnvelope) +
             scene.pairs.size() * extra;
  }
}
/// The mode's name in messages: the proto's and the CLI's (unspecified reads as all pairs).
std::string mode_name(model::ReportMode mode) {
  const model::Term<model::ReportMode>* term = model::find_term(mode);
  if (term == nullptr || term->wire == 0) term = model::find_term(model::ReportMode::all_pairs);
  return text(term->name, " (--mode ", term->spelling,
              mode == model::ReportMode::changed ? "; its first report holds every pair)" : ")");
}

/// "near points and gradients", or "" when the options ask for neither of the three extras.
std::string extras(const DistanceOptions<double>& options) {
  std::string out;
  auto add = [&](bool on, const char* what) {
    if (!on) return;
    if (!out.empty()) out += " and ";
    out += what;
  };
  add(options.near_points, "near points");
  add(options.penetration_bound, "penetration bounds");
  add(options.penetration_depth, "penetration depths");
  add(options.gradient, "gradients");
  return out;
}

}  // namespace

std::size_t report_bytes_bound(const SceneDefinition& scene, const ResolvedOptions& options) {
  return report_bytes_bound(scene, options.engine, options.report_mode);
}

std::optional<Error> check_report_bytes(const SceneDefinition& scene,
                                        const ResolvedOptions& options, std::size_t limit,
                                        const std::string& field, std::size_t event_bytes) {
  const std::size_t pairs_bound = report_bytes_bound(scene, options);
  const std::size_t bound = pairs_bound + event_bytes;
  if (bound <= limit) return std::nullopt;
  if (pairs_bound <= limit)
    return resource_exhausted(
        "thresholds",
        text("a report of scene ", quoted(scene.id), " could take up to ", pairs_bound,
             " bytes for its pairs and ", event_bytes,
             " for the thresholds' events (one per watched pair and threshold), more than the ",
             limit,
             " bytes the server sends in one message (--max-message-bytes): watch fewer "
             "pairs, or ask for fewer outputs"));
  const DistanceOptions<double>& engine = options.engine;
  const std::size_t all_bound = report_bytes_bound(scene, engine, model::ReportMode::all_pairs);
  const std::size_t pairs = std::max<std::size_t>(1, scene.pairs.size());
  const std::size_t per_pair =
      std::max<std::size_t>(1, (all_bound - report_size::kReportEnvelope) / pairs);
  const std::size_t fitting =
      limit > report_size::kReportEnvelope ? (limit - report_size::kReportEnvelope) / per_pair : 0;
  // The modes whose reports would fit, with these outputs.
  std::string fit;
  for (const model::ReportMode mode :
       {model::ReportMode::nearest_per_object, model::ReportMode::global_minimum}) {
    const std::size_t mode_bound = report_bytes_bound(scene, engine, mode);
    if (mode_bound <= limit && mode != options.report_mode)
      fit += text(fit.empty() ? "" : ", ", mode_name(mode), " (up to ", mode_bound, " bytes)");
  }
  if (options.report_mode != model::ReportMode::within_cutoff ||
      !std::isfinite(engine.distance_cutoff))
    fit += text(fit.empty() ? "" : ", ", mode_name(model::ReportMode::within_cutoff),
                " with a finite distance_cutoff (as large as the pairs within it)");
  const std::string with = extras(engine);
  const std::string what =
      text("a report of ", field.empty() ? std::string("this scene") : "scene " + quoted(scene.id),
           " in ", mode_name(options.report_mode), with.empty() ? std::string() : " with " + with,
           " could take up to ", bound, " bytes (", scene.pairs.size(), " pairs, object ids up to ",
           scene.longest_object_id, " bytes), more than the ", limit,
           " bytes the server sends in one message (--max-message-bytes); about ", fitting,
           " pairs of this size fit. Report modes that fit: ", fit, ". ");
  if (field.empty())
    return resource_exhausted(field, what +
                                         "Set default_options.report_mode to one of them, or "
                                         "select fewer pairs or use shorter object ids");
  return resource_exhausted(field, what +
                                       "Ask for one of them (options.report_mode) or for "
                                       "fewer outputs, or create a scene with fewer pairs or "
                                       "shorter ids");
}

}  // namespace nearpoint::server
