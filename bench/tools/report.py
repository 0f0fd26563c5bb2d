#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Turns the CSV files of one benchmark run (bench/run.sh) into Markdown tables, PNG plots and the
summary page (bench/RESULTS.md). Every figure it writes is read from those CSV files: nothing is
typed in by hand, so a re-run of bench/run.sh rewrites every number.

usage: report.py --results DIR --summary FILE.md
"""
import argparse
import csv
import math
import os
from collections import Counter, defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

CASES = ["separated", "touching", "intersecting"]
DISTANCE_IMPLS = ["nearpoint_johnson", "nearpoint_signed_volumes", "fcl_libccd", "fcl_indep", "bullet",
                  "opengjk", "coal_1e-12", "coal_1e-6"]
DISTANCE_PEERS = [i for i in DISTANCE_IMPLS if not i.startswith("nearpoint")]
# Issue 25's yardstick: the fastest open peers at an exact tolerance.
FAST_PEERS = ["opengjk", "coal_1e-12"]
NEARPOINT_DEFAULT = "nearpoint_signed_volumes"  # the engine's default subalgorithm
YESNO_IMPLS = ["nearpoint_johnson_yesno", "nearpoint_signed_volumes_yesno", "ccd_intersect"]
LABEL = {
    "nearpoint_johnson": "nearpoint Johnson",
    "nearpoint_signed_volumes": "nearpoint signed volumes",
    "nearpoint_johnson_scan": "nearpoint Johnson, linear scan",
    "nearpoint_signed_volumes_scan": "nearpoint signed volumes, linear scan",
    "fcl_libccd": "FCL 0.7 libccd",
    "fcl_indep": "FCL 0.7 indep",
    "bullet": "Bullet 3.24 double",
    "opengjk": "openGJK 174d3aa",
    "coal_1e-12": "coal 3.0.0+ tol 1e-12",
    "coal_1e-6": "coal 3.0.0+ tol 1e-6",
    "nearpoint_johnson_yesno": "nearpoint Johnson, cutoff 0",
    "nearpoint_signed_volumes_yesno": "nearpoint signed volumes, cutoff 0",
    "ccd_intersect": "libccd 2.1 ccdGJKIntersect",
}
COLOR = {
    "nearpoint_johnson": "tab:blue",
    "nearpoint_signed_volumes": "tab:cyan",
    "nearpoint_johnson_scan": "tab:gray",
    "nearpoint_signed_volumes_scan": "tab:brown",
    "fcl_libccd": "tab:red",
    "fcl_indep": "tab:orange",
    "bullet": "tab:green",
    "opengjk": "tab:olive",
    "coal_1e-12": "tab:pink",
    "coal_1e-6": "tab:brown",
    "nearpoint_johnson_yesno": "tab:blue",
    "nearpoint_signed_volumes_yesno": "tab:cyan",
    "ccd_intersect": "tab:purple",
}
# The paper's Table I ratios (single-point / special initialisation, Harris 800).
PAPER_TABLE1 = {10: 1.7, 100: 2.9, 1000: 3.1}
ERROR_FLOOR = 1e-18  # where an exact 0 error is drawn on log axes


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def ns(x):
    x = num(x)
    return "—" if math.isnan(x) else f"{x:,.0f}"


def err(x):
    x = num(x)
    if math.isnan(x):
        return "—"
    return "0" if x == 0 else f"{x:.1e}"


def ratio(x):
    return "—" if math.isnan(x) else f"{x:.2f}×"


def table(header, rows):
    out = ["", "| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------------------------------
# The figures: each draws from rows a section computed, and saves through `save(fig, name)`.


def plot_fig4(pairs, meta, save):
    """Fig. 4: time against M, one panel per case; and ns per vertex."""
    for name, column, ylabel in [("fig4_time_vs_M.png", "median_ns", "median ns per query"),
                                 ("fig4_ns_per_vertex.png", "ns_per_vertex", "median ns per vertex (M)")]:
        fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), sharey=True)
        for ax, c in zip(axes, CASES):
            for i in DISTANCE_IMPLS + ["ccd_intersect", "nearpoint_johnson_yesno"]:
                pts = sorted((int(r["M"]), num(r[column])) for r in pairs if r["impl"] == i and r["case"] == c)
                pts = [(m, y) for m, y in pts if not math.isnan(y)]
                if not pts:
                    continue
                xs, ys = [m for m, _ in pts], [y for _, y in pts]
                hollow = i in YESNO_IMPLS
                ax.scatter(xs, ys, s=16, color=COLOR[i], alpha=0.85, label=LABEL[i],
                           facecolors="none" if hollow else COLOR[i])
                # Least-squares line a + b·M: the paper's "cost ≈ linear in M" shape.
                n = len(xs)
                mx, my = sum(xs) / n, sum(ys) / n
                sxx = sum((x - mx) ** 2 for x in xs)
                if sxx > 0 and column == "median_ns":  # a line in M fits time, not time / M
                    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx
                    a = my - b * mx
                    ax.plot([0, max(xs)], [a, a + b * max(xs)], "--" if hollow else "-",
                            color=COLOR[i], lw=1, alpha=0.7)
            ax.set_title(f"{c}")
            ax.set_xlabel("M = M_A + M_B (vertices)")
            ax.grid(alpha=0.3)
        axes[0].set_ylabel(ylabel)
        axes[0].set_ylim(bottom=0)
        axes[2].legend(fontsize=8)
        fig.suptitle("Section VII experiment (Fig. 4's shape): each point is one pair's median over "
                     f"{meta['poses_per_case']} poses × {meta['rounds']} rounds"
                     + ("; lines: least-squares fit in M" if column == "median_ns" else ""))
        save(fig, name)


def plot_table1_distances(curve, save):
    """The distances along the Table I path (the paper's Fig. 6)."""
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for k in range(1, 6):
        pts = [r for r in curve if int(r["obstacle"]) == k]
        s = [num(r["s"]) for r in pts]
        d = [num(r["distance"]) if num(r["distance"]) > 0 else -num(r["penetration_bound"]) for r in pts]
        ax.plot(s, d, label=f"d{k}: {pts[0]['name']}")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xlabel("s")
    ax.set_ylabel("distance (negative: −d⁻, the penetration lower bound)")
    ax.set_title("Section VIII scene: distances along the path (the paper's Fig. 6), T = 1000")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    save(fig, "table1_distances.png")


def plot_error_time(rows_in, impls, c, save):
    """Max and median error against time for case `c`, one line per knob."""
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8), sharex=True)
    for ax, column, title in [(axes[0], "max_error", "max"), (axes[1], "median_error", "median")]:
        for i in impls:
            for knob, style in [("epsilon", "-"), ("distance_tolerance", "-"),
                                ("equal_vertex_threshold", "-"), ("max_iterations", ":")]:
                pts = [r for r in rows_in if r["impl"] == i and r["case"] == c and r["knob"] == knob
                       and not math.isnan(num(r["median_ns"]))]
                if not pts:
                    continue
                pts.sort(key=lambda r: -num(r["value"]) if knob != "max_iterations" else num(r["value"]))
                x = [num(r["median_ns"]) for r in pts]
                y = [max(num(r[column]), ERROR_FLOOR) for r in pts]
                label = LABEL[i] + (" (iteration cap)" if knob == "max_iterations" else "")
                ax.plot(x, y, style, marker="o", ms=3, color=COLOR[i], label=label)
        ax.set_yscale("log")
        ax.set_xlabel("median ns per query")
        ax.set_ylabel(f"{title} |d − d_exact| (0 drawn at {ERROR_FLOOR:g})")
        ax.set_title(f"{c}: {title} error against time")
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=7)
    save(fig, f"error_time_{c}.png")


