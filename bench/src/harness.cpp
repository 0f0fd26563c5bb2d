// SPDX-License-Identifier: Apache-2.0
#include "harness.hpp"

#include <algorithm>
#include <cstdarg>
#include <filesystem>
#include <stdexcept>

namespace nearpoint::bench {

const char* to_string(Exit exit) {
  switch (exit) {
    case Exit::unknown:
      return "-";
    case Exit::distance_subalgorithm:
      return "DS";
    case Exit::backup_procedure:
      return "BP";
    case Exit::numerical_limit:
      return "numerical limit";
    case Exit::iteration_cap:
      return "cap";
    case Exit::beyond_cutoff:
      return "beyond cutoff";
    case Exit::invalid_input:
      return "invalid input";
  }
  return "?";
}

double clock_overhead_ns() {
  static const double overhead = [] {
    std::vector<double> samples;
    samples.reserve(20001);
    for (int k = 0; k < 20001; ++k) {
      const auto t0 = Clock::now();
      const auto t1 = Clock::now();
      samples.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
    }
    return median(samples);
  }();
  return overhead;
}

void time_queries(Runner& runner, std::span<const std::uint32_t> indices, std::span<float> ns,
                  std::span<Outcome> outcomes) {
  const double overhead = clock_overhead_ns();
  Outcome outcome;
  for (const std::uint32_t i : indices) {
    const auto t0 = Clock::now();
    runner.run(i, outcome);
    const auto t1 = Clock::now();
    const double elapsed = std::chrono::duration<double, std::nano>(t1 - t0).count() - overhead;
    ns[i] = float(std::max(0.0, elapsed));
    if (!outcomes.empty()) outcomes[i] = outcome;
  }
}

namespace {
template <class T>
double quantile_impl(std::vector<T>& v, double q) {
  if (v.empty()) return kNaN;
  const double position = std::clamp(q, 0.0, 1.0) * double(v.size() - 1);
  const std::size_t lo = std::size_t(position);
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(lo), v.end());
  const double low = double(v[lo]);
  if (lo + 1 >= v.size()) return low;
  // The next order statistic is the minimum of the upper part (nth_element partitioned it).
  const double high = double(*std::min_element(v.begin() + std::ptrdiff_t(lo) + 1, v.end()));
  return low + (position - double(lo)) * (high - low);
}
}  // namespace

double quantile(std::vector<float>& values, double q) {
  return quantile_impl(values, q);
}
double quantile(std::vector<double>& values, double q) {
  return quantile_impl(values, q);
}

Csv::Csv(const std::string& path, const std::vector<std::string>& header) {
  file_ = std::fopen(path.c_str(), "w");
  if (!file_) throw std::runtime_error("cannot write " + path);
  for (const std::string& h : header) *this << h;
  end_row();
}

Csv::~Csv() {
  if (file_) std::fclose(file_);
}

void Csv::separator() {
  if (row_started_) std::fputc(',', file_);
  row_started_ = true;
}

Csv& Csv::operator<<(const std::string& field) {
  separator();
  // Quote only when needed (names with commas, e.g. "irregular M=100, …").
  if (field.find_first_of(",\"\n") == std::string::npos) {
    std::fputs(field.c_str(), file_);
  } else {
    std::fputc('"', file_);
    for (const char c : field) {
      if (c == '"') std::fputc('"', file_);
      std::fputc(c, file_);
    }
    std::fputc('"', file_);
  }
  return *this;
}

Csv& Csv::operator<<(double value) {
  separator();
  if (std::isnan(value))
    std::fputs("nan", file_);
  else
    std::fprintf(file_, "%.17g", value);
  return *this;
}

Csv& Csv::operator<<(int value) {
  separator();
  std::fprintf(file_, "%d", value);
  return *this;
}

Csv& Csv::operator<<(long value) {
  separator();
  std::fprintf(file_, "%ld", value);
  return *this;
}

Csv& Csv::operator<<(std::size_t value) {
  separator();
  std::fprintf(file_, "%zu", value);
  return *this;
}

void Csv::end_row() {
  std::fputc('\n', file_);
  row_started_ = false;
}

std::string output_path(const Args& args, const std::string& name) {
  std::filesystem::create_directories(args.out_dir);
  return (std::filesystem::path(args.out_dir) / name).string();
}

void progress(const char* format, ...) {
  std::va_list list;
  va_start(list, format);
  std::fputs("[bench] ", stderr);
  std::vfprintf(stderr, format, list);
  std::fputc('\n', stderr);
  va_end(list);
}

}  // namespace nearpoint::bench
