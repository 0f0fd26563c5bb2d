// SPDX-License-Identifier: Apache-2.0
// One distance with the installed engine: a unit box at the origin and a unit sphere centred at
// (4, 0, 0) are 2 apart. Prints the distance; exits 1 when it is not 2 within the error bound.
#include <cmath>
#include <cstdio>

#include "nearpoint/distance.hpp"
#include "nearpoint/shapes.hpp"

int main() {
  using Shape = nearpoint::Shape<double>;
  using Pose = nearpoint::Pose<double>;
  const Shape box(nearpoint::Box<double>{});
  const Shape sphere = Shape::sphere(1.0);
  Pose at;
  at.translation = {4.0, 0.0, 0.0};
  const auto result = nearpoint::distance(box, Pose::identity(), sphere, at);
  std::printf("distance %.12g error_bound %.3g\n", result.distance, result.error_bound);
  return std::abs(result.distance - 2.0) <= result.error_bound + 1e-12 ? 0 : 1;
}
