// SPDX-License-Identifier: Apache-2.0
// (7) Penetration depth against the exact depth, peers side by side (issue 31, "Measure").
//
// Inputs, all polytopes given by vertex lists (every peer takes them):
//   paper_intersecting, paper_touching: the Section VII examples of those two cases
//     (tests/common/paper_family.hpp; touching pairs have exact depths of 0 to a few 1e-16);
//   stiff: face–face, edge–edge and vertex–face box contacts at depths 1e-12 … 1 × the size,
//     identical shapes (K = P − P) and a box nested in a box, at sizes 1e-6, 1, 1e6, at the
//     origin and 1e6 × the size away from it (stiff_far), each under two random rotations.
// The truth is the exact depth of the very double input (ExactDepth: CGAL's exact hull of all
// vertex differences). Errors are |depth − exact| / D, D = D(K) of eq. (37) as nearpoint reports
// it (a function of the input only: the same D for every implementation).
//
// Implementations and their knobs (several settings each, the error-against-time curve):
//   nearpoint (signed volumes, penetration_depth): depth_tolerance 1e-3, 1e-6, 1e-9 and the
//     default; its certified interval is checked against the exact depth (violations: 0 allowed);
//   coal_epa: gjk_tolerance = epa_tolerance 1e-3 … 1e-12 (1e-6 is coal's default);
//   fcl_libccd_epa: fcl::distance with signed distance, distance_tolerance 1e-3 … 1e-12;
//   fcl_libccd_mpr: fcl::collide with contacts (MPR), gjk_tolerance 1e-6 (default) and 1e-12;
//   libccd_epa: ccdGJKPenetration, epa_tolerance 1e-4 (default) … 1e-12;
//   bullet_gjkepa2: btGjkEpaSolver2::Penetration (double), no knob.
// Timing as in experiment (3): per query, blocks (set, group) shuffled each round, settings
// interleaved block by block, a first untimed round records the answers.
//
// Output: depth.csv (per setting and set), depth_cases.csv (per stiff case and setting),
// depth_violations.csv (every nearpoint interval — depth or signed distance — that misses the
// exact value, with the input in hex floats so the case can be replayed), depth_meta.csv.
#include <algorithm>
#include <map>
#include <numbers>
#include <numeric>
#include <random>
#include <thread>

#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include "common/exact_distance.hpp"
#include "common/paper_family.hpp"
#include "common/random_hull.hpp"
#include "exact_depth.hpp"
#include "experiments.hpp"
#include "runners.hpp"

