// SPDX-License-Identifier: Apache-2.0
/* openGJK prints diagnostics on degenerate input; in a timing loop they are noise (and cost a
   write). bench/cmake/source_peers.cmake compiles openGJK with -Dprintf=<this function>. */
int nearpoint_bench_opengjk_quiet_printf(const char* format, ...);

int nearpoint_bench_opengjk_quiet_printf(const char* format, ...) {
  (void)format;
  return 0;
}