def plot_error_bound(pts, violations, save):
    """nearpoint's reported error bound against the true error, every sampled example."""
    fig, ax = plt.subplots(figsize=(6.5, 6))
    for i, marker in [("nearpoint_johnson", "o"), ("nearpoint_signed_volumes", "x")]:
        sel = [r for r in pts if r["impl"] == i]
        ax.scatter([max(num(r["error"]), ERROR_FLOOR) for r in sel],
                   [max(num(r["error_bound"]), ERROR_FLOOR) for r in sel], s=10, alpha=0.45,
                   color=COLOR[i], marker=marker, label=LABEL[i],
                   facecolors="none" if marker == "o" else None)
    lo, hi = ERROR_FLOOR / 2, 10
    ax.plot([lo, hi], [lo, hi], "k--", lw=0.8, label="bound = error")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_xlabel(f"true error |d − d_exact| (0 drawn at {ERROR_FLOOR:g})")
    ax.set_ylabel("reported error bound")
    ax.set_title(f"error bound against true error\n(all ε and cap settings; {violations} violations)")
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(alpha=0.3, which="both")
    save(fig, "error_bound.png")


def plot_large(by, sizes, series, save):
    """Large polytopes: median time against vertex count, one line per series."""
    fig, ax = plt.subplots(figsize=(8, 5))
    for i, m in series:
        pts = [(n, num(by[(n, i, m)]["median_ns"])) for n in sizes if (n, i, m) in by]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "-" if m == "cold" else "--", marker="o", ms=4,
                color=COLOR[i], label=f"{LABEL[i]} {m}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("points per hull (N)")
    ax.set_ylabel("median ns per query")
    ax.set_title("Large polytopes: time against vertex count")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    save(fig, "large_time_vs_vertices.png")


def stability_cell(r, v):
    """One (case, variant) cell of the stability page: the error and its bound, iterations, exit,
    time and verdict; or why the variant did not run (`r` is None: no row for it)."""
    if r is None:
        return "—"
    if r["outcome"] == "not accepted":
        return "not accepted"
    if r["outcome"] != "ran":
        return f"**{r['outcome']}**"
    if math.isnan(num(r["error"])) and v[0] == "ccd_intersect":
        cell = "intersecting" if r["intersecting"] == "1" else "separated"
    else:
        cell = err(r["error"])
    if not math.isnan(num(r["error_bound"])):
        cell += f" ≤ {err(r['error_bound'])}" if r["bound_holds"] == "yes" else f" **> bound {err(r['error_bound'])}**"
    extra = []
    if int(r["iterations"]) >= 0:
        extra.append(f"{r['iterations']} it")
    if r["exit"] != "-":
        extra.append(r["exit"])
    if not math.isnan(num(r["time_us"])):
        extra.append(f"{num(r['time_us']):.3g} µs")
    if r["verdict"] != "ok":
        extra.append(f"**{r['verdict']}**" if r["verdict"] in ("WRONG", "NaN") else r["verdict"])
    return cell + (" · " + ", ".join(extra) if extra else "")


DEPTH_IMPLS = ["nearpoint", "coal_epa", "fcl_libccd_epa", "fcl_libccd_mpr", "libccd_epa", "bullet_gjkepa2"]
DEPTH_LABEL = {
    "nearpoint": "nearpoint (signed volumes + EPA, certified)",
    "coal_epa": "coal cf75966 GJK + EPA",
    "fcl_libccd_epa": "FCL 0.7 signed distance (libccd GJK + EPA)",
    "fcl_libccd_mpr": "FCL 0.7 collide (libccd MPR)",
    "libccd_epa": "libccd 2.1 ccdGJKPenetration (EPA)",
    "bullet_gjkepa2": "Bullet 3.24 double btGjkEpaSolver2",
}
DEPTH_COLOR = {"nearpoint": "tab:blue", "coal_epa": "tab:pink", "fcl_libccd_epa": "tab:red",
               "fcl_libccd_mpr": "tab:orange", "libccd_epa": "tab:purple", "bullet_gjkepa2": "tab:green"}
DEPTH_SETS = [("paper_intersecting", "paper's intersecting pairs"), ("paper_touching", "paper's touching pairs"),
              ("stiff", "stiff sweep at the origin"), ("stiff_far", "stiff sweep 1e6·size away")]


def knob_label(impl, value):
    v = num(value)
    if math.isnan(v):
        return "fixed"
    if impl == "nearpoint" and abs(v - 4096 * 2.0 ** -52) < 1e-20:
        return "default"
    return f"{v:.0e}"


