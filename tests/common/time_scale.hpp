// SPDX-License-Identifier: Apache-2.0
// How many times slower than a plain build this test binary runs. Sanitizer builds define
// NEARPOINT_TEST_TIME_SCALE (tests/CMakeLists.txt: about 3 under ASan, 10 under TSan); a test that
// fills a fixed time with work and then counts it scales that time, so that it asks for the same
// amount of work in every build instead of being loosened for all of them.
#pragma once

#ifndef NEARPOINT_TEST_TIME_SCALE
#define NEARPOINT_TEST_TIME_SCALE 1
#endif

namespace nearpoint::testkit {

inline constexpr int kTimeScale = NEARPOINT_TEST_TIME_SCALE;

}  // namespace nearpoint::testkit
