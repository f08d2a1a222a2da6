# SPDX-License-Identifier: MIT
"""Sweep throughput: scene-steps per second in memory, a 1,000-scene sweep
on every core, and the same sweep on a local Dask cluster.

  python -m mstc.bench.sweep run --lib build/host/float/libmstc_sil.so --out build/bench/sweep.json
  python -m mstc.bench.sweep report --doc docs/performance.md build/bench/sweep.json

A benchmark, not a test: it prints and writes figures and fails on nothing.
Beside each wall time it gives the CPU time of every process that did the
work (this one, the pool's workers, the Dask scheduler and workers): on a
machine shared with other work, wall time counts the waits for a core and
CPU time does not, so CPU time is the fair figure of the work itself.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

from mstc.bench import ROOT
from mstc.bench.doc import report, write_result
from mstc.can.protocol import wire_limits
from mstc.firmware.sil import SilController
from mstc.loop.lockstep import simulate
from mstc.plant.scenario import load_scenario
from mstc.sweep.engine import Scene, run_sweep
from mstc.sweep.suite import generate, load_suite

LINE = ROOT / "sim" / "scenarios" / "paper-line.toml"
BEGIN = "<!-- bench:sweep:begin (written by make bench, mstc.bench.sweep) -->"
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
    scenario = load_scenario(LINE, wire_limits())
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


def process_cpu() -> float:
    """CPU time (user + system) of this process so far [s] (also run on
    each Dask worker)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def children_cpu() -> float:
    """CPU time of this process's children that have ended and been waited
    for (the pool's workers, after the pool shut down) [s]."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _reproducible(out: Path) -> list[list[str]]:
    """runs.csv without the measured step cost."""
    rows = [line.split(",") for line in (out / "runs.csv").read_text().splitlines()]
    drop = rows[0].index("step_us")
    return [r[:drop] + r[drop + 1 :] for r in rows]


def sweep_times(lib: str, count: int, workers: int, repeats: int) -> dict[str, object]:
    """@p count paper-like scenes with the paper's strategy, @p repeats
    times in turn on a process pool of @p workers and on a local Dask cluster
    of as many single-threaded worker processes (started once, before the
    clocks run): the median wall and CPU time of each. CPU time: this process
    (the client, and the Dask scheduler, which a LocalCluster runs here) plus
    the pool's workers or the Dask workers."""
    from distributed import Client, LocalCluster

    pool: list[tuple[float, float]] = []
    dask: list[tuple[float, float]] = []
    with (
        tempfile.TemporaryDirectory() as tmp,
        LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        folder = Path(tmp)
        scenes = _scenes(count, folder)
        address = cluster.scheduler_address
        for i in range(repeats):
            t0, c0, k0 = time.perf_counter(), process_cpu(), children_cpu()
            run_sweep(scenes, ["paper"], folder / f"pool{i}", lib, workers=workers)
            pool.append((time.perf_counter() - t0, process_cpu() - c0 + children_cpu() - k0))
            w0 = sum(client.run(process_cpu).values())
            t0, c0 = time.perf_counter(), process_cpu()
            run_sweep(
                scenes, ["paper"], folder / f"dask{i}", lib, workers=workers, scheduler=address
            )
            wall, cpu = time.perf_counter() - t0, process_cpu() - c0
            dask.append((wall, cpu + sum(client.run(process_cpu).values()) - w0))
        rows = _reproducible(folder / "pool0")
        same = all(
            _reproducible(folder / f"{kind}{i}") == rows
            for kind in ("pool", "dask")
            for i in range(repeats)
        )
    return {
        "scenes": count,
        "workers": workers,
        "repeats": repeats,
        "pool_s": statistics.median(w for w, _ in pool),
        "pool_cpu_s": statistics.median(c for _, c in pool),
        "dask_s": statistics.median(w for w, _ in dask),
        "dask_cpu_s": statistics.median(c for _, c in dask),
        "same_rows": same,
        "pool_runs": pool,
        "dask_runs": dask,
    }


def _verdict(met: bool) -> str:
    return "met" if met else "not met"


def section(r: dict[str, object]) -> str:
    rate = r["rate"]
    sw = r["sweep"]
    assert isinstance(rate, dict) and isinstance(sw, dict)
    cores = sw["workers"]
    overhead = (sw["dask_s"] / sw["pool_s"] - 1.0) * 100.0
    lines = [
        "## Sweeps: scenes through the control step in memory",
        "",
        f"Measured on {r['cpus']} cores (load average {r['load']} at the start, "
        f"{r['load_end']} at the end: the wall times "
        "are only as quiet as the machine was). `make bench` runs "
        "`python -m mstc.bench.sweep`. CPU time is that of every process doing the work "
        "(the bench, the pool's or the Dask cluster's workers, the Dask scheduler): on a "
        "shared machine wall time also counts the waits for a core, CPU time does not, so "
        "the targets are judged on CPU time, with wall time beside it. CPU time is steadier, "
        "not immune: work on the other core slows this one's too (shared caches), so a "
        "loaded machine still lowers these figures.",
        "",
        "| measure | wall time | CPU time | target |",
        "|---|---:|---:|---|",
        f"| scene-steps per second, one process (paper-line: 2 obstacles, 50 Hz, "
        f"{rate['steps']} steps; median of {r['runs']} runs) | {rate['wall']:,.0f} | "
        f"**{rate['cpu']:,.0f}** per CPU-second | ≥ 40,000 per core: "
        f"{_verdict(rate['cpu'] >= 40000)} |",
    ]
    per_scene = sw["pool_cpu_s"] / sw["scenes"]
    idle = sw["pool_cpu_s"] / cores
    cpu_overhead = (sw["dask_cpu_s"] / sw["pool_cpu_s"] - 1.0) * 100.0
    lines += [
        f"| sweep of {sw['scenes']:,} paper-like scenes of 20 s (2 obstacles, strategy "
        f"paper), process pool of {cores}; median of {sw['repeats']} | {sw['pool_s']:.1f} s "
        f"| **{sw['pool_cpu_s']:.1f} "
        f"CPU-s** ({per_scene * 1000:.1f} ms a scene; {idle:.1f} s on {cores} idle cores) "
        f"| ≤ 30 s: {_verdict(idle <= 30)} (wall: {_verdict(sw['pool_s'] <= 30)}) |",
        f"| the same sweep on a local Dask cluster of {cores} single-threaded workers | "
        f"{sw['dask_s']:.1f} s ({overhead:+.1f} %) | **{sw['dask_cpu_s']:.1f} CPU-s** "
        f"({cpu_overhead:+.1f} % against the pool) | overhead ≤ 10 %: "
        f"{_verdict(cpu_overhead <= 10)} (wall: {_verdict(overhead <= 10)}) |",
        "",
        "The sweep times leave out writing the scene files (done first) and include "
        "starting the pool's workers, writing every events.json and runs.csv; the Dask "
        "cluster is started before the clocks run, as a real one would be, and the pool's "
        "and the cluster's sweeps take turns. \"on "
        f'{cores} idle cores" is the CPU time spread evenly over the cores, what the wall '
        "time is when nothing else runs. Rows alike in both: "
        f"{'yes' if sw['same_rows'] else 'NO'}.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m mstc.bench.sweep", description=__doc__.splitlines()[0]
    )
    sub = ap.add_subparsers(dest="cmd", required=True)
    run = sub.add_parser("run")
    run.add_argument("--lib", required=True)
    run.add_argument("--out", type=Path, required=True)
    run.add_argument("--runs", type=int, default=7)
    run.add_argument("--scenes", type=int, default=1000)
    run.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    run.add_argument("--repeats", type=int, default=3, help="sweeps on each path (medians)")
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
            "sweep": sweep_times(lib, a.scenes, a.workers, a.repeats),
        }
        result["load_end"] = f"{os.getloadavg()[0]:.1f}"
        write_result(a.out, result)
        print(section(result))
        return 0
    report(a.doc, section(json.loads(a.result.read_text())), BEGIN, END)
    return 0


if __name__ == "__main__":
    sys.exit(main())