def plot_depth(rows_in, save):
    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    for ax, (key, title) in zip(axes.flat, DEPTH_SETS):
        for impl in DEPTH_IMPLS:
            rs = [r for r in rows_in if r["impl"] == impl and r["set"] == key and not math.isnan(num(r["median_ns"]))]
            if not rs:
                continue
            xs = [num(r["median_ns"]) for r in rs]
            ys = [max(num(r["max_rel_error"]), ERROR_FLOOR) for r in rs]
            ax.plot(xs, ys, "o-", color=DEPTH_COLOR[impl], label=DEPTH_LABEL[impl])
            for r, x, y in zip(rs, xs, ys):
                ax.annotate(knob_label(impl, r["value"]), (x, y), fontsize=6, xytext=(3, 3),
                            textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # overlapping labels
        ax.set_xlabel("median time per query (ns)")
        ax.set_ylabel("max |depth − exact| / D(K)")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[0].legend(fontsize=7, loc="best")
    fig.suptitle("Penetration depth: worst error against median time (labels: each setting's tolerance)")
    save(fig, "depth_error_time.png")


class Report:
    def __init__(self, results, summary):
        self.dir = results
        self.summary = summary
        self.rel = os.path.relpath(results, os.path.dirname(os.path.abspath(summary)) or ".")
        # A folder filled by `bench/run.sh --only …` may lack other experiments' files: their
        # sections then say so instead of failing the whole report.
        self.machine = self.keyvalues("machine.csv")
        self.targets = []  # (target, measured, met)
        self.meta = self.keyvalues("paper_meta.csv")

    def keyvalues(self, name):
        if not os.path.exists(self.path(name)):
            return {}
        return {r["key"]: r["value"] for r in read(self.path(name))}

    def path(self, name):
        return os.path.join(self.dir, name)

    def link(self, name):
        return f"{self.rel}/{name}"

    def save(self, fig, name):
        fig.tight_layout()
        fig.savefig(self.path(name), dpi=110)
        plt.close(fig)
        return name

    # ------------------------------------------------------------------------------------------
    # (1) Section VII / Fig. 4
    def paper(self):
        cases = read(self.path("paper_cases.csv"))
        pairs = read(self.path("paper_pairs.csv"))
        meta = {r["key"]: r["value"] for r in read(self.path("paper_meta.csv"))}
        by = {(r["impl"], r["case"]): r for r in cases}
        md = []
        md.append(f"{meta['examples']} examples ({meta['poses_per_case']} poses per pair and case), "
                  f"{meta['rounds']} interleaved rounds; clock overhead {num(meta['clock_overhead_ns']):.0f} ns "
                  "subtracted from every query. Times are pooled over examples × rounds.\n\n")
        declined = [f"{LABEL[i]}: {by[(i, 'all')]['declined']}" for i in DISTANCE_IMPLS + YESNO_IMPLS
                    if (i, "all") in by and by[(i, "all")]["declined"]]
        if declined:
            md.append("Not measured: " + "; ".join(declined) + ".\n\n")

        md += self.paper_tables(by)
        self.paper_targets(by)
        pp = {(r["impl"], r["case"], int(r["pair"])): r for r in pairs}
        self.paper_pairs_page(pp, pairs)
        groups_md, wins, total = self.paper_groups(pp, pairs)
        with open(self.path("paper_groups.md"), "w") as f:
            f.write(groups_md)
        if total:
            self.targets.append((f"at or below the fastest of {' and '.join(LABEL[p] for p in FAST_PEERS)} "
                                 f"in every (pair, case) group ({LABEL[NEARPOINT_DEFAULT]})",
                                 f"{wins} of {total} groups", wins == total))

        plot_fig4(pairs, meta, self.save)
        md.append(f"\n![time vs M]({self.link('fig4_time_vs_M.png')})\n")
        md.append(f"\n![ns per vertex]({self.link('fig4_ns_per_vertex.png')})\n")
        md.append(f"\nPer (pair, case) group against the fastest peers: "
                  f"[{self.link('paper_groups.md')}]({self.link('paper_groups.md')}).\n")
        md.append(f"\nPer pair: [{self.link('paper_pairs.md')}]({self.link('paper_pairs.md')}); "
                  f"raw: `paper_cases.csv`, `paper_pairs.csv`.\n")
        return "".join(md)

    def paper_tables(self, by):
        """The pooled tables: times, speed ratios, accuracy, the yes/no query, the spread."""
        md = []
        md.append("**Distance queries: median / p99 ns per query**\n")
        rows = []
        for i in DISTANCE_IMPLS:
            rows.append([LABEL[i]] + [f"{ns(by[(i, c)]['median_ns'])} / {ns(by[(i, c)]['p99_ns'])}"
                                      for c in CASES + ["all"]])
        md.append(table(["implementation"] + CASES + ["all"], rows))

        md.append("\n**Speed ratio: the peer's median over nearpoint's (> 1: nearpoint faster)**\n")
        rows = []
        for np_impl in ["nearpoint_johnson", "nearpoint_signed_volumes"]:
            for peer in DISTANCE_PEERS:
                row = [f"{LABEL[peer]} / {LABEL[np_impl]}"]
                for c in CASES + ["all"]:
                    row.append(ratio(num(by[(peer, c)]["median_ns"]) / num(by[(np_impl, c)]["median_ns"])))
                rows.append(row)
        md.append(table(["ratio"] + CASES + ["all"], rows))

        md.append("\n**Accuracy against CGAL's exact distance** (max |d − d_exact|; wrong verdicts "
                  "are counted on separated and intersecting examples, whose truth has a margin; "
                  "bound violations: nearpoint's reported error bound below the true error)\n")
        rows = []
        for i in DISTANCE_IMPLS:
            r = [LABEL[i]] + [err(by[(i, c)]["max_error"]) for c in CASES]
            a = by[(i, "all")]
            r += [a["wrong_verdicts"], a["nans"], a["bound_violations"] if i.startswith("nearpoint") else "—",
                  "—" if math.isnan(num(a["mean_iterations"])) else f"{num(a['mean_iterations']):.2f}"]
            rows.append(r)
        md.append(table(["implementation"] + [f"max error {c}" for c in CASES]
                        + ["wrong verdicts", "NaNs", "bound violations", "mean iterations"], rows))

        md.append("\n**Yes/no intersection query: median / p99 ns** (wrong verdicts in brackets)\n")
        rows = []
        for i in YESNO_IMPLS:
            rows.append([LABEL[i]] + [f"{ns(by[(i, c)]['median_ns'])} / {ns(by[(i, c)]['p99_ns'])} "
                                      f"[{by[(i, c)]['wrong_verdicts']}]" for c in CASES + ["all"]])
        for np_impl in ["nearpoint_johnson_yesno", "nearpoint_signed_volumes_yesno"]:
            rows.append([f"ratio libccd / {LABEL[np_impl]}"] + [
                ratio(num(by[("ccd_intersect", c)]["median_ns"]) / num(by[(np_impl, c)]["median_ns"]))
                for c in CASES + ["all"]])
        md.append(table(["implementation"] + CASES + ["all"], rows))

        md.append("\n**Run-to-run spread**: the lowest and highest per-round median (ns), and their "
                  "difference relative to the pooled median\n")
        rows = []
        for i in DISTANCE_IMPLS + YESNO_IMPLS:
            rows.append([LABEL[i]] + [
                f"{ns(by[(i, c)]['round_median_min'])}–{ns(by[(i, c)]['round_median_max'])} "
                f"({num(by[(i, c)]['spread_pct']):.1f}%)" for c in CASES])
        md.append(table(["implementation"] + CASES, rows))
        return md

    def paper_targets(self, by):
        """Issue 25's targets on the pooled figures (added to self.targets)."""
        # Pooled, ≥ 1.5× the faster of openGJK and coal (tol 1e-12) in each
        # case, with the accuracy kept (the 5× FCL + libccd target is retired).
        for np_impl in ["nearpoint_johnson", "nearpoint_signed_volumes"]:
            fast = [p for p in FAST_PEERS if num(by.get((p, "all"), {}).get("median_ns")) == num(by.get((p, "all"), {}).get("median_ns"))]
            if not fast:
                continue
            ratios = {c: min(num(by[(p, c)]["median_ns"]) for p in fast) / num(by[(np_impl, c)]["median_ns"])
                      for c in CASES}
            max_error = max(num(by[(np_impl, c)]["max_error"]) for c in CASES)
            wrong = sum(int(by[(np_impl, c)]["wrong_verdicts"]) for c in CASES)
            nans = sum(int(by[(np_impl, c)]["nans"]) for c in CASES)
            bound = sum(int(by[(np_impl, c)]["bound_violations"]) for c in CASES)
            met = (all(r >= 1.5 for r in ratios.values()) and max_error <= 2e-14 and wrong == 0
                   and nans == 0 and bound == 0)
            measured = (", ".join(f"{c} {ratios[c]:.2f}×" for c in CASES)
                        + f"; max error {err(max_error)}; wrong verdicts {wrong}; NaNs {nans}; "
                        f"bound violations {bound}")
            self.targets.append((f"pooled ≥ 1.5× faster than the faster of {' and '.join(LABEL[p] for p in fast)} "
                                 f"in each case, max error ≤ 2e-14, no wrong verdict ({LABEL[np_impl]})",
                                 measured, met))
        for np_impl in ["nearpoint_johnson_yesno", "nearpoint_signed_volumes_yesno"]:
            ratios = {c: num(by[("ccd_intersect", c)]["median_ns"]) / num(by[(np_impl, c)]["median_ns"])
                      for c in CASES + ["all"]}
            wrong = int(by[(np_impl, "all")]["wrong_verdicts"])
            met = all(ratios[c] >= 2 for c in CASES) and wrong == 0
            measured = ", ".join(f"{c} {ratios[c]:.2f}×" for c in CASES + ["all"]) + f"; wrong verdicts {wrong}"
            self.targets.append((f"yes/no query ≥ 2× faster than ccdGJKIntersect in each case "
                                 f"({LABEL[np_impl]})", measured, met))

    def paper_pairs_page(self, pp, pairs):
        """paper_pairs.md: per pair and case, every implementation's median and nearpoint's details."""
        pm = ["# Section VII, per pair\n",
              "Median ns per query for each of the 20 pairs (sorted by M = M_A + M_B), then "
              "nearpoint Johnson's ns per vertex, mean iterations and the max error of nearpoint "
              "Johnson and FCL + libccd. Written by bench/tools/report.py from paper_pairs.csv.\n"]
        for c in CASES:
            pm.append(f"\n## {c}\n")
            keys = sorted({int(r["pair"]) for r in pairs}, key=lambda p: int(pp[("nearpoint_johnson", c, p)]["M"]))
            rows = []
            for p in keys:
                j = pp[("nearpoint_johnson", c, p)]
                row = [f"({j['polytope_a']},{j['polytope_b']})", j["M"]]
                row += [ns(pp[(i, c, p)]["median_ns"]) if (i, c, p) in pp else "—" for i in DISTANCE_IMPLS + YESNO_IMPLS]
                row += [f"{num(j['ns_per_vertex']):.1f}", f"{num(j['mean_iterations']):.2f}", err(j["max_error"]),
                        err(pp[("fcl_libccd", c, p)]["max_error"]) if ("fcl_libccd", c, p) in pp else "—"]
                rows.append(row)
            pm.append(table(["pair", "M"] + [LABEL[i] for i in DISTANCE_IMPLS + YESNO_IMPLS]
                            + ["Johnson ns/vertex", "Johnson iterations", "Johnson max error", "FCL libccd max error"], rows))
        with open(self.path("paper_pairs.md"), "w") as f:
            f.write("\n".join(pm))

    def paper_groups(self, pp, pairs):
        """The 60 (pair, case) groups: nearpoint's median against the fastest peer's."""
        present = [p for p in DISTANCE_PEERS if any(r["impl"] == p for r in pairs)]
        fast = [p for p in FAST_PEERS if p in present]
        out = ["# Section VII, per (pair, case) group: nearpoint against the fastest peer\n",
               f"Median ns per query over the group's examples × rounds (one interleaved run). "
               f"nearpoint: {LABEL[NEARPOINT_DEFAULT]} (the default), near points on. "
               f"'fastest target peer': the faster of {', '.join(LABEL[p] for p in fast) or '—'} "
               f"(issue 25's yardstick); 'fastest peer': any of {', '.join(LABEL[p] for p in present)}. "
               "ratio = peer / nearpoint (> 1: nearpoint faster). Written by bench/tools/report.py "
               "from paper_pairs.csv.\n"]
        wins = wins_all = total = 0
        rows = []
        for c in CASES:
            keys = sorted({int(r["pair"]) for r in pairs},
                          key=lambda p: (int(pp[(NEARPOINT_DEFAULT, c, p)]["M"]), p))
            for p in keys:
                n = pp[(NEARPOINT_DEFAULT, c, p)]
                t = num(n["median_ns"])

                def best(impls):
                    got = [(num(pp[(i, c, p)]["median_ns"]), i) for i in impls if (i, c, p) in pp]
                    got = [g for g in got if not math.isnan(g[0])]
                    return min(got) if got else (math.nan, None)
                tf, f = best(fast)
                ta, a = best(present)
                total += 1
                win = not math.isnan(tf) and t <= tf
                wins += win
                wins_all += not math.isnan(ta) and t <= ta
                rows.append([c, f"({n['polytope_a']},{n['polytope_b']})", n["M"], ns(t),
                             f"{ns(tf)} ({LABEL.get(f, '—')})", ratio(tf / t),
                             f"{ns(ta)} ({LABEL.get(a, '—')})", ratio(ta / t), "yes" if win else "**no**"])
        if not fast:  # neither openGJK nor coal measured: no yardstick, no target verdict
            total = 0
            out.append("\nopenGJK and coal were not measured in this run (see the summary's "
                       "'Not measured'): no target peer.\n")
        out.append(f"\nnearpoint at or below the fastest target peer in **{wins} of {total}** groups; "
                   f"at or below every peer in {wins_all} of {total}.\n")
        out.append(table(["case", "pair", "M", "nearpoint ns", "fastest target peer ns", "ratio",
                          "fastest peer ns", "ratio", "nearpoint ≤ target"], rows))
        return "\n".join(out), wins, total

    # ------------------------------------------------------------------------------------------
    # (6) Primitives (issue 25)
    def primitives(self):
        path = self.path("primitives.csv")
        if not os.path.exists(path):
            return "Not run.\n"
        rows_in = read(path)
        by = {(r["impl"], r["pair"], r["case"]): r for r in rows_in}
        groups = []
        for r in rows_in:
            if r["impl"] == "nearpoint" and (r["pair"], r["case"]) not in groups:
                groups.append((r["pair"], r["case"]))
        peers = ["fcl_libccd", "fcl_indep", "coal_1e-12", "coal_1e-6"]
        md = ["Median over 41 rounds of each block's mean ns per query (blocks timed whole after an untimed pass over the same block: these queries are too short for a clock read each; one interleaved run). nearpoint: GJK on support "
              "functions with near points and its certified error bound (a sphere is a point with a "
              "radius, a capsule a segment with one); FCL 0.7: `fcl::distance` on its own shapes with "
              "nearest points (it takes its specialised sphere–sphere, sphere–box, sphere–capsule and "
              "capsule–capsule routines; GJK otherwise); coal: `internal::ShapeShapeDistance` "
              "(specialised sphere–sphere, capsule–capsule, sphere–capsule, sphere–box; GJK on its "
              "shapes otherwise). 'hull24': the hull of 24 points on an ellipsoid. Ratio: the fastest "
              "of FCL and coal (tol 1e-12) over nearpoint (> 1: nearpoint faster; the target is ≥ 0.67, "
              "within 1.5×). Max |Δd|: the largest distance difference from nearpoint's answer.\n"]
        declined = sorted({f"{r['impl']}: {r['declined']}" for r in rows_in if r["declined"]})
        if declined:
            md.append("Not measured: " + "; ".join(declined) + ".\n")
        rows = []
        within = []
        for pair, case in groups:
            n = by[("nearpoint", pair, case)]
            t = num(n["median_ns"])
            row = [pair, case, n["examples"], f"{ns(t)} ({num(n['mean_iterations']):.2f} it.)"]
            best = math.nan
            for p in peers:
                r = by.get((p, pair, case))
                v = num(r["median_ns"]) if r else math.nan
                row.append(f"{ns(v)}" + (f" [{err(r['max_abs_diff_to_nearpoint'])}]" if r and not math.isnan(v) else ""))
                if p != "coal_1e-6" and not math.isnan(v):
                    best = v if math.isnan(best) else min(best, v)
            row.append(ratio(best / t))
            row.append(err(n["nearpoint_max_error_bound"]))
            rows.append(row)
            if pair in ("sphere-sphere", "capsule-capsule", "box-box"):
                within.append((f"{pair} {case}", best / t))
        md.append(table(["pair", "case", "examples", "nearpoint ns", "FCL libccd ns [max |Δd|]",
                         "FCL indep ns [max |Δd|]", "coal 1e-12 ns [max |Δd|]", "coal 1e-6 ns [max |Δd|]",
                         "fastest FCL/coal 1e-12 ÷ nearpoint", "nearpoint max error bound"], rows))
        if within:
            met = all(r >= 1 / 1.5 for _, r in within)
            self.targets.append(("primitives within 1.5× of FCL's and coal's specialised routines "
                                 "(sphere–sphere, capsule–capsule, box–box)",
                                 ", ".join(f"{g} {r:.2f}×" for g, r in within), met))
        return "\n".join(md)

    # ------------------------------------------------------------------------------------------
    # (2) Section VIII / Table I
    def table1(self):
        rows_in = read(self.path("table1.csv"))
        md = ["Total time for the distances to all five obstacles at s = t/T, t = 0 … T (5(T+1) "
              "compound queries), median over rounds; cold = single-point initialisation, warm = "
              "the previous step's simplex per piece pair. The paper's ratio (Harris 800) in the "
              "last column. Operations: support calls / subalgorithm runs per query, summed over "
              "the evaluated piece pairs. The ceiling is max(calls cold / calls warm, runs cold / "
              "runs warm): a query's time is the work outside the two operations plus calls·c_s + "
              "runs·c_r, so with each operation costing no less warm than cold (the same scans; "
              "warm runs are on the larger simplices) cold / warm cannot exceed it, whatever the "
              "costs.\n"]
        rows = []
        for r in rows_in:
            T = int(r["T"])
            rows.append([r["subalgorithm"], T, f"{num(r['cold_ms']):.3f} ({num(r['cold_ms_min']):.3f}–{num(r['cold_ms_max']):.3f})",
                         f"{num(r['warm_ms']):.3f} ({num(r['warm_ms_min']):.3f}–{num(r['warm_ms_max']):.3f})",
                         f"**{num(r['ratio']):.2f}**", f"{num(r['cold_mean_iterations']):.2f} / {num(r['warm_mean_iterations']):.2f}",
                         f"{100 * num(r['warm_started_fraction']):.0f}%", f"{num(r['pairs_evaluated_per_query']):.2f}",
                         err(r["max_abs_cold_warm_difference"]),
                         f"{num(r['cold_support_calls_per_query']):.2f} / {num(r['cold_subalgorithm_runs_per_query']):.2f}",
                         f"{num(r['warm_support_calls_per_query']):.2f} / {num(r['warm_subalgorithm_runs_per_query']):.2f}",
                         f"{num(r['operation_ceiling']):.2f}", PAPER_TABLE1.get(T, "—")])
        md.append(table(["subalgorithm", "T", "cold ms (min–max)", "warm ms (min–max)", "ratio",
                         "iterations cold / warm", "warm-started", "piece pairs per query",
                         "max \\|d_cold − d_warm\\|", "operations cold", "operations warm",
                         "ceiling", "paper"], rows))
        for method, label in (("signed_volumes", "signed volumes"), ("johnson", "Johnson")):
            at1000 = [r for r in rows_in if r["subalgorithm"] == method and int(r["T"]) == 1000]
            if at1000:
                q = num(at1000[0]["ratio"])
                ceiling = num(at1000[0]["operation_ceiling"])
                self.targets.append(("warm start ≥ 4× faster than cold on the Table I path at "
                                     f"T = 1000 (nearpoint {label})",
                                     f"{q:.2f}× (operation ceiling {ceiling:.2f}×)", q >= 4))

        plot_table1_distances(read(self.path("table1_distances.csv")), self.save)
        md.append(f"\n![distances along the path]({self.link('table1_distances.png')})\n")
        return "".join(md)

    # ------------------------------------------------------------------------------------------
    # (3) Error against run time
    def error_time(self):
        rows_in = read(self.path("error_time.csv"))
        impls = ["nearpoint_johnson", "nearpoint_signed_volumes", "fcl_libccd", "fcl_indep", "bullet"]
        md = ["Each implementation at each setting of its accuracy knob (nearpoint: ε of eq. (35) "
              "from 1e-2 to 1e-15 and its default, and iteration caps at the default ε; FCL: distance_tolerance; "
              "Bullet: the simplex solver's equal-vertex threshold, its only run-time knob). "
              "**Speed at a given accuracy**: the median ns of the loosest setting whose max error (and "
              "verdicts) reach the level, with that setting in brackets:\n"]
        levels = [1e-3, 1e-6, 1e-9, 2e-14]
        rows = []
        for i in impls:
            for c in CASES:
                cand = [r for r in rows_in if r["impl"] == i and r["case"] == c and r["knob"] != "max_iterations"
                        and not math.isnan(num(r["median_ns"]))]
                row = [LABEL[i], c]
                for level in levels:
                    ok = [r for r in cand if num(r["max_error"]) <= level and int(r["wrong_verdicts"]) == 0
                          and int(r["nans"]) == 0]
                    if ok:
                        # The loosest setting that reaches the level: looser settings stop earlier,
                        # and picking by measured time would pick noise among equal settings.
                        best = max(ok, key=lambda r: num(r["value"]))
                        row.append(f"{ns(best['median_ns'])} ({num(best['value']):.0e})")
                    else:
                        row.append("not reached")
                rows.append(row)
        md.append(table(["implementation", "case"] + [f"max error ≤ {lvl:g}" for lvl in levels], rows))

        violations = sum(int(r["bound_violations"]) for r in rows_in if r["impl"].startswith("nearpoint"))
        checked = sum(1 for r in rows_in if r["impl"].startswith("nearpoint"))
        md.append(f"\nnearpoint's reported error bound against the true error over all {checked} "
                  f"(setting, case) cells × examples: **{violations} violations**.\n")
        loose = [r for r in rows_in if r["impl"].startswith("nearpoint") and r["knob"] == "epsilon"
                 and int(r["wrong_verdicts"]) > 0]
        if loose:
            worst = max(loose, key=lambda r: num(r["value"]))
            tight = min(loose, key=lambda r: num(r["value"]))
            md.append(f"\nWith a loose ε nearpoint answers `separated` on intersecting pairs (its "
                      f"distance then lies within its error bound of 0, but the status does not say "
                      f"so): {len(loose)} (subalgorithm, ε, case) cells, from ε = {num(worst['value']):.0e} "
                      f"({worst['wrong_verdicts']} examples) down to ε = {num(tight['value']):.0e} "
                      f"({tight['wrong_verdicts']}). Capped runs carry the `iteration_limit` status "
                      "and are not counted as verdicts.\n")

        for c in CASES:
            plot_error_time(rows_in, impls, c, self.save)
            md.append(f"\n![error against time, {c}]({self.link(f'error_time_{c}.png')})\n")

        pts = read(self.path("error_bound_points.csv"))
        plot_error_bound(pts, violations, self.save)
        md.append(f"\n![error bound against true error]({self.link('error_bound.png')})\n")
        md.append("\nThe plot shows a sample per (setting, case): the 10 largest errors, the 10 "
                  "tightest bounds and 30 spread examples; the violation count covers every example.\n")
        return "".join(md)

    # ------------------------------------------------------------------------------------------
    # (4) Large polytopes
    def large(self):
        rows_in = read(self.path("large.csv"))
        series = [("nearpoint_signed_volumes", "cold"), ("nearpoint_signed_volumes", "warm"),
                  ("nearpoint_johnson", "cold"), ("nearpoint_johnson", "warm"),
                  ("nearpoint_signed_volumes_scan", "cold"), ("nearpoint_signed_volumes_scan", "warm"),
                  ("fcl_libccd", "cold"), ("fcl_indep", "cold"), ("bullet", "cold")]
        nearpoint_series = [s for s in series if s[0].startswith("nearpoint")]
        by = {(int(r["points"]), r["impl"], r["mode"]): r for r in rows_in}
        sizes = sorted({int(r["points"]) for r in rows_in})
        any_row = rows_in[0]
        md = [f"Hull of N random points on a unit sphere (A) against the hull of N points on an "
              f"ellipsoid with radii 1, 0.6, 0.35 (B) moving along a closed path in "
              f"{any_row['steps']} steps (separated, touching and intersecting: "
              f"{any_row['intersecting_steps']} of {any_row['exact_checked']} checked steps "
              f"intersect); median ns per query over the path × {any_row['rounds']} rounds. "
              "Warm: the cache of the previous step. nearpoint's polytopes come from "
              "`nearpoint::hull_polytope` (hull vertices and faces): from "
              "`Polytope::kHillClimbThreshold` = 64 vertices on, the support climbs the hull's edges, "
              "starting from the previous answer; the *linear scan* columns are the same queries on "
              "plain vertex lists. fcl::Convex walks the hull's edges above 32 vertices.\n"]
        rows = []
        for n in sizes:
            r0 = by[(n, "nearpoint_signed_volumes", "cold")]
            row = [f"{n:,}", f"{int(r0['hull_vertices_a']):,} / {int(r0['hull_vertices_b']):,}"]
            row += [ns(by[(n, i, m)]["median_ns"]) if (n, i, m) in by else "—" for i, m in series]
            row += [err(max(num(by[(n, i, m)]["max_error"]) for i, m in nearpoint_series if (n, i, m) in by))]
            rows.append(row)
        md.append(table(["N", "hull vertices A / B"] + [f"{LABEL[i]} {m}" for i, m in series]
                        + ["nearpoint max error"], rows))
        for impl in ("nearpoint_signed_volumes", "nearpoint_johnson"):
            if (1000, impl, "cold") in by:
                t = num(by[(1000, impl, "cold")]["median_ns"])
                self.targets.append((f"1000-vertex hull pairs < 1.5 µs cold ({LABEL[impl]}, hull "
                                     "climbing, median over the path)", f"{t / 1000:.2f} µs", t < 1500))
        plot_large(by, sizes, series, self.save)
        md.append(f"\n![large polytopes]({self.link('large_time_vs_vertices.png')})\n")
        return "".join(md)

    # ------------------------------------------------------------------------------------------
    # (5) Stability report
    def stability(self):
        rows_in = read(self.path("stability.csv"))
        variants = []
        for r in rows_in:
            v = (r["impl"], r["precision"])
            if v not in variants:
                variants.append(v)

        def vlabel(v):
            return f"{LABEL.get(v[0], v[0])} ({v[1]})" if v[0].startswith("nearpoint") else LABEL.get(v[0], v[0])

        families = []
        for r in rows_in:
            if r["family"] not in families:
                families.append(r["family"])

        def summary_rows(selected):
            out = []
            for v in variants:
                rs = [r for r in selected if (r["impl"], r["precision"]) == v]
                ran = [r for r in rs if r["outcome"] == "ran"]
                failed = Counter(r["outcome"] for r in rs if r["outcome"] not in ("ran", "not accepted"))
                declined = sum(1 for r in rs if r["outcome"] == "not accepted")
                errs = [(num(r["error"]), num(r["relative_error"]), r["case"]) for r in ran if not math.isnan(num(r["error"]))]
                worst = max(errs, default=(math.nan, math.nan, ""), key=lambda e: e[1])
                bounds = [num(r["error_bound"]) / num(r["size"]) for r in ran if not math.isnan(num(r["error_bound"]))]
                violations = sum(1 for r in ran if r["bound_holds"] == "NO")
                stated_fail = sum(1 for r in ran if r["within_stated"] == "NO")
                verdicts = Counter(r["verdict"] for r in ran)
                its = [int(r["iterations"]) for r in ran if int(r["iterations"]) >= 0]
                exits = Counter(r["exit"] for r in ran if r["exit"] != "-")
                out.append([
                    vlabel(v), f"{len(ran)}/{len(rs)}", declined or "", ", ".join(f"{k} {n}" for k, n in failed.items()) or "",
                    ("0" if worst[1] == 0 else f"{worst[1]:.1e} ({worst[2].split('/')[-1]})")
                    if not math.isnan(worst[1]) else "—",
                    f"{max(bounds):.1e}" if bounds else "—",
                    (f"{violations}" if bounds else "—"), (f"{stated_fail}" if v[0].startswith("nearpoint") else "—"),
                    verdicts.get("WRONG", 0),
                    f"{verdicts.get('within bound', 0)} / {verdicts.get('at contact', 0)}",
                    verdicts.get("NaN", 0),
                    f"{max(its)}" if its else "—",
                    ", ".join(f"{k} {n}" for k, n in sorted(exits.items())) or "—"])
            return out

        header = ["implementation", "ran", "not accepted", "crash / timeout", "worst error / size (case)",
                  "worst bound / size", "bound violations", "beyond stated accuracy", "wrong verdicts",
                  "within bound / at contact", "NaNs",
                  "max iterations", "exits"]
        sm = ["# Stability report: the stiff suite against CGAL's exact distance\n",
              "Written by bench/tools/report.py from `stability.csv` (bench/run.sh). Every case of "
              "tests/stiff/stiff_cases.hpp, each implementation in its own process with a time limit, "
              "against the exact distance of the very input it sees (float variants: the inputs "
              "rounded to float, truth recomputed). Errors are |d − d_exact|, relative to the "
              "case's size. Exits: DS / BP = eq. (35) or finite termination held with the last ν "
              "from the distance subalgorithm / the Backup Procedure; numerical limit = step 5; cap "
              "= iteration cap. Verdicts: *ok*; *within bound* = disagrees with the truth but the "
              "truth lies within the reported error bound (flagged honestly); *at contact* = the truth "
              "is within 1e-12·size of touching, where either verdict is defensible; *WRONG* = "
              "otherwise. Peers report no error bound, so only the contact allowance applies to "
              "them: a peer that answers within its own documented tolerance (FCL: 1e-6) but "
              "beyond 1e-12·size of the truth is counted WRONG. The stated accuracy is the test "
              "suite's (1e-12·size in double, 2e-4·size in float). Each cell: error (≤ reported bound), "
              "iterations, exit, one query's time (µs, second call, not a benchmark), verdict when "
              "not ok.\n",
              "\n## All families\n", table(header, summary_rows(rows_in))]
        for fam in families:
            sel = [r for r in rows_in if r["family"] == fam]
            sm.append(f"\n## {fam}\n")
            sm.append(table(header, summary_rows(sel)))
            cases = []
            for r in sel:
                if r["case"] not in cases:
                    cases.append(r["case"])
            rows = []
            for c in cases:
                rs = {(r["impl"], r["precision"]): r for r in sel if r["case"] == c}
                first = next(iter(rs.values()))
                row = [c.split("/", 1)[1], f"{num(first['truth_distance']):.3g}"]
                row += [stability_cell(rs.get(v), v) for v in variants]
                rows.append(row)
            sm.append("\n" + table(["case", "truth"] + [vlabel(v) for v in variants], rows))
        with open(self.path("stability.md"), "w") as f:
            f.write("\n".join(sm))

        md = ["Every case of the stiff suite (tests/stiff/stiff_cases.hpp) against CGAL's exact "
              f"distance; the full report per family and case is [{self.link('stability.md')}]"
              f"({self.link('stability.md')}).\n\n", table(header, summary_rows(rows_in))]
        return "".join(md)

    # ------------------------------------------------------------------------------------------
    # (7) Penetration depth (issue 31)
    def depth(self):
        if not os.path.exists(self.path("depth.csv")):
            return "Not run (`bench/run.sh --only depth`).\n"
        rows_in = read(self.path("depth.csv"))
        meta = {r["key"]: r["value"] for r in read(self.path("depth_meta.csv"))}
        run = {}
        if os.path.exists(self.path("run_depth.csv")):
            run = {r["key"]: r["value"] for r in read(self.path("run_depth.csv"))}
        counts = {r["set"]: r["cases"] for r in rows_in if r["impl"] == "nearpoint"}
        md = []
        if run:
            md.append(f"Run on its own: `{run.get('command', '?')}` at commit {run.get('commit', '?')} "
                      f"(working tree {run.get('working_tree', '?')}), {run.get('date', '?')}, "
                      f"{run.get('seconds', '?')} s; load average before / after "
                      f"{run.get('load_before', '?')} / {run.get('load_after', '?')} (2 shared cores).\n\n")
        md.append(f"{meta['cases']} cases ({', '.join(f'{k} {v}' for k, v in counts.items())}), "
                  f"{meta['rounds']} interleaved rounds, the exact depth of every case from CGAL's exact "
                  f"hull of all vertex differences ({num(meta['oracle_seconds']):.0f} s). "
                  "Errors are |depth − exact| / D, D = D(K) of eq. (37) (the same D for every "
                  "implementation). nearpoint's interval [depth_lower, depth_upper] is checked exactly "
                  "against the exact depth, and its signed-distance interval against the exact signed distance (the exact distance when separated). *missed*: the exact depth exceeds the setting's tolerance·D "
                  "but the answer is 0 (no penetration). *failed*: NaN, FCL's EPA throwing, or a query that "
                  "aborted the process (an assertion in Debian's libfcl) or did not return within 0.5 s "
                  "(libccd's EPA has no iteration cap); such cases are screened in a child process "
                  "first, then skipped and counted. Each setting runs on every case; times are medians "
                  "over cases × rounds.\n\n")
        declined = sorted({f"{DEPTH_LABEL.get(r['impl'], r['impl'])} {knob_label(r['impl'], r['value'])}: {r['declined']}"
                           for r in rows_in if r["declined"]})
        if declined:
            md.append("Not measured: " + "; ".join(declined) + ".\n\n")
        for key, title in DEPTH_SETS:
            rows = []
            for r in rows_in:
                if r["set"] != key or r["declined"]:
                    continue
                failed = int(r["nans"]) + int(r["threw"]) + int(r["hung"]) + int(r["aborted"])
                fail_note = []
                for col, word in (("threw", "threw"), ("aborted", "aborted"), ("hung", "hung"), ("nans", "NaN")):
                    if int(r[col]):
                        fail_note.append(f"{r[col]} {word}")
                near = r["impl"] == "nearpoint"
                rows.append([DEPTH_LABEL.get(r["impl"], r["impl"]), knob_label(r["impl"], r["value"]),
                             ns(r["median_ns"]), ns(r["p99_ns"]), err(r["max_rel_error"]),
                             err(r["median_rel_error"]), r["missed"],
                             ", ".join(fail_note) if failed else "0",
                             f"{r['violations']} / {r['signed_violations']}" if near else "—",
                             err(r["max_rel_width"]) if near else "—",
                             r["wider_than_1e-12"] if near else "—",
                             err(r["max_rel_signed_width"]) if near else "—",
                             r["capped"]])
            md.append(f"\n**{title}** ({counts.get(key, '?')} cases)\n\n")
            md.append(table(["implementation", "tolerance", "median", "p99", "max error / D", "median error / D",
                             "missed", "failed", "violations: depth / signed", "max width / D",
                             "width > 1e-12·D", "signed-distance width / D", "capped"], rows))
        # The stiff sweep by contact kind and by size: where each implementation's worst errors are.
        cases = read(self.path("depth_cases.csv"))
        picks = [("nearpoint", "default"), ("coal_epa", "1e-06"), ("coal_epa", "1e-12"),
                 ("fcl_libccd_epa", "1e-06"), ("fcl_libccd_mpr", "1e-06"), ("libccd_epa", "1e-04"),
                 ("bullet_gjkepa2", "fixed")]
        kinds = ["face_face", "edge_edge", "vertex_face", "identical", "nested"]
        sizes = sorted({num(r["size"]) for r in cases})
        rows = []
        for impl, knob in picks:
            mine = [r for r in cases if r["impl"] == impl and knob_label(impl, r["value"]) == knob]
            if not mine:
                continue

            def worst(sel):
                errs = [num(r["rel_error"]) for r in sel if not math.isnan(num(r["rel_error"]))]
                return err(max(errs)) if errs else "—"
            rows.append([f"{DEPTH_LABEL[impl]} {knob}"]
                        + [worst([r for r in mine if r["group"] == k]) for k in kinds]
                        + [worst([r for r in mine if num(r["size"]) == z]) for z in sizes])
        md.append("\n**Stiff sweep (both offsets): max error / D by contact kind and by size** (cases that "
                  "failed are not in these maxima; see the tables above)\n\n")
        md.append(table(["implementation, tolerance"] + kinds + [f"size {z:g}" for z in sizes], rows))
        plot_depth(rows_in, self.save)
        md.append(f"\n![depth error against time]({self.link('depth_error_time.png')})\n")
        md.append("\nPer stiff case (kind, size, offset, depth) and setting: `depth_cases.csv`; every "
                  "interval violation with its input in hex floats: `depth_violations.csv`.\n")

        # Targets of issue 31.
        near = [r for r in rows_in if r["impl"] == "nearpoint"]
        violations = sum(int(r["violations"]) for r in near)
        signed = sum(int(r["signed_violations"]) for r in near)
        self.targets.append(("depth: the exact depth inside nearpoint's certified interval on every case "
                             "(all tolerances, all sets; and the exact signed distance inside its interval)",
                             f"{violations} depth / {signed} signed-distance violations",
                             violations == 0 and signed == 0))
        default = [r for r in near if knob_label("nearpoint", r["value"]) == "default"]
        if default:
            wmax = max(num(r["max_rel_width"]) for r in default)
            wide = sum(int(r["wider_than_1e-12"]) for r in default)
            self.targets.append(("depth: interval width ≤ 1e-12·D on polytope pairs at the default tolerance",
                                 f"max {wmax:.2g}·D, {wide} cases wider", wide == 0))
            contact = [r for r in default if r["set"] != "paper_intersecting"]
            swidth = max(num(r["max_rel_signed_width"]) for r in contact)
            self.targets.append(("depth: signed-distance intervals near contact ≤ 1e-13·D wide on polytope pairs "
                                 "(the paper's touching pairs and the stiff sweeps, default tolerance)",
                                 f"max {swidth:.2g}·D", swidth <= 1e-13))
            pi = {(r["impl"], knob_label(r["impl"], r["value"])): r for r in rows_in
                  if r["set"] == "paper_intersecting" and not r["declined"]}
            mine = pi.get(("nearpoint", "default"))
            coal = pi.get(("coal_epa", "1e-06"))
            if mine and coal:
                t_me, t_coal = num(mine["median_ns"]), num(coal["median_ns"])
                e_me, e_coal = num(mine["max_rel_error"]), num(coal["max_rel_error"])
                gain = e_coal / max(e_me, ERROR_FLOOR)
                self.targets.append(("depth: faster than coal's EPA at tolerance 1e-6 on the paper's intersecting "
                                     "pairs while 10⁶× more accurate (median time; max error / D)",
                                     f"{t_me:.0f} ns vs {t_coal:.0f} ns ({t_coal / t_me:.2f}×); max error "
                                     f"{e_me:.1e} vs {e_coal:.1e} ({gain:.1e}×)",
                                     t_me < t_coal and gain >= 1e6))
        return "".join(md)

    # ------------------------------------------------------------------------------------------
    def write(self):
        m = self.machine
        sections = [("Section VII / Fig. 4: the 6000 examples", self.paper),
                    ("Section VIII / Table I: warm start along a path", self.table1),
                    ("Error against run time", self.error_time),
                    ("Large polytopes", self.large),
                    ("Stability report (issue 4)", self.stability),
                    ("Primitives against specialised routines (issue 25)", self.primitives),
                    ("Penetration depth against the exact depth (issue 31)", self.depth)]
        def body(fn):
            try:
                return fn()
            except FileNotFoundError as missing:
                return f"Not run in this results folder ({os.path.basename(missing.filename)} is missing).\n"
        bodies = [(title, body(fn)) for title, fn in sections]
        seconds = {k[len("seconds_"):]: v for k, v in m.items() if k.startswith("seconds_")}
        out = ["# nearpoint benchmarks: results\n",
               "Written by `bench/tools/report.py` from the CSV files of one run of "
               f"`{m.get('command', 'bench/run.sh')}`; every figure below comes from that run.\n",
               table(["", ""], [
                   ["machine", f"{m.get('cpu', '?')}, {m.get('cores', '?')} cores (shared with other "
                               "users' compilations: see the load)"],
                   ["kernel / compiler", f"{m.get('kernel', '?')} / {m.get('compiler', '?')}"],
                   ["nearpoint compiled for", m.get("arch", "portable")],
                   ["date (UTC)", m.get("date", "?")],
                   ["commit", f"{m.get('commit', '?')} (working tree {m.get('working_tree', '?')})"],
                   ["command", f"`{m.get('command', '?')}`"],
                   ["run time", f"{m.get('total_seconds', '?')} s in all (build {m.get('build_seconds', '?')} s; "
                                + ", ".join(f"{k} {v} s" for k, v in seconds.items()) + ")"],
                   ["load average before / after", f"{m.get('load_before', '?')} / {m.get('load_after', '?')}"],
               ]),
               "\nPeers: FCL 0.7 (`fcl::Convex` from CGAL hulls, `fcl::distance` with nearest points, "
               "solvers GST_LIBCCD and GST_INDEP, default tolerance 1e-6), Bullet 3.24 double precision "
               "(`btGjkPairDetector` + `btVoronoiSimplexSolver` on `btConvexHullShape`, margins 0, no "
               "penetration solver), libccd 2.1 double (`ccdGJKIntersect`, max_iterations 1000), "
               "openGJK 174d3aa (scalar, double, `compute_minimum_distance` on vertices posed in the "
               "call), coal cf75966 (`GJKSolver::shapeDistance` on `coal::Convex<coal::Triangle>` "
               "from the hulls, GJK only, tolerance 1e-12 and 1e-6; openGJK and coal built from "
               "the snapshots of bench/README.md, 'Peers built from source', when given: see "
               "'Not measured' below). "
               f"nearpoint runs with its defaults (ε = {num(self.meta.get('default_epsilon')):.3g}, "
               f"max_iterations {self.meta.get('default_max_iterations', '?')}), near points on, and "
               "both subalgorithms are measured (the engine's default is "
               f"{self.meta.get('default_subalgorithm', '?').replace('_', ' ')}).\n",
               "\n## Targets (issues 3, 25 and 31)\n"]
        rows = [[t, mv, "**met**" if ok else "**not met**"] for t, mv, ok in self.targets]
        out.append(table(["target", "measured", "verdict"], rows))
        for title, body in bodies:
            out.append(f"\n## {title}\n\n{body}")
        with open(self.summary, "w") as f:
            f.write("\n".join(out))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", required=True)
    parser.add_argument("--summary", required=True)
    args = parser.parse_args()
    Report(args.results, args.summary).write()


if __name__ == "__main__":
    main()
