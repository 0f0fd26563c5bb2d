// SPDX-License-Identifier: Apache-2.0
// What the fuzz targets share: a reader that turns libFuzzer's bytes into the values a target
// needs, and the one way a target reports a broken invariant.
//
// The reader never fails: past the end of the input it yields zeros, so every byte string is a
// valid input and short inputs are the simple cases. Values are drawn so that the interesting
// ranges (zero, denormals, huge magnitudes, non-finite) are a byte away, not 2⁻⁶⁴ likely.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>

namespace nearpoint::fuzz {

/// Called by `fail` before it aborts, when set: a target's survey mode (fuzz_engine's
/// NEARPOINT_FUZZ_SURVEY) throws from here to its own entry point, to count broken invariants by
/// kind and keep fuzzing. Null (the default): every broken invariant is a crash.
inline void (*on_failure)(const char* file, int line, const std::string& what) = nullptr;

/// A broken invariant: print what and where, then abort, which libFuzzer (and the replay driver)
/// records as a crash with the input that caused it.
[[noreturn]] inline void fail(const char* file, int line, const std::string& what) {
  if (on_failure) on_failure(file, line, what);
  std::fprintf(stderr, "\nFUZZ INVARIANT BROKEN at %s:%d\n  %s\n", file, line, what.c_str());
  std::fflush(stderr);
  std::abort();
}

#define NEARPOINT_FUZZ_CHECK(condition, message)                              \
  do {                                                                        \
    if (!(condition)) ::nearpoint::fuzz::fail(__FILE__, __LINE__, (message)); \
  } while (false)

class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  std::size_t remaining() const { return size_ - pos_; }

  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  std::uint16_t u16() { return std::uint16_t(byte() | (unsigned(byte()) << 8)); }
  std::uint32_t u32() { return std::uint32_t(u16()) | (std::uint32_t(u16()) << 16); }
  std::uint64_t u64() { return std::uint64_t(u32()) | (std::uint64_t(u32()) << 32); }

  /// `n` bytes (fewer at the end of the input).
  std::string bytes(std::size_t n) {
    n = n < remaining() ? n : remaining();
    std::string out(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return out;
  }

  /// A value of type Scalar. Mostly a 16-bit fixed-point number in (-8, 8) scaled by 2^scale_exp
  /// (the input's common scale), sometimes with its own exponent, sometimes a special value
  /// (zeros, ±1, denormals, the largest finite, infinities, NaN) or raw bits.
  template <class Scalar>
  Scalar value(int scale_exp) {
    using L = std::numeric_limits<Scalar>;
    const std::uint8_t tag = byte();
    if (tag < 12) {
      const Scalar specials[12] = {Scalar(0),       -Scalar(0),     Scalar(1),      Scalar(-1),
                                   L::denorm_min(), L::min(),       L::max(),       -L::max(),
                                   L::infinity(),   -L::infinity(), L::quiet_NaN(), L::epsilon()};
      return specials[tag];
    }
    if (tag < 20) {  // raw bits
      if constexpr (sizeof(Scalar) == 8) {
        const std::uint64_t bits = u64();
        Scalar out;
        std::memcpy(&out, &bits, sizeof out);
        return out;
      } else {
        const std::uint32_t bits = u32();
        Scalar out;
        std::memcpy(&out, &bits, sizeof out);
        return out;
      }
    }
    const double mantissa = double(std::int16_t(u16())) / 4096.0;
    int exp = scale_exp;
    if (tag < 40) exp = exponent<Scalar>();  // its own scale
    return Scalar(std::ldexp(mantissa, exp));
  }

  /// An exponent over the whole range of Scalar, near 0 for small bytes.
  template <class Scalar>
  int exponent() {
    const int e = std::int8_t(byte());
    using L = std::numeric_limits<Scalar>;
    // Steps of 1 near zero, coarser towards the ends of the range.
    const int scaled =
        (e >= -32 && e <= 32) ? e : (e > 0 ? 32 + (e - 32) * 11 : -32 + (e + 32) * 11);
    const int lo = L::min_exponent - L::digits - 1, hi = L::max_exponent;
    return scaled < lo ? lo : (scaled > hi ? hi : scaled);
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace nearpoint::fuzz
