# SPDX-License-Identifier: MIT
"""The two sweep engines compared (issue 22): the same scenes swept with
``--engine scene`` (the reference) and ``--engine batched``.

  python -m mstc.bench.agreement runs DIR_SCENE DIR_BATCHED
      every row of the two runs.csv and every events.json, family by family:
      rows alike (all but the measured step_us), events.json alike, and the
      verdicts the issue names (events: kind, obstacle, side, order;
      contact; D_s kept; rejoined); every difference listed
  python -m mstc.bench.agreement poses --lib LIB SCENARIO...
      the robot's pose at every step of each scenario under both engines
      (paper and mstc): the largest difference [m]

A check, not a benchmark: it prints figures and exits 1 when they differ
beyond the issue's bounds (99.9 % of runs alike in events and verdicts;
poses within 1e-9 m).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

from mstc.can.protocol import wire_limits
from mstc.firmware.sil import SilBatch, SilController
from mstc.loop.batched import BatchStep, simulate_batch
from mstc.loop.lockstep import simulate
from mstc.model import Strategy
from mstc.plant.scenario import load_scenario

MEASURED = ("step_us",)
VERDICTS = ("contact", "ds_kept", "rejoined")


def _rows(folder: Path) -> dict[tuple[str, str], dict[str, str]]:
    with (folder / "runs.csv").open(newline="") as f:
        return {(r["scene"], r["strategy"]): r for r in csv.DictReader(f)}


def _events(folder: Path, strategy: str, scene: str) -> str | None:
    path = folder / strategy / scene / "events.json"
    return path.read_text() if path.is_file() else None


def _sequence(text: str | None) -> list[tuple[object, ...]]:
    if text is None:
        return []
    return [(e["event"], e["obstacle"], e.get("side")) for e in json.loads(text)["events"]]


def compare_runs(scene_dir: Path, batched_dir: Path) -> int:
    """Print the agreement of two sweeps; 1 when below the issue's bound."""
    ref, got = _rows(scene_dir), _rows(batched_dir)
    if set(ref) != set(got):
        print(f"the sweeps ran different jobs: {len(set(ref) ^ set(got))} not in both")
        return 1
    tally: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))
    differences = []
    for key in sorted(ref):
        a, b = ref[key], got[key]
        fam = f"{a['family']} {a['strategy']}"
        t = tally[fam]
        t["runs"] += 1
        ea, eb = _events(scene_dir, key[1], key[0]), _events(batched_dir, key[1], key[0])
        columns = [c for c in a if c not in MEASURED and a[c] != b[c]]
        same_events = _sequence(ea) == _sequence(eb)
        same_verdicts = all(a[c] == b[c] for c in VERDICTS)
        t["rows alike"] += not columns
        t["events.json alike"] += ea == eb
        t["events and verdicts alike"] += same_events and same_verdicts
        if columns or ea != eb:
            what = ", ".join(f"{c} {a[c]!r} → {b[c]!r}" for c in columns)
            if ea != eb:
                what += ("; " if what else "") + (
                    "event times or min_distance differ" if same_events else "events differ"
                )
            differences.append(f"{key[0]} ({key[1]}): {what}")
    heads = ("runs", "rows alike", "events.json alike", "events and verdicts alike")
    print("| family strategy | " + " | ".join(heads) + " |")
    print("|---|" + "---:|" * len(heads))
    total: dict[str, int] = defaultdict(int)
    for fam, t in tally.items():
        print(f"| {fam} | " + " | ".join(f"{t[h]:,}" for h in heads) + " |")
        for h in heads:
            total[h] += t[h]
    print("| all | " + " | ".join(f"{total[h]:,}" for h in heads) + " |")
    share = total["events and verdicts alike"] / max(1, total["runs"])
    print(f"\nevents and verdicts alike in {100 * share:.3f} % of runs (bound: 99.9 %)")
    print(f"{len(differences)} runs differ in any column or events.json:")
    for line in differences:
        print(f"- {line}")
    return 0 if share >= 0.999 else 1


def compare_poses(lib: str, paths: list[Path]) -> int:
    """Print the largest pose difference between the engines over each run."""
    worst = 0.0
    for path in paths:
        scenario = load_scenario(path, wire_limits())
        for strategy in ("paper", "mstc"):
            s = dataclasses.replace(
                scenario, params=dataclasses.replace(scenario.params, strategy=Strategy(strategy))
            )
            trace = simulate(s, SilController(s.params, lib)).trace
            poses: list[tuple[float, float]] = []

            def keep(step: BatchStep, poses: list[tuple[float, float]] = poses) -> None:
                poses.append((float(step.x[0]), float(step.y[0])))

            simulate_batch((s,), SilBatch([s.params], lib), keep)
            xy = np.array(poses)
            d = float(np.hypot(xy[:, 0] - trace["x"], xy[:, 1] - trace["y"]).max())
            worst = max(worst, d)
            print(f"{path.name} {strategy}: {len(xy)} steps, largest pose difference {d:.3g} m")
    print(f"largest: {worst:.3g} m (bound: 1e-9 m)")
    return 0 if worst <= 1e-9 else 1


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m mstc.bench.agreement", description=__doc__.splitlines()[0]
    )
    sub = ap.add_subparsers(dest="cmd", required=True)
    runs = sub.add_parser("runs")
    runs.add_argument("scene_dir", type=Path)
    runs.add_argument("batched_dir", type=Path)
    poses = sub.add_parser("poses")
    poses.add_argument("--lib", required=True)
    poses.add_argument("scenarios", type=Path, nargs="+")
    a = ap.parse_args(argv)
    if a.cmd == "runs":
        return compare_runs(a.scene_dir, a.batched_dir)
    return compare_poses(a.lib, a.scenarios)


if __name__ == "__main__":
    sys.exit(main())
