# SPDX-License-Identifier: MIT
"""Sweep throughput: scene-steps per second in memory, a 1,000-scene sweep
on every core, and the same sweep on a local Dask cluster.

  sweep_bench.py run --lib build/host/float/libmstc_sil.so --out build/bench/sweep.json
  sweep_bench.py report --doc docs/performance.md build/bench/sweep.json

A benchmark, not a test: it prints and writes figures and fails on nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from report import update_doc  # tools/bench/report.py, beside this script

from mstc.firmware import SilController
from mstc.sim.run import simulate
from mstc.sim.scenario import load_scenario
from mstc.sweep.engine import Scene, run_sweep
from mstc.sweep.suite import generate, load_suite

ROOT = Path(__file__).resolve().parents[2]
LINE = ROOT / "sim" / "scenarios" / "paper-line.toml"
BEGIN = "<!-- bench:sweep:begin (written by make bench, tools/bench/sweep_bench.py) -->"
END = "<!-- bench:sweep:end -->"
# Paper-like scenes: a straight reference at about the paper's speed, two
# obstacles near it, 20 s at 50 Hz (1,001 steps), Table 1, forward Euler.
PAPER_LIKE = """\
[suite]
name = "paper-like"
dt = 0.02
integrator = "euler"

[family.paper_like]
kind = "isolated"
count = {count}
seed = 42
duration = 20.0
obstacles = [2, 2]
along = [2.0, 8.0]
lateral = [-0.4, 0.4]
"""


def steps_per_second(lib: str, runs: int) -> dict[str, float]:
    """The paper's line scene (2 obstacles, 1,001 steps) run in memory in this
    process, @p runs times: median steps per second, wall and CPU time."""
    scenario = load_scenario(LINE)
    wall, cpu = [], []
    for _ in range(runs):
        ctl = SilController(scenario.params, lib)
        t0, c0 = time.perf_counter(), time.process_time()
        simulate(scenario, ctl)
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    steps = scenario.sim.steps + 1
    return {
        "steps": steps,
        "wall": steps / statistics.median(wall),
        "cpu": steps / statistics.median(cpu),
    }


def _scenes(count: int, folder: Path) -> list[Scene]:
    suite_path = folder / "paper-like.toml"
    suite_path.write_text(PAPER_LIKE.format(count=count))
    files = generate(load_suite(suite_path), folder / "scenes")
    return [Scene.from_file(f.path) for f in files]


def _reproducible(out: Path) -> list[list[str]]:
    """runs.csv without the measured step cost."""
    rows = [line.split(",") for line in (out / "runs.csv").read_text().splitlines()]
    drop = rows[0].index("step_us")
    return [r[:drop] + r[drop + 1 :] for r in rows]


def sweep_times(lib: str, count: int, workers: int) -> dict[str, float]:
    """@p count paper-like scenes with the paper's strategy: wall time on a
    process pool of @p workers, then on a local Dask cluster of as many
    single-threaded worker processes (started before the clock runs)."""
    from distributed import LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        scenes = _scenes(count, folder)
        t0 = time.perf_counter()
        run_sweep(scenes, ["paper"], folder / "pool", lib, workers=workers)
        pool = time.perf_counter() - t0
        with LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster:
            t0 = time.perf_counter()
            address = cluster.scheduler_address
            run_sweep(scenes, ["paper"], folder / "dask", lib, workers=workers, scheduler=address)
            dask = time.perf_counter() - t0
        same = _reproducible(folder / "pool") == _reproducible(folder / "dask")
    return {"scenes": count, "workers": workers, "pool_s": pool, "dask_s": dask, "same_rows": same}


def section(r: dict[str, object]) -> str:
    rate = r["rate"]
    sw = r["sweep"]
    assert isinstance(rate, dict) and isinstance(sw, dict)
    overhead = (sw["dask_s"] / sw["pool_s"] - 1.0) * 100.0
    per_scene = sw["pool_s"] / sw["scenes"] * sw["workers"]
    lines = [
        "## Sweeps: scenes through the control step in memory",
        "",
        f"Measured on {r['cpus']} cores (load average {r['load']} at the start: the figures "
        "are only as quiet as the machine was). `make bench` runs "
        "`tools/bench/sweep_bench.py`.",
        "",
        "| measure | figure | target |",
        "|---|---:|---|",
        f"| scene-steps per second, one process (paper-line: 2 obstacles, 50 Hz, "
        f"{rate['steps']} steps; median of {r['runs']} runs, wall time) | "
        f"**{rate['wall']:,.0f}** | ≥ 40,000: {'met' if rate['wall'] >= 40000 else 'not met'} |",
        f"| the same, CPU time of the process | {rate['cpu']:,.0f} | — |",
        f"| sweep of {sw['scenes']:,} paper-like scenes of 20 s (2 obstacles, strategy paper), "
        f"process pool of {sw['workers']} | **{sw['pool_s']:.1f} s** "
        f"({per_scene * 1000:.0f} ms of a core per scene) | ≤ 30 s: "
        f"{'met' if sw['pool_s'] <= 30 else 'not met'} |",
        f"| the same sweep on a local Dask cluster of {sw['workers']} single-threaded workers "
        f"| **{sw['dask_s']:.1f} s** ({overhead:+.1f} % against the pool) | overhead ≤ 10 %: "
        f"{'met' if overhead <= 10 else 'not met'} |",
        "",
        "The sweep times leave out writing the scene files (done first) and include "
        "starting the pool's workers, writing every events.json and runs.csv; the Dask "
        f"cluster is started before the clock runs, as a real one would be. Rows alike in "
        f"both: {'yes' if sw['same_rows'] else 'NO'}.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    run = sub.add_parser("run")
    run.add_argument("--lib", required=True)
    run.add_argument("--out", type=Path, required=True)
    run.add_argument("--runs", type=int, default=7)
    run.add_argument("--scenes", type=int, default=1000)
    run.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    rep = sub.add_parser("report")
    rep.add_argument("--doc", type=Path, required=True)
    rep.add_argument("result", type=Path)
    a = ap.parse_args(argv)
    if a.cmd == "run":
        lib = str(Path(a.lib).resolve())
        result = {
            "cpus": os.cpu_count(),
            "load": f"{os.getloadavg()[0]:.1f}",
            "runs": a.runs,
            "rate": steps_per_second(lib, a.runs),
            "sweep": sweep_times(lib, a.scenes, a.workers),
        }
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps(result, indent=1) + "\n")
        print(section(result))
        return 0
    body = section(json.loads(a.result.read_text()))
    update_doc(a.doc, body, BEGIN, END)
    print(body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