namespace nearpoint::bench {
namespace {

using VertexList = std::shared_ptr<const std::vector<Vec3<double>>>;

struct DepthCase {
  std::string set;               ///< paper_intersecting | paper_touching | stiff | stiff_far
  std::string group;             ///< the paper pair "(1,2)", or the stiff kind "face_face" …
  double size = 1;               ///< stiff: the shapes' size; paper: 1
  double relative_depth = kNaN;  ///< stiff contacts: the intended depth / size
  PairInput input;
  ExactDepth exact;
  /// The exact distance, correctly rounded (0 when the hulls meet): the paper family's own, or
  /// CGAL's (common/exact_distance.hpp) for a stiff case that the rounding of its pose separated.
  double exact_distance = kNaN;
};

struct Setting {
  std::string impl;
  std::string knob;
  double value = kNaN;
  bool nearpoint = false;
  std::unique_ptr<Runner> runner;
  std::string declined;
};

VertexList box_vertices(const Vec3<double>& h) {
  auto v = std::make_shared<std::vector<Vec3<double>>>();
  for (int k = 0; k < 8; ++k)
    v->emplace_back((k & 1) ? h.x() : -h.x(), (k & 2) ? h.y() : -h.y(), (k & 4) ? h.z() : -h.z());
  return v;
}

VertexList rotated(const VertexList& v, const Mat3<double>& r) {
  auto out = std::make_shared<std::vector<Vec3<double>>>();
  for (const Vec3<double>& p : *v) out->push_back(r * p);
  return out;
}

Mat3<double> axis_rotation(int axis, double angle) {
  return Eigen::AngleAxis<double>(angle, Vec3<double>::Unit(axis)).toRotationMatrix();
}

std::string hex(double x) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%a", x);
  return buffer;
}

std::string hex_vertices(const std::vector<Vec3<double>>& v) {
  std::string s;
  for (const Vec3<double>& p : v) {
    if (!s.empty()) s += ';';
    s += hex(p.x()) + ' ' + hex(p.y()) + ' ' + hex(p.z());
  }
  return s;
}

std::string hex_pose(const Pose<double>& p) {
  std::string s;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += hex(p.rotation(i, j)) + ' ';
  return s + "| " + hex(p.translation.x()) + ' ' + hex(p.translation.y()) + ' ' +
         hex(p.translation.z());
}

/// The stiff sweep: contacts of known kind at controlled depths, sizes and offsets.
std::vector<DepthCase> stiff_cases(bool quick) {
  std::vector<DepthCase> cases;
  std::mt19937_64 rng(31031);
  const std::vector<double> relative = {1e-12, 1e-9, 1e-6, 1e-3, 0.1, 0.5};
  const int rotations = quick ? 1 : 2;
  // The cube rotated so that its vertex (−1,−1,−1) points along −x (the vertex–face contact).
  const Vec3<double> corner = Vec3<double>(-1, -1, -1).normalized();
  const Mat3<double> vertex_down =
      Eigen::Quaternion<double>::FromTwoVectors(corner, Vec3<double>(-1, 0, 0)).toRotationMatrix();
  for (const double size : {1e-6, 1.0, 1e6})
    for (const bool far : {false, true})
      for (int rot = 0; rot < rotations; ++rot) {
        const Mat3<double> r = testkit::random_rotation(rng);
        const Vec3<double> base =
            far ? Vec3<double>(1e6 * size, -1e6 * size, 1e6 * size) : Vec3<double>::Zero();
        const std::string set = far ? "stiff_far" : "stiff";
        auto add = [&](const char* group, double rel, const VertexList& a, const VertexList& b,
                       const Vec3<double>& offset_b) {
          PairInput in;
          in.a = a;
          in.b = b;
          in.pose_a.rotation = r;
          in.pose_a.translation = base;
          in.pose_b.rotation = r;
          in.pose_b.translation = base + r * offset_b;
          DepthCase c{set, group, size, rel, in, ExactDepth(*a, in.pose_a, *b, in.pose_b), 0.0};
          if (!c.exact.intersecting()) {
            const testkit::ExactDistance x = testkit::exact_distance(*a, in.pose_a, *b, in.pose_b);
            c.exact_distance = x.intersecting ? 0.0 : x.distance;
          }
          cases.push_back(std::move(c));
        };
        const VertexList box_a = box_vertices(Vec3<double>(1, 2, 3) * size);
        const VertexList box_b = box_vertices(Vec3<double>(1.5, 2.5, 3.5) * size);
        const VertexList cube = box_vertices(Vec3<double>(1, 1, 1) * size);
        // A's edge along z at x = √2·size, B's edge along y at x = −√2·size (local): crossing.
        const VertexList edge_a = rotated(cube, axis_rotation(2, std::numbers::pi / 4));
        const VertexList edge_b = rotated(cube, axis_rotation(1, std::numbers::pi / 4));
        const VertexList vertex_b = rotated(cube, vertex_down);
        for (const double rel : relative) {
          const double depth = rel * size;
          add("face_face", rel, box_a, box_b,
              Vec3<double>(2.5 * size - depth, 0.3 * size, -0.2 * size));
          add("edge_edge", rel, edge_a, edge_b,
              Vec3<double>(2 * std::sqrt(2.0) * size - depth, 0.1 * size, -0.15 * size));
          add("vertex_face", rel, box_a, vertex_b,
              Vec3<double>((1 + std::sqrt(3.0)) * size - depth, 0.2 * size, -0.3 * size));
        }
        const VertexList hull = std::make_shared<std::vector<Vec3<double>>>(
            testkit::random_hull_vertices(rng(), 12, size));
        add("identical", kNaN, hull, hull, Vec3<double>::Zero());
        add("nested", kNaN, box_vertices(Vec3<double>(2, 3, 4) * size),
            box_vertices(Vec3<double>(0.5, 0.5, 0.5) * size), Vec3<double>(1.2, 0.5, -0.25) * size);
      }
  return cases;
}

std::vector<double> knob_values(const std::string& impl) {
  if (impl == "nearpoint") return {1e-3, 1e-6, 1e-9, kDefaultDepthTolerance<double>};
  if (impl == "fcl_libccd_mpr") return {1e-6, 1e-12};
  if (impl == "libccd_epa") return {1e-4, 1e-6, 1e-9, 1e-12};
  if (impl == "bullet_gjkepa2") return {kNaN};
  return {1e-3, 1e-6, 1e-9, 1e-12};
}

/// Queries that do not return: libccd's EPA has no iteration cap and, at tight tolerances, can
/// loop for ever on some inputs. Before anything is timed, every setting answers every case once
/// in a child process (fork: the prepared runner is copied); a case on which the child makes no
/// progress for `limit` is recorded as hung and the child restarts after it. The hung cases are
/// then skipped in the timed rounds (HungSkipping) and counted in the results.
/// A child that dies instead (a peer's failed assertion: abort) marks the case as crashed.
/// Returns per case 0 (answered), kHung or kCrashed.
constexpr char kHung = 1, kCrashed = 2;
std::vector<char> screen_for_hangs(Runner& runner, std::size_t n, std::chrono::milliseconds limit) {
  std::vector<char> hung(n, 0);
  auto* shared = static_cast<volatile long*>(
      mmap(nullptr, sizeof(long), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0));
  if (shared == MAP_FAILED) return hung;
  std::size_t start = 0;
  while (start < n) {
    *shared = long(start);
    std::fflush(nullptr);
    const pid_t child = fork();
    if (child == 0) {
      // The peers' diagnostics before an abort (FCL prints the configuration) are not results.
      if (std::FILE* null = std::freopen("/dev/null", "w", stderr)) (void)null;
      Outcome out;
      for (std::size_t i = start; i < n; ++i) {
        *shared = long(i);
        runner.run(i, out);
      }
      *shared = long(n);
      _exit(0);
    }
    if (child < 0) break;
    long last = *shared;
    auto since = Clock::now();
    int status = 0;
    bool done = false;
    while (!done) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (waitpid(child, &status, WNOHANG) == child) {
        done = true;
        break;
      }
      const long now = *shared;
      if (now != last) {
        last = now;
        since = Clock::now();
      } else if (Clock::now() - since > limit) {
        kill(child, SIGKILL);
        waitpid(child, &status, 0);
        break;
      }
    }
    if (done && WIFEXITED(status) && WEXITSTATUS(status) == 0) break;
    // Hung or crashed at case `*shared` (re-read: it may have advanced since the last poll).
    last = *shared;
    if (last >= 0 && std::size_t(last) < n) hung[std::size_t(last)] = done ? kCrashed : kHung;
    start = std::size_t(last) + 1;
  }
  munmap(const_cast<long*>(shared), sizeof(long));
  return hung;
}

