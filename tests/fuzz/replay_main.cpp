// SPDX-License-Identifier: Apache-2.0
// main() for the fuzz targets in builds without libFuzzer (the normal g++ build): runs
// LLVMFuzzerTestOneInput once on each file named, or on each file of each directory named, so
// that the seed corpus and every saved finding are regression tests of the ordinary test suite.
//
// libFuzzer bounds each input's memory and time; here the same bounds keep an open finding (a
// billion-laughs file, say) from taking the machine's memory or the suite's time: 2 GiB of address
// space (ASan builds: of resident memory, ASan needs the address space) and 60 s per input, after
// which SIGALRM ends the process and the test fails.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) __attribute__((weak));

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define NEARPOINT_REPLAY_SANITIZED 1
#endif
// Read by ASan at start (ASAN_OPTIONS adds to it).
extern "C" const char* __asan_default_options() {
  return "hard_rss_limit_mb=2048";
}

namespace {
constexpr rlim_t kMemoryBytes = rlim_t(2) << 30;
constexpr unsigned kSecondsPerInput = 60;
}  // namespace

int main(int argc, char** argv) {
#ifndef NEARPOINT_REPLAY_SANITIZED
  const rlimit memory{kMemoryBytes, kMemoryBytes};
  setrlimit(RLIMIT_AS, &memory);
#endif
  if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
  std::vector<std::filesystem::path> files;
  for (int i = 1; i < argc; ++i) {
    const std::filesystem::path arg(argv[i]);
    if (std::filesystem::is_directory(arg)) {
      for (const auto& entry : std::filesystem::recursive_directory_iterator(arg))
        if (entry.is_regular_file()) files.push_back(entry.path());
    } else if (std::filesystem::is_regular_file(arg)) {
      files.push_back(arg);
    } else {
      std::fprintf(stderr, "replay: no such file or directory: %s\n", argv[i]);
      return 2;
    }
  }
  std::sort(files.begin(), files.end());  // a stable order, so a failure is reproducible
  for (const auto& file : files) {
    std::ifstream in(file, std::ios::binary);
    const std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
    std::fprintf(stderr, "replay: %s (%zu bytes)\n", file.c_str(), bytes.size());
    alarm(kSecondsPerInput);
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    alarm(0);
  }
  std::fprintf(stderr, "replay: %zu inputs, no invariant broken\n", files.size());
  return 0;
}
