// SPDX-License-Identifier: Apache-2.0
// The one quantile the CLI's summaries (`load`, `stream`) and the service benchmarks report, so
// that a p99 printed by one means what it means in the other.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace nearpoint::model {

/// The q-quantile of `values` by nearest rank (0.5: the median; 0.99: p99): the smallest value
/// with at least q·n values at or below it, one of the values and never an interpolation. 0 for
/// no values. `values` is taken by copy because it is partially reordered.
inline double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const double rank = std::ceil(std::clamp(q, 0.0, 1.0) * double(values.size()));
  const std::size_t index = rank < 1 ? 0 : std::min(values.size(), std::size_t(rank)) - 1;
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(index), values.end());
  return values[index];
}

}  // namespace nearpoint::model