/// A runner that does not call its inner runner on the cases screened as hung (NaN answer).
class HungSkipping final : public Runner {
 public:
  HungSkipping(std::unique_ptr<Runner> inner, std::vector<char> hung)
      : inner_(std::move(inner)), hung_(std::move(hung)) {}
  void run(std::size_t i, Outcome& out) override {
    if (hung_[i]) {
      out = Outcome{};
      return;
    }
    inner_->run(i, out);
  }
  void reset() override { inner_->reset(); }

 private:
  std::unique_ptr<Runner> inner_;
  std::vector<char> hung_;
};

}  // namespace

int run_depth(const Args& args) {
  const int rounds = args.rounds > 0 ? args.rounds : (args.quick ? 2 : 5);
  testkit::PaperExperimentConfig config;
  config.poses_per_case = args.quick ? 10 : 100;
  progress("depth: generating %d paper examples", config.poses_per_case * 60);
  const std::vector<testkit::PaperExample> examples = testkit::paper_experiment(config);

  std::vector<DepthCase> cases;
  const auto oracle_start = Clock::now();
  for (const testkit::PaperExample& e : examples) {
    if (e.kind == testkit::PaperCase::separated) continue;
    char pair[32];
    std::snprintf(pair, sizeof pair, "(%d,%d)", e.polytope_a, e.polytope_b);
    DepthCase c{
        e.kind == testkit::PaperCase::intersecting ? "paper_intersecting" : "paper_touching",
        pair,
        1.0,
        kNaN,
        {e.vertices_a, e.vertices_b, e.pose_a, e.pose_b, 0, 0},
        ExactDepth(*e.vertices_a, e.pose_a, *e.vertices_b, e.pose_b)};
    cases.push_back(std::move(c));
    if (cases.size() % 500 == 0) progress("depth: exact depth of %zu paper examples", cases.size());
  }
  for (DepthCase& c : stiff_cases(args.quick)) cases.push_back(std::move(c));
  const double oracle_seconds = std::chrono::duration<double>(Clock::now() - oracle_start).count();
  const std::size_t n = cases.size();
  progress("depth: %zu cases, exact depths in %.1f s", n, oracle_seconds);
  std::vector<PairInput> inputs;
  for (const DepthCase& c : cases) inputs.push_back(c.input);

  std::vector<Setting> settings;
  for (const double tol : knob_values("nearpoint")) {
    DistanceOptions<double> options;
    options.penetration_depth = true;
    options.depth_tolerance = tol;
    settings.push_back({"nearpoint", "depth_tolerance", tol, true,
                        make_nearpoint_runner(inputs, options, false), ""});
  }
  const std::pair<DepthPeer, const char*> peers[] = {
      {DepthPeer::coal, "gjk_tolerance=epa_tolerance"},
      {DepthPeer::fcl_epa, "distance_tolerance"},
      {DepthPeer::fcl_mpr, "gjk_tolerance"},
      {DepthPeer::libccd_epa, "epa_tolerance"},
      {DepthPeer::bullet, "none"}};
  for (const auto& [peer, knob] : peers) {
    for (const double tol : knob_values(to_string(peer))) {
      Setting s{to_string(peer), knob, tol, false, nullptr, ""};
      s.runner = make_depth_peer_runner(peer, inputs, PeerSettings{tol}, &s.declined);
      settings.push_back(std::move(s));
    }
  }
  const std::size_t m = settings.size();
  const std::size_t reference = 3;
  std::vector<std::vector<char>> hung(m, std::vector<char>(n, 0));
  for (std::size_t k = 0; k < m; ++k) {
    Setting& s = settings[k];
    if (!s.runner) continue;
    hung[k] = screen_for_hangs(*s.runner, n, std::chrono::milliseconds(500));
    const long hangs = std::count(hung[k].begin(), hung[k].end(), kHung);
    const long crashes = std::count(hung[k].begin(), hung[k].end(), kCrashed);
    if (hangs + crashes > 0) {
      progress(
          "depth: %s at %g did not return (> 0.5 s) on %ld cases and aborted on %ld: "
          "those are skipped and counted",
          s.impl.c_str(), s.value, hangs, crashes);
      s.runner = std::make_unique<HungSkipping>(std::move(s.runner), hung[k]);
    }
  }

  std::map<std::pair<std::string, std::string>, std::vector<std::uint32_t>> block_map;
  for (std::size_t i = 0; i < n; ++i)
    block_map[{cases[i].set, cases[i].group}].push_back(std::uint32_t(i));
  std::vector<std::vector<std::uint32_t>> blocks;
  for (auto& [key, indices] : block_map) blocks.push_back(std::move(indices));

  std::vector<std::vector<std::vector<float>>> ns(
      m, std::vector<std::vector<float>>(std::size_t(rounds), std::vector<float>(n)));
  std::vector<std::vector<Outcome>> outcomes(m, std::vector<Outcome>(n));
  std::vector<float> scratch(n);
  std::mt19937_64 rng(20261203);
  for (int round = -1; round < rounds; ++round) {
    std::vector<std::size_t> order(blocks.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    for (std::size_t pos = 0; pos < order.size(); ++pos) {
      for (std::size_t k = 0; k < m; ++k) {
        const std::size_t which = (pos * 7 + std::size_t(round + 1) * 13 + k) % m;
        Setting& s = settings[which];
        if (!s.runner) continue;
        if (round < 0)
          time_queries(*s.runner, blocks[order[pos]], scratch, outcomes[which]);
        else
          time_queries(*s.runner, blocks[order[pos]], ns[which][std::size_t(round)]);
      }
    }
    progress("depth: round %d/%d done", round + 1, rounds);
  }

  // D(K) per case, from nearpoint's answer at the default tolerance.
  std::vector<double> diameter(n);
  for (std::size_t i = 0; i < n; ++i) diameter[i] = outcomes[reference][i].diameter_bound;

  Csv table(output_path(args, "depth.csv"), {"impl",
                                             "knob",
                                             "value",
                                             "set",
                                             "cases",
                                             "median_ns",
                                             "p99_ns",
                                             "max_rel_error",
                                             "median_rel_error",
                                             "p90_rel_error",
                                             "missed",
                                             "nans",
                                             "threw",
                                             "violations",
                                             "no_interval",
                                             "max_rel_width",
                                             "median_rel_width",
                                             "wider_than_1e-12",
                                             "signed_violations",
                                             "max_rel_signed_width",
                                             "median_rel_signed_width",
                                             "capped",
                                             "degenerate",
                                             "hung",
                                             "aborted",
                                             "declined"});
  Csv per_case(output_path(args, "depth_cases.csv"),
               {"impl", "knob", "value", "set", "group", "size", "relative_depth", "exact_depth",
                "diameter", "depth", "rel_error", "rel_width", "violation", "median_ns"});
  Csv violations_csv(output_path(args, "depth_violations.csv"),
                     {"knob_value", "set", "group", "exact_depth", "lower", "upper", "what",
                      "vertices_a", "pose_a", "vertices_b", "pose_b"});
  const std::vector<std::string> sets = {"paper_intersecting", "paper_touching", "stiff",
                                         "stiff_far"};
  long total_violations = 0;
  for (std::size_t k = 0; k < m; ++k) {
    const Setting& s = settings[k];
    for (const std::string& set : sets) {
      std::vector<std::size_t> members;
      for (std::size_t i = 0; i < n; ++i)
        if (cases[i].set == set) members.push_back(i);
      if (!s.runner) {
        table << s.impl << s.knob << s.value << set << members.size() << kNaN << kNaN << kNaN
              << kNaN << kNaN << 0 << 0 << 0 << 0 << 0 << kNaN << kNaN << 0 << 0 << kNaN << kNaN
              << 0 << 0 << 0 << 0 << s.declined;
        table.end_row();
        continue;
      }
      std::vector<float> times;
      std::vector<double> errors, widths, signed_widths;
      int signed_violations = 0;
      int missed = 0, nans = 0, violations = 0, no_interval = 0, wide = 0, capped = 0,
          degenerate = 0, hung_cases = 0, aborted = 0, threw = 0;
      for (const std::size_t i : members) {
        const DepthCase& c = cases[i];
        const Outcome& o = outcomes[k][i];
        if (hung[k][i]) {
          ++(hung[k][i] == kHung ? hung_cases : aborted);
          continue;
        }
        std::vector<float> mine;
        for (int r = 0; r < rounds; ++r) {
          times.push_back(ns[k][std::size_t(r)][i]);
          mine.push_back(ns[k][std::size_t(r)][i]);
        }
        const double d = diameter[i];
        double rel_error = kNaN, rel_width = kNaN;
        bool violation = false;
        if (o.exit == Exit::invalid_input && !s.nearpoint) {
          ++threw;  // FCL's EPA threw: no answer (not a NaN it returned)
        } else if (std::isnan(o.depth)) {
          ++nans;
        } else {
          rel_error = c.exact.error(o.depth) / d;
          errors.push_back(rel_error);
          // A depth of 0 (or no penetration reported) on a pair whose exact depth exceeds the
          // setting's own tolerance: the peer missed the overlap.
          const double allowance = std::isnan(s.value) ? 1e-12 : s.value;
          if (c.exact.intersecting() && !(o.depth > 0) && c.exact.depth() > allowance * d) ++missed;
        }
        if (s.nearpoint) {
          // Coal's and libccd's codes are statuses; nearpoint's code_a is its DepthTermination.
          if (o.code_a == int(DepthTermination::iteration_limit)) ++capped;
          if (o.code_a == int(DepthTermination::degenerate)) ++degenerate;
          // The signed distance's interval: its width, and whether it holds the exact φ (the
          // exact distance, correctly rounded, when separated — a double outside [l, u] proves φ
          // outside, the ends being doubles —; −depth, decided exactly, when intersecting).
          if (!std::isnan(o.signed_lower) && !std::isnan(o.signed_upper)) {
            signed_widths.push_back((o.signed_upper - o.signed_lower) / d);
            bool miss = false;
            if (c.exact.intersecting()) {
              miss = c.exact.below(-o.signed_lower) || c.exact.above(-o.signed_upper);
            } else {
              miss = c.exact_distance < o.signed_lower || c.exact_distance > o.signed_upper;
            }
            if (miss) {
              ++signed_violations;
              violations_csv << s.value << c.set << c.group << c.exact.depth() << o.signed_lower
                             << o.signed_upper << "signed distance interval misses"
                             << hex_vertices(*c.input.a) << hex_pose(c.input.pose_a)
                             << hex_vertices(*c.input.b) << hex_pose(c.input.pose_b);
              violations_csv.end_row();
            }
          }
          if (std::isnan(o.depth_lower) || std::isnan(o.depth_upper)) {
            ++no_interval;
          } else {
            rel_width = (o.depth_upper - o.depth_lower) / d;
            widths.push_back(rel_width);
            if (rel_width > 1e-12) ++wide;
            const bool low = c.exact.above(o.depth_lower);   // lower end above the truth
            const bool high = c.exact.below(o.depth_upper);  // upper end below the truth
            if (low || high) {
              violation = true;
              ++violations;
              violations_csv << s.value << c.set << c.group << c.exact.depth() << o.depth_lower
                             << o.depth_upper
                             << (low ? "depth_lower above the exact depth"
                                     : "depth_upper below the exact depth")
                             << hex_vertices(*c.input.a) << hex_pose(c.input.pose_a)
                             << hex_vertices(*c.input.b) << hex_pose(c.input.pose_b);
              violations_csv.end_row();
            }
          }
        } else if (o.exit == Exit::iteration_cap) {
          ++capped;  // coal: EPA ran out of iterations (its status Failed)
        }
        if (set.rfind("stiff", 0) == 0) {
          per_case << s.impl << s.knob << s.value << c.set << c.group << c.size << c.relative_depth
                   << c.exact.depth() << d << o.depth << rel_error << rel_width
                   << (violation ? 1 : 0) << median(mine);
          per_case.end_row();
        }
      }
      total_violations += violations + signed_violations;
      const double max_signed_width =
          signed_widths.empty() ? kNaN
                                : *std::max_element(signed_widths.begin(), signed_widths.end());
      const double max_error =
          errors.empty() ? kNaN : *std::max_element(errors.begin(), errors.end());
      const double max_width =
          widths.empty() ? kNaN : *std::max_element(widths.begin(), widths.end());
      table << s.impl << s.knob << s.value << set << members.size() << median(times)
            << quantile(times, 0.99) << max_error << median(errors) << quantile(errors, 0.9)
            << missed << nans << threw << violations << no_interval << max_width << median(widths)
            << wide << signed_violations << max_signed_width << median(signed_widths) << capped
            << degenerate << hung_cases << aborted << "";
      table.end_row();
    }
  }
  Csv meta(output_path(args, "depth_meta.csv"), {"key", "value"});
  meta << "rounds" << rounds;
  meta.end_row();
  meta << "paper_poses_per_case" << config.poses_per_case;
  meta.end_row();
  meta << "cases" << n;
  meta.end_row();
  meta << "oracle_seconds" << oracle_seconds;
  meta.end_row();
  meta << "clock_overhead_ns" << clock_overhead_ns();
  meta.end_row();
  meta << "default_depth_tolerance" << kDefaultDepthTolerance<double>;
  meta.end_row();
  meta << "default_depth_max_iterations" << kDefaultDepthMaxIterations;
  meta.end_row();
  meta << "violations" << total_violations;
  meta.end_row();
  progress("depth: done (%ld interval violations)", total_violations);
  return 0;
}

}  // namespace nearpoint::bench
