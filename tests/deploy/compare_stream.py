#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Checks a streamed trajectory's reports against the engine run locally (`nearpoint distance`).

    compare_stream.py --scene S.json --trajectory T.jsonl --reports R.jsonl --nearpoint BIN

S is a scene file with single-piece geometries (the SHAPE syntax), T a JSON Lines trajectory
({"poses": {OBJECT: POSE}} per step; objects not named keep their last pose), R what
`nearpoint stream SCENE T --json` printed. Every step must have exactly one report, in order
(sequence 1, 2, ...), covering every pair of the scene's objects, each with the distance the
local engine gives for the same shapes and poses, within the two error bounds (plus 1e-12).
deploy/test-container.sh runs it on the reports of the image's nearpointd; exit 0 when all agree.
"""
import argparse
import itertools
import json
import subprocess
import sys


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--scene", required=True)
    parser.add_argument("--trajectory", required=True)
    parser.add_argument("--reports", required=True)
    parser.add_argument("--nearpoint", required=True)
    args = parser.parse_args()

    with open(args.scene) as f:
        scene = json.load(f)
    with open(args.trajectory) as f:
        steps = [json.loads(line) for line in f if line.strip()]
    with open(args.reports) as f:
        reports = [json.loads(line) for line in f if line.strip()]

    geometry = {o["id"]: scene["geometries"][o["geometry"]] for o in scene["objects"]}
    pose = {o["id"]: o.get("pose", {}) for o in scene["objects"]}
    ids = [o["id"] for o in scene["objects"]]
    if scene.get("pairs", "all") != "all":
        print("compare_stream: only scenes with \"pairs\": \"all\" are supported")
        return 1

    # One `nearpoint distance` line per step and pair, in report order.
    lines, keys = [], []
    for step_index, step in enumerate(steps):
        pose.update(step["poses"])
        for a, b in itertools.combinations(ids, 2):
            lines.append(json.dumps({"id": f"{step_index}:{a}:{b}",
                                     "a": {**geometry[a], "pose": pose[a]},
                                     "b": {**geometry[b], "pose": pose[b]}}))
            keys.append((step_index, a, b))
    local = subprocess.run([args.nearpoint, "distance"], input="\n".join(lines) + "\n",
                           stdout=subprocess.PIPE, text=True, check=True, timeout=60)
    expected = {}
    for key, line in zip(keys, local.stdout.splitlines()):
        result = json.loads(line)
        if result["status"] == "error":
            print(f"compare_stream: the local engine refused {key}: {result['message']}")
            return 1
        expected[key] = result

    failures = []
    if len(reports) != len(steps):
        failures.append(f"{len(reports)} reports for {len(steps)} steps")
    checked = 0
    for step_index, report in enumerate(reports[:len(steps)]):
        if report.get("sequence") != step_index + 1 or "error" in report:
            failures.append(f"report {step_index}: sequence {report.get('sequence')}, "
                            f"error {report.get('error')}")
            continue
        seen = set()
        for pair in report["pairs"]:
            a, b = pair["object_a"], pair["object_b"]
            key = (step_index, a, b) if (step_index, a, b) in expected else (step_index, b, a)
            if key not in expected or "distance" not in pair:
                failures.append(f"report {step_index}: unexpected pair {pair}")
                continue
            seen.add(key)
            want = expected[key]
            tolerance = pair["error_bound"] + want["error_bound"] + 1e-12
            if abs(pair["distance"] - want["distance"]) > tolerance:
                failures.append(f"step {step_index} {a}-{b}: streamed {pair['distance']!r}, "
                                f"local {want['distance']!r} (tolerance {tolerance:.3g})")
            checked += 1
        missing = {k for k in expected if k[0] == step_index} - seen
        if missing:
            failures.append(f"report {step_index}: pairs missing: {sorted(missing)}")

    for failure in failures[:20]:
        print("FAIL", failure)
    if failures:
        return 1
    print(f"compare_stream: {len(reports)} reports, {checked} pair distances agree with the "
          f"local engine within their error bounds")
    return 0


if __name__ == "__main__":
    sys.exit(main())
