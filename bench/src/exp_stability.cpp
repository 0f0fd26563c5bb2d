// SPDX-License-Identifier: Apache-2.0
// (5) The stability report of issue 4: every case of the stiff suite (tests/stiff/stiff_cases.hpp)
// through nearpoint (Johnson and signed volumes, double and float) and through the peers (FCL with
// libccd and with its own GJK, Bullet in double, libccd's yes/no query), against CGAL's exact
// distance on the very inputs each one sees.
//
// Each (implementation, case) runs in a child process with a time limit, so that a peer that
// crashes or hangs on a degenerate input is reported as such ("crash", "timeout") and the report
// goes on. A case a peer cannot express (a rounded polytope for fcl::Convex) is reported as "not
// accepted" with the reason, never left out.
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <functional>

#include "common/exact_distance.hpp"
#include "experiments.hpp"
#include "runners.hpp"
#include "stiff/stiff_cases.hpp"

namespace nearpoint::bench {
namespace {

// What a child sends back: plain data, written to a pipe in one piece.
struct Report {
  int declined = 0;
  double distance = kNaN;
  int intersecting = 0;
  int iterations = -1;
  double error_bound = kNaN;
  int exit = int(Exit::unknown);
  int code_a = -1, code_b = -1;
  double time_us = kNaN;
  char termination[32] = {};
  char reason[160] = {};
};

/// Runs `work` in a child process. Returns the child's report, or sets `failure` to "timeout" or
/// "crash (…)" when it did not come back.
Report isolated(const std::function<Report()>& work, int timeout_s, std::string& failure) {
  failure.clear();
  int fds[2];
  if (pipe(fds) != 0) {
    failure = "pipe() failed";
    return {};
  }
  std::fflush(nullptr);  // nothing buffered may be written twice
  const pid_t pid = fork();
  if (pid < 0) {
    failure = "fork() failed";
    return {};
  }
  if (pid == 0) {
    close(fds[0]);
    const Report r = work();
    const ssize_t written = write(fds[1], &r, sizeof r);
    _exit(written == ssize_t(sizeof r) ? 0 : 3);
  }
  close(fds[1]);
  Report report;
  pollfd p{fds[0], POLLIN, 0};
  const int ready = poll(&p, 1, timeout_s * 1000);
  bool got = false;
  if (ready > 0) got = read(fds[0], &report, sizeof report) == ssize_t(sizeof report);
  if (ready == 0) {
    kill(pid, SIGKILL);
    failure = "timeout (> " + std::to_string(timeout_s) + " s)";
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (failure.empty() && !got) {
    if (WIFSIGNALED(status))
      failure = std::string("crash (") + strsignal(WTERMSIG(status)) + ")";
    else
      failure = "no answer (exit code " + std::to_string(WEXITSTATUS(status)) + ")";
  }
  return report;
}

template <class F>
double time_us(F&& query) {
  const auto t0 = Clock::now();
  query();
  return std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
}

// nearpoint in precision S on a case (double, or the float-rounded copy of it).
template <class S>
Report nearpoint_report(const stiff::StiffCase<S>& c, Subalgorithm method) {
  DistanceOptions<S> options;
  options.subalgorithm = method;
  options.near_points = true;
  const Shape<S> a(Polytope<S>(c.a), c.radius_a), b(Polytope<S>(c.b), c.radius_b);
  DistanceResult<S> r = distance(a, c.pose_a, b, c.pose_b, options);
  Report out;
  out.time_us = time_us([&] { r = distance(a, c.pose_a, b, c.pose_b, options); });
  out.distance = double(r.distance);
  out.intersecting = r.status == Status::intersecting;
  out.iterations = r.iterations;
  out.error_bound = double(r.error_bound);
  out.exit = int(exit_of(r));
  std::snprintf(out.termination, sizeof out.termination, "%s", to_string(r.termination));
  if (r.message) std::snprintf(out.reason, sizeof out.reason, "%s", r.message);
  return out;
}

Report peer_report(Peer peer, const stiff::StiffCase<double>& c) {
  const std::vector<PairInput> inputs = {{std::make_shared<const std::vector<Vec3<double>>>(c.a),
                                          std::make_shared<const std::vector<Vec3<double>>>(c.b),
                                          c.pose_a, c.pose_b, c.radius_a, c.radius_b}};
  Report out;
  std::string why;
  const std::unique_ptr<Runner> runner = make_peer_runner(peer, inputs, PeerSettings{}, &why);
  if (!runner) {
    out.declined = 1;
    std::snprintf(out.reason, sizeof out.reason, "%s", why.c_str());
    return out;
  }
  Outcome o;
  runner->run(0, o);
  out.time_us = time_us([&] { runner->run(0, o); });
  out.distance = o.distance;
  out.intersecting = o.intersecting;
  out.iterations = o.iterations;
  out.exit = int(o.exit);
  out.code_a = o.code_a;
  out.code_b = o.code_b;
  return out;
}

struct Truth {
  double distance = 0;
  bool intersecting = false;
};

template <class S>
Truth truth_of(const stiff::StiffCase<S>& c) {
  const testkit::ExactDistance e = testkit::exact_distance<S>(c.a, c.pose_a, c.b, c.pose_b);
  const double radii = double(c.radius_a) + double(c.radius_b);
  return {std::max(0.0, e.distance - radii), e.intersecting || e.distance <= radii};
}

}  // namespace

int run_stability(const Args& args) {
  const std::vector<stiff::StiffCase<double>> cases = stiff::make_stiff_cases();
  const std::vector<stiff::StiffCase<float>> cases_f = stiff::to_float(cases);
  const int timeout_s = args.quick ? 20 : 60;

  Csv table(output_path(args, "stability.csv"), {"family",
                                                 "case",
                                                 "size",
                                                 "impl",
                                                 "precision",
                                                 "truth_distance",
                                                 "truth_intersecting",
                                                 "outcome",
                                                 "reason",
                                                 "distance",
                                                 "intersecting",
                                                 "error",
                                                 "relative_error",
                                                 "error_bound",
                                                 "bound_holds",
                                                 "stated_accuracy",
                                                 "within_stated",
                                                 "iterations",
                                                 "exit",
                                                 "termination",
                                                 "code_a",
                                                 "code_b",
                                                 "verdict",
                                                 "time_us"});
  struct Variant {
    const char* name;
    const char* precision;
    std::function<Report(std::size_t)> work;
    double stated;  // the stated accuracy relative to size (tests/stiff), NaN for peers
  };
  const std::vector<Variant> variants = {
      {"nearpoint_johnson", "double",
       [&](std::size_t i) { return nearpoint_report(cases[i], Subalgorithm::johnson); }, 1e-12},
      {"nearpoint_signed_volumes", "double",
       [&](std::size_t i) { return nearpoint_report(cases[i], Subalgorithm::signed_volumes); },
       1e-12},
      {"nearpoint_johnson", "float",
       [&](std::size_t i) { return nearpoint_report(cases_f[i], Subalgorithm::johnson); }, 2e-4},
      {"nearpoint_signed_volumes", "float",
       [&](std::size_t i) { return nearpoint_report(cases_f[i], Subalgorithm::signed_volumes); },
       2e-4},
      {"fcl_libccd", "double",
       [&](std::size_t i) { return peer_report(Peer::fcl_libccd, cases[i]); }, kNaN},
      {"fcl_indep", "double", [&](std::size_t i) { return peer_report(Peer::fcl_indep, cases[i]); },
       kNaN},
      {"bullet", "double", [&](std::size_t i) { return peer_report(Peer::bullet, cases[i]); },
       kNaN},
      {"ccd_intersect", "double",
       [&](std::size_t i) { return peer_report(Peer::ccd_intersect, cases[i]); }, kNaN},
  };

  for (std::size_t i = 0; i < cases.size(); ++i) {
    const stiff::StiffCase<double>& c = cases[i];
    const Truth truth_d = truth_of(c);
    const Truth truth_f = truth_of(cases_f[i]);
    for (const Variant& v : variants) {
      const bool single = std::strcmp(v.precision, "float") == 0;
      const Truth& truth = single ? truth_f : truth_d;
      std::string failure;
      const Report r = isolated([&] { return v.work(i); }, timeout_s, failure);
      table << c.family << c.name << c.size << v.name << v.precision << truth.distance
            << int(truth.intersecting);
      if (!failure.empty() || r.declined) {
        table << (r.declined ? "not accepted" : failure) << std::string(r.reason) << kNaN << 0
              << kNaN << kNaN << kNaN << "" << v.stated * c.size << "" << -1 << "" << -1 << -1 << ""
              << kNaN;
        table.end_row();
        continue;
      }
      const bool yes_no = std::isnan(r.distance) && v.name == std::string("ccd_intersect");
      const double error = yes_no ? kNaN : std::abs(r.distance - truth.distance);
      // Judging a verdict. A disagreement with the truth is "within bound" when the result's own
      // certified error bound reaches the truth (nearpoint says how sure it is; such an answer is
      // honest), "at contact" when the truth is within 1e-12 of the shapes' size of touching
      // (either answer is defensible there; the distance error is what counts), else WRONG. Peers
      // report no bound, so only the contact allowance applies to them.
      const bool at_contact = truth.distance <= 1e-12 * c.size && !c.deep_overlap;
      const bool within_bound =
          !std::isnan(r.error_bound) && truth.distance <= r.error_bound && !c.deep_overlap;
      std::string verdict = "ok";
      if (bool(r.intersecting) != truth.intersecting)
        verdict = within_bound ? "within bound" : (at_contact ? "at contact" : "WRONG");
      if (!yes_no && std::isnan(r.distance)) verdict = "NaN";
      const bool has_bound = !std::isnan(r.error_bound);
      table << "ran" << std::string(r.reason) << r.distance << r.intersecting << error
            << error / c.size << r.error_bound
            << (has_bound ? (error <= r.error_bound ? "yes" : "NO") : "") << v.stated * c.size
            << (std::isnan(v.stated) || yes_no ? "" : (error <= v.stated * c.size ? "yes" : "NO"))
            << r.iterations << to_string(Exit(r.exit)) << std::string(r.termination) << r.code_a
            << r.code_b << verdict << r.time_us;
      table.end_row();
    }
    progress("stability: %zu/%zu %s", i + 1, cases.size(), c.name.c_str());
  }
  progress("stability: done");
  return 0;
}

}  // namespace nearpoint::bench
