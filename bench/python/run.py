#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Per-pair time of the engine from Python (issue 34), against the C++ engine on the same pairs
in the same run:

  - one Python call per pair (`nearpoint.distance`), poses as Pose objects and as (7,) rows;
  - the batch call (`nearpoint.distance_batch`), N = 10, 10^3, 10^5, on 1 and 2 threads, poses as
    (N, 7) rows (the engine's quaternion constructor runs per row) and as (N, 4, 4) matrices;
  - the C++ engine (tests/python/engine_reference.cpp `time`): the same shapes, the same doubles,
    poses built beforehand, a plain loop.

Small shapes (a box and an 8-vertex polytope) make the bindings' overhead as visible as it gets.
Writes bench/results/python.csv and bench/results/python.md (or --out DIR).

    cmake --build build --target nearpoint_python engine_reference
    /usr/bin/python3 bench/python/run.py --build build
"""
import argparse
import csv
import os
import platform
import random
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tests", "python"))
import engine_cases as cases  # noqa: E402


def best_of(fn, repeats, min_seconds):
    """The least per-call time of `repeats` runs of `fn` looped for at least `min_seconds`."""
    best = float("inf")
    for _ in range(repeats):
        calls, start = 0, time.perf_counter()
        while True:
            fn()
            calls += 1
            elapsed = time.perf_counter() - start
            if elapsed >= min_seconds:
                break
        best = min(best, elapsed / calls)
    return best


def cpp_ns(tool, path, reps):
    out = subprocess.run([tool, "time", path, str(reps)], check=True, capture_output=True,
                         text=True).stdout.split()
    return float(out[0])


def measure_python(npt, np, a, b, rows_a, rows_b, mats_a, mats_b, n, m, between):
    """(method, N, threads, seconds per pair, C++ reference) for every Python measurement."""
    out = []
    # One Python call per pair (the C++ loop on the same pairs as reference).
    poses_a = [npt.Pose.from_quaternion(r[3:], r[:3]) for r in rows_a[:m]]
    poses_b = [npt.Pose.from_quaternion(r[3:], r[:3]) for r in rows_b[:m]]
    pairs = list(zip(poses_a, poses_b))
    row_pairs = list(zip(rows_a[:m], rows_b[:m]))
    distance = npt.distance

    def single_pose_objects():
        for pa, pb in pairs:
            distance(a, pa, b, pb)

    def single_rows():
        for pa, pb in row_pairs:
            distance(a, pa, b, pb)
    out.append(("single call, Pose objects", m, 1, best_of(single_pose_objects, 7, 0.2) / m,
                "single"))
    out.append(("single call, (7,) numpy rows", m, 1, best_of(single_rows, 7, 0.2) / m, "single"))
    between()
    # The batch call.
    for count in (10, 1_000, n):
        for threads in (1, 2):
            for layout, pa, pb in (("(N, 7) rows", rows_a, rows_b),
                                   ("(N, 4, 4) matrices", mats_a, mats_b)):
                xa, xb = pa[:count], pb[:count]
                seconds = best_of(lambda: npt.distance_batch(a, xa, b, xb, threads=threads),
                                  7, 0.2 if count < n else 0.0)
                out.append((f"batch, {layout}", count, threads, seconds / count, "all"))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default=os.path.join(ROOT, "build"))
    parser.add_argument("--out", default=os.path.join(ROOT, "bench", "results"))
    parser.add_argument("--pairs", type=int, default=100_000)
    parser.add_argument("--single", type=int, default=20_000, help="pairs timed one call each")
    args = parser.parse_args()
    sys.path.insert(0, os.path.join(args.build, "client", "python"))
    import numpy as np
    import nearpoint as npt
    tool = os.path.join(args.build, "tests", "engine_reference")

    rng = random.Random(1988)
    cube8 = [[rng.uniform(-0.5, 0.5) for _ in range(3)] for _ in range(8)]
    specs = [cases.Spec("box", [0.5, 0.3, 0.2], 0.0), cases.Spec("polytope", cube8, 0.0)]
    a, b = (s.make(npt) for s in specs)
    n = args.pairs
    rows_a = np.array([cases.random_row7(rng, 1.5) for _ in range(n)])
    rows_b = np.array([cases.random_row7(rng, 1.5) for _ in range(n)])
    mats_a = np.array([cases.matrix_of(r) for r in rows_a])
    mats_b = np.array([cases.matrix_of(r) for r in rows_b])
    results = []
    started = time.time()

    with tempfile.TemporaryDirectory(prefix="nearpoint_pybench_") as tmp:
        def write(name, count):
            path = os.path.join(tmp, name)
            cases.write_cases(path, {}, specs,
                              [(0, 1, rows_a[i], rows_b[i]) for i in range(count)])
            return path
        all_pairs, single_pairs = write("all.txt", n), write("single.txt", args.single)
        load = open("/proc/loadavg").read().split()[0] if os.path.exists("/proc/loadavg") else "?"
        # The C++ loop is timed before, between and after the Python measurements, and its best
        # taken, as theirs is: on a shared machine the least time is the least disturbed one.
        cpp_times = {"all": [], "single": []}

        def time_cpp():
            cpp_times["all"].append(min(cpp_ns(tool, all_pairs, 3) for _ in range(2)))
            cpp_times["single"].append(min(cpp_ns(tool, single_pairs, 10) for _ in range(2)))
        time_cpp()
        results_python = measure_python(npt, np, a, b, rows_a, rows_b, mats_a, mats_b, n,
                                        args.single, time_cpp)
        time_cpp()
    cpp_all, cpp_single = min(cpp_times["all"]), min(cpp_times["single"])

    def record(method, count, threads, seconds_per_pair, reference):
        ns = seconds_per_pair * 1e9
        results.append({"method": method, "n": count, "threads": threads,
                        "ns_per_pair": round(ns, 1), "cpp_ns_per_pair": round(reference, 1),
                        "ratio_to_cpp": round(ns / reference, 3),
                        "overhead_ns": round(ns - reference, 1)})

    for method, count, threads, seconds, which in results_python:
        record(method, count, threads, seconds, cpp_single if which == "single" else cpp_all)

    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "python.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(results[0]))
        w.writeheader()
        w.writerows(results)
    host = f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores (shared)"
    lines = [
        "# The engine from Python: per-pair time against C++ (bench/python/run.py)",
        "",
        f"One run, {time.strftime('%Y-%m-%d')}, {host}, Python {platform.python_version()}, "
        f"numpy {np.__version__}; {n} pairs of a box and an 8-vertex polytope at random poses "
        f"(distance only, default options). C++: the engine in a plain loop on the same pairs, "
        f"{cpp_all:.1f} ns per pair over all {n} ({cpp_single:.1f} ns over the first "
        f"{args.single}, the "
        "single calls' reference), timed before, between and after the Python runs. Each figure "
        "is the best of 7 repeats (C++: of 6); the machine is shared, "
        "so the ratios (measured together) mean more than the absolute times. Load average "
        f"at the start: {load} (other jobs were running). Ratios on 2 threads are against the "
        "one-thread C++ loop.",
        "",
        "| method | N | threads | ns/pair | C++ ns/pair | ratio | overhead ns |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in results:
        lines.append(f"| {r['method']} | {r['n']} | {r['threads']} | {r['ns_per_pair']} | "
                     f"{r['cpp_ns_per_pair']} | {r['ratio_to_cpp']} | {r['overhead_ns']} |")
    lines += ["", f"Run time: {time.time() - started:.0f} s.", ""]
    with open(os.path.join(args.out, "python.md"), "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
