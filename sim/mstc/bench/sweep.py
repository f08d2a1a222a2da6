# SPDX-License-Identifier: MIT
"""Sweep throughput: scene-steps per CPU-second of the batched engine against
the per-scene one on the standard suite's families (with ideal wheels and
with its "gearmotor" actuator), scene-steps per second of one scene in
memory, `mstc sweep` end to end against its engine's own CPU time, sweeps on
every core, and the same sweeps on a local Dask cluster.

  python -m mstc.bench.sweep run --lib build/host/float/libmstc_sil.so --out build/bench/sweep.json
  python -m mstc.bench.sweep report --doc docs/performance.md build/bench/sweep.json
  python -m mstc.bench.sweep engines --lib build/host/float/libmstc_sil.so --actuator gearmotor
      only the two engines' table under one actuator profile, printed
  python -m mstc.bench.sweep end-to-end --lib build/host/float/libmstc_sil.so
      only the end-to-end sweep against its engine, printed

A benchmark, not a test: it prints and writes figures and fails on nothing.
Beside each wall time it gives the CPU time of every process that did the
work (this one, the pool's workers, the Dask scheduler and workers): on a
machine shared with other work, wall time counts the waits for a core and
CPU time does not, so CPU time is the fair figure of the work itself.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from mstc.bench import ROOT
from mstc.bench.doc import report, write_result
from mstc.can.protocol import wire_limits
from mstc.firmware.sil import SilController
from mstc.loop.lockstep import simulate
from mstc.plant.scenario import load_scenario
from mstc.sweep.engine import BATCH, Job, library_sha256, run_batch, run_jobs_batched
from mstc.sweep.plan import Plan, Slice, run_sweep
from mstc.sweep.suite import IDEAL, Suite, load_suite

LINE = ROOT / "sim" / "scenarios" / "paper-line.toml"
STANDARD = ROOT / "sim" / "suites" / "standard.toml"
BATCHED_TARGET = 1_000_000
"""Scene-steps per CPU-second of the batched engine, ideal wheels, "mstc" (issue 22)."""
GEARMOTOR = "gearmotor"
"""The standard suite's actuator profile of the second target."""
GEARMOTOR_TARGET = 250_000
"""Scene-steps per CPU-second of the batched engine, "gearmotor" wheels, "mstc" (issue 22)."""
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


def _plan(suite: Suite, strategies: list[str], actuator: str | None = None) -> Plan:
    """The plan of @p suite (only its profile @p actuator when given)."""
    plan = Plan(strategies)
    problems = plan.add_suite(
        suite, str(suite.path), None, None if actuator is None else [actuator]
    )
    assert not problems, problems
    return plan


def _family_jobs(
    per_family: int, strategy: str, actuator: str = IDEAL
) -> tuple[dict[str, list[Job]], dict[str, float]]:
    """The first @p per_family scenes of every family of the standard suite
    under its actuator profile @p actuator, made as a worker makes them
    (their documents, parsed); and the CPU time the making took per family [s]."""
    suite = load_suite(STANDARD)
    suite = replace(suite, families=tuple(replace(f, count=per_family) for f in suite.families))
    jobs: dict[str, list[Job]] = {}
    make: dict[str, float] = {}
    for block in _plan(suite, [strategy], actuator).blocks:
        c0 = time.process_time()
        scenes = [block.make(i, "") for i in range(per_family)]
        make[block.family.name] = time.process_time() - c0
        jobs[block.family.name] = [(scene, strategy) for scene in scenes]
    return jobs, make


def engine_rates(
    lib: str, batch: int, scenes: int, runs: int, strategy: str = "mstc", actuator: str = IDEAL
) -> dict[str, object]:
    """Scene-steps per CPU-second of this process, family by family of the
    standard suite under its actuator profile @p actuator: the batched
    engine on one batch of @p batch scenes of the
    family, the per-scene engine on @p scenes of them, taking turns @p runs
    times; each family's median, and the suite's (all its scene-steps over
    the sum of the families' median CPU times). A worker's work is counted
    (the runs, the metrics, events.json); the scenes come parsed, as the
    client sends them, and the making's own cost is given beside."""
    sha = library_sha256(lib)
    batched_jobs, make = _family_jobs(batch, strategy, actuator)
    scene_jobs = {f: jobs[:scenes] for f, jobs in batched_jobs.items()}
    families: dict[str, dict[str, float]] = {}
    for family in batched_jobs:
        cpu: dict[str, list[float]] = {"batched": [], "scene": []}
        steps: dict[str, int] = {}
        for _ in range(runs):
            for engine, jobs in (("batched", batched_jobs[family]), ("scene", scene_jobs[family])):
                c0 = time.process_time()
                if engine == "batched":
                    outcomes = run_jobs_batched(jobs, lib, sha)
                else:
                    outcomes = run_batch(jobs, lib, "scene")
                cpu[engine].append(time.process_time() - c0)
                steps[engine] = sum(int(o.row["steps"]) for o in outcomes)
        families[family] = (
            {f"{e}_steps": float(steps[e]) for e in steps}
            | {f"{e}_cpu": statistics.median(cpu[e]) for e in cpu}
            | {"make_cpu": make[family]}
        )
    total = {
        e: sum(f[f"{e}_steps"] for f in families.values())
        / sum(f[f"{e}_cpu"] for f in families.values())
        for e in ("batched", "scene")
    }
    return {
        "strategy": strategy,
        "actuator": actuator,
        "batch": batch,
        "scenes": scenes,
        "runs": runs,
        "families": families,
        "batched": total["batched"],
        "scene": total["scene"],
    }


def _paper_like(count: int, folder: Path) -> Plan:
    """The plan of @p count paper-like scenes under "paper"."""
    path = folder / "paper-like.toml"
    path.write_text(PAPER_LIKE.format(count=count))
    return _plan(load_suite(path), ["paper"])


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


def _subreaper() -> None:
    """Adopt the orphans of the processes this one starts (Linux: a worker
    whose parent ended before it), so that their CPU time is counted in
    RUSAGE_CHILDREN once :func:`_reap` has waited for them."""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_CHILD_SUBREAPER)")


PR_SET_CHILD_SUBREAPER = 36
"""prctl's option (linux/prctl.h)."""


def _reap() -> None:
    """Wait for every child left, adopted orphans too."""
    while True:
        try:
            os.wait()
        except ChildProcessError:
            return


_CPU_LINE = re.compile(
    r"CPU: ([\d.]+) s making scenes and ([\d.]+) s running them .*?, ([\d.]+) s writing"
)


def _slice_jobs(piece: Slice) -> list[Job]:
    """The jobs of a slice, its scenes made."""
    jobs: list[Job] = []
    for k, number in piece.runs():
        _, index, strategy = piece.run(k, number)
        jobs.append((piece.parts[k].block.make(index, ""), strategy))
    return jobs


def _engine_cpu(task: tuple[Slice, str]) -> float:
    """The CPU time of :func:`run_batch` on a slice whose scenes are made
    first, outside the clock [s] (run in a pool's worker)."""
    piece, lib = task
    jobs = _slice_jobs(piece)
    c0 = time.process_time()
    run_batch(jobs, lib, "batched")
    return time.process_time() - c0


def end_to_end(lib: str, per_family: int, workers: int, repeats: int) -> dict[str, object]:
    """`mstc sweep` of @p per_family scenes of every family of the standard
    suite (ideal wheels, "mstc") on @p workers local processes, end to end
    (its process start, the scenes made, run, runs.csv, summary.md and its
    figures; no gallery): the CPU time of every process of it. Beside it, the
    engine's own CPU time for those scenes, the same slices with their scenes
    made beforehand, run with :func:`run_batch` twice: on @p workers
    processes at once, as the sweep runs them (the like-for-like figure: two
    processes on a machine's cores share its caches and memory, and each
    runs slower than one alone), and in this process alone. @p repeats
    times each, taking turns; medians."""
    _subreaper()
    suite = load_suite(STANDARD)
    suite = replace(suite, families=tuple(replace(f, count=per_family) for f in suite.families))
    plan = _plan(suite, ["mstc"], IDEAL)
    runs: list[dict[str, float]] = []
    engine: list[float] = []
    alone: list[float] = []
    command = [sys.executable, "-m", "mstc", "sweep", "--lib", lib, "--count", str(per_family)]
    command += ["--actuator", IDEAL, "--strategy", "mstc", "--gallery", "0", "-q"]
    command += ["--jobs", str(workers)]
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            c0, t0 = children_cpu(), time.perf_counter()
            done = subprocess.run(
                [*command, "--out", tmp, str(STANDARD)], capture_output=True, text=True, check=True
            )
            _reap()
            cpu, wall = children_cpu() - c0, time.perf_counter() - t0
        found = _CPU_LINE.search(done.stdout)
        assert found is not None, done.stdout
        make, run, here = (float(x) for x in found.groups())
        runs.append({"cpu": cpu, "wall": wall, "make": make, "run": run, "here": here})
        pieces = list(plan.slices(workers, np.zeros(0, dtype=np.int64)))
        with ProcessPoolExecutor(workers, mp_context=get_context("fork")) as pool:
            engine.append(sum(pool.map(_engine_cpu, [(p, lib) for p in pieces], chunksize=1)))
        alone.append(sum(_engine_cpu((p, lib)) for p in pieces))
    middle = sorted(runs, key=lambda r: r["cpu"])[len(runs) // 2]
    return {
        "scenes": plan.scenes,
        "workers": workers,
        "repeats": repeats,
        "runs": runs,
        "engine_runs": engine,
        "engine_alone_runs": alone,
        "median": middle,
        "engine_cpu": statistics.median(engine),
        "engine_alone_cpu": statistics.median(alone),
    }


def _end_to_end_rows(e: dict[str, Any]) -> list[str]:
    m, engine = e["median"], float(e["engine_cpu"])
    ratio = m["cpu"] / engine
    overhead = m["make"] + m["here"]
    rest = m["cpu"] - m["make"] - m["run"] - m["here"]
    return [
        f"| `mstc sweep` of {e['scenes']:,} scenes (the standard suite, "
        f'{e["scenes"] // 10:,} a family, ideal wheels, "mstc", {e["workers"]} local '
        f"workers), end to end; the run of median CPU time of {e['repeats']} | {m['wall']:.1f} s "
        f"| **{m['cpu']:.1f} CPU-s**: {m['run']:.1f} running the scenes, {m['make']:.1f} making "
        f"them (the workers), {m['here']:.1f} writing runs.csv and summary.md (the client), "
        f"{rest:.1f} the rest (process starts, imports, the slices' travel) | — |",
        f"| the engine's own CPU time for those scenes (the same slices, made beforehand, "
        f"on {e['workers']} processes at once as the sweep's workers run them; median of "
        f"{e['repeats']}) | — | **{engine:.1f} CPU-s** "
        f"| end to end ≤ 1.3× it: {_verdict(ratio <= 1.3)} (**{ratio:.2f}×**; "
        f"{m['cpu'] / m['run']:.2f}× the workers' own time running them in the sweep) |",
        *(
            [
                f"| the same in one process alone (one core busy, the other idle; median of "
                f"{e['repeats']}) | — | {alone:.1f} CPU-s | {m['cpu'] / alone:.2f}× |"
            ]
            if (alone := e.get("engine_alone_cpu")) is not None
            else []
        ),
        f"| making the scenes and writing the outputs, share of the sweep's CPU time | — | "
        f"**{100 * overhead / m['cpu']:.1f} %** ({overhead:.1f} CPU-s) | < 30 %: "
        f"{_verdict(overhead / m['cpu'] < 0.3)} |",
    ]


def sweep_times(
    lib: str, count: int, workers: int, repeats: int, engine: str = "scene"
) -> dict[str, object]:
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
        plan = _paper_like(count, folder)
        address = cluster.scheduler_address
        for i in range(repeats):
            t0, c0, k0 = time.perf_counter(), process_cpu(), children_cpu()
            run_sweep(plan, folder / f"pool{i}", lib, workers=workers, engine=engine)
            pool.append((time.perf_counter() - t0, process_cpu() - c0 + children_cpu() - k0))
            w0 = sum(client.run(process_cpu).values())
            t0, c0 = time.perf_counter(), process_cpu()
            run_sweep(
                plan,
                folder / f"dask{i}",
                lib,
                workers=workers,
                scheduler=address,
                engine=engine,
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
        "engine": engine,
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


def _sweep_rows(sw: dict[str, object], what: str) -> list[str]:
    """The pool's and the Dask cluster's rows of one sweep."""
    cores, scenes = sw["workers"], sw["scenes"]
    pool_s, pool_cpu = float(sw["pool_s"]), float(sw["pool_cpu_s"])  # type: ignore[arg-type]
    dask_s, dask_cpu = float(sw["dask_s"]), float(sw["dask_cpu_s"])  # type: ignore[arg-type]
    overhead = (dask_s / pool_s - 1.0) * 100.0
    cpu_overhead = (dask_cpu / pool_cpu - 1.0) * 100.0
    per_scene = pool_cpu / int(scenes)  # type: ignore[call-overload]
    idle = pool_cpu / int(cores)  # type: ignore[call-overload]
    return [
        f"| {what}, process pool of {cores}; median of {sw['repeats']} | {pool_s:.1f} s "
        f"| **{pool_cpu:.1f} CPU-s** ({per_scene * 1000:.2f} ms a scene; {idle:.1f} s on "
        f"{cores} idle cores) | — |",
        f"| the same sweep on a local Dask cluster of {cores} single-threaded workers | "
        f"{dask_s:.1f} s ({overhead:+.1f} %) | **{dask_cpu:.1f} CPU-s** "
        f"({cpu_overhead:+.1f} % against the pool) | overhead ≤ 10 %: "
        f"{_verdict(cpu_overhead <= 10)} (wall: {_verdict(overhead <= 10)}); rows alike: "
        f"{'yes' if sw['same_rows'] else 'NO'} |",
    ]


def engine_table(eng: dict[str, Any]) -> list[str]:
    """The table of :func:`engine_rates`' result: each family's rates, the suite's."""
    lines = [
        "| family | batched | per scene | ratio | making the scene [ns per scene-step] |",
        "|---|---:|---:|---:|---:|",
    ]
    for family, f in eng["families"].items():
        b = f["batched_steps"] / f["batched_cpu"]
        sc = f["scene_steps"] / f["scene_cpu"]
        make = f["make_cpu"] / f["batched_steps"] * 1e9
        lines.append(f"| {family} | {b:,.0f} | {sc:,.0f} | {b / sc:.1f}× | {make:,.0f} |")
    lines.append(
        f"| **the suite** | **{eng['batched']:,.0f}** | **{eng['scene']:,.0f}** | "
        f"**{eng['batched'] / eng['scene']:.1f}×** | |"
    )
    return lines


def section(r: dict[str, object]) -> str:
    rate, sw, swb, eng = r["rate"], r["sweep"], r["sweep_batched"], r["engines"]
    e2e = r.get("end_to_end")
    assert isinstance(rate, dict) and isinstance(sw, dict)
    assert isinstance(swb, dict) and isinstance(eng, dict)
    ratio = eng["batched"] / eng["scene"]
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
        "### The two engines (docs/sweeps.md)",
        "",
        f'Scene-steps per CPU-second of one process under "{eng["strategy"]}" with ideal '
        "wheels, family by family of the standard suite (sim/suites/standard.toml: 30 s "
        f"scenes, 1,501 steps): the batched engine on one batch of {eng['batch']} scenes of "
        f"the family, the per-scene engine on {eng['scenes']} of them, the two taking turns, "
        f"median of {eng['runs']} runs each. A worker's work is counted (the runs, the "
        "metrics, events.json); the scenes come made, and the making's own cost is the last "
        "column (a worker's, once per scene, whichever engine runs it: the scene's document "
        "drawn from its seed and parsed by the scenario loader; the sweeps below count it).",
        "",
        *engine_table(eng),
        "",
    ]
    gear = r.get("engines_gearmotor")
    if isinstance(gear, dict):
        lines += [
            f'With the suite\'s "{GEARMOTOR}" actuator (wheels in 1 ms substeps, 20 a '
            "period, with their encoders), the same scenes measured the same way:",
            "",
            *engine_table(gear),
            "",
        ]
    lines += [
        f'- Ideal wheels, "{eng["strategy"]}": **{eng["batched"]:,.0f}** scene-steps per '
        f"CPU-second, {ratio:.1f}× the per-scene engine (target ≥ {BATCHED_TARGET:,}: "
        f"{_verdict(eng['batched'] >= BATCHED_TARGET)}).",
    ]
    if isinstance(gear, dict):
        lines.append(
            f'- "{GEARMOTOR}" wheels: **{gear["batched"]:,.0f}** scene-steps per CPU-second, '
            f"{gear['batched'] / gear['scene']:.1f}× the per-scene engine (target ≥ "
            f"{GEARMOTOR_TARGET:,}: {_verdict(gear['batched'] >= GEARMOTOR_TARGET)})."
        )
    else:
        lines.append(f'- "{GEARMOTOR}" wheels: not measured in this run.')
    lines += [
        "",
        "### Sweeps on every core and on Dask",
        "",
        "| measure | wall time | CPU time | target |",
        "|---|---:|---:|---|",
        *(_end_to_end_rows(e2e) if isinstance(e2e, dict) else []),
        f"| scene-steps per second, one process, per-scene engine (paper-line: 2 obstacles, "
        f"50 Hz, {rate['steps']} steps; median of {r['runs']} runs) | {rate['wall']:,.0f} | "
        f"**{rate['cpu']:,.0f}** per CPU-second | ≥ 40,000 per core: "
        f"{_verdict(rate['cpu'] >= 40000)} |",
    ]
    lines += _sweep_rows(
        sw,
        f"sweep of {sw['scenes']:,} paper-like scenes of 20 s (2 obstacles, strategy "
        "paper), per-scene engine",
    )
    lines += _sweep_rows(
        swb, f"sweep of {swb['scenes']:,} paper-like scenes of 20 s, batched engine"
    )
    lines += [
        "",
        "The end-to-end sweep is the command as a user runs it, its CPU time that of the "
        "`mstc sweep` process and of every process it started (counted when they end). "
        "Its engine's figure runs the same slices on as many processes at once as the "
        "sweep has workers: processes on a machine's cores at once share its caches and "
        "memory and each runs slower than one alone (the table gives both), and a figure "
        "from one process would count that as the sweep's overhead. "
        "The other sweep times are `run_sweep` in this process: they leave out the "
        "command's start and the summary, and include starting the pool's workers, making "
        "the scenes and writing runs.csv; the Dask "
        "cluster is started before the clocks run, as a real one would be, and the pool's "
        "and the cluster's sweeps take turns. \"on "
        f'{sw["workers"]} idle cores" is the CPU time spread evenly over the cores, what '
        "the wall time is when nothing else runs.",
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
    run.add_argument("--batched-scenes", type=int, default=10000)
    run.add_argument(
        "--per-family", type=int, default=1000, help="scenes a family, end-to-end sweep"
    )
    run.add_argument("--batch", type=int, default=BATCH, help="scenes of a family in one batch")
    run.add_argument(
        "--per-scene", type=int, default=6, help="scenes of a family, per-scene engine"
    )
    run.add_argument("--engine-runs", type=int, default=3, help="runs of each engine (medians)")
    run.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    run.add_argument("--repeats", type=int, default=3, help="sweeps on each path (medians)")
    eng = sub.add_parser(
        "engines", help="only the two engines' table, under one actuator profile: printed"
    )
    eng.add_argument("--lib", required=True)
    eng.add_argument("--actuator", default=IDEAL, help="a profile of the standard suite")
    eng.add_argument("--strategy", default="mstc", choices=("paper", "mstc"))
    eng.add_argument("--batch", type=int, default=BATCH, help="scenes of a family in one batch")
    eng.add_argument("--per-scene", type=int, default=6)
    eng.add_argument("--engine-runs", type=int, default=3)
    eng.add_argument("--out", type=Path, help="also write the figures here (JSON)")
    e2e = sub.add_parser("end-to-end", help="only the end-to-end sweep against its engine")
    e2e.add_argument("--lib", required=True)
    e2e.add_argument("--per-family", type=int, default=1000)
    e2e.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    e2e.add_argument("--repeats", type=int, default=3)
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
            "engines": engine_rates(lib, a.batch, a.per_scene, a.engine_runs),
            "engines_gearmotor": engine_rates(
                lib, a.batch, a.per_scene, a.engine_runs, actuator=GEARMOTOR
            ),
            "rate": steps_per_second(lib, a.runs),
            "end_to_end": end_to_end(lib, a.per_family, a.workers, a.repeats),
            "sweep": sweep_times(lib, a.scenes, a.workers, a.repeats, "scene"),
            "sweep_batched": sweep_times(lib, a.batched_scenes, a.workers, a.repeats, "batched"),
        }
        result["load_end"] = f"{os.getloadavg()[0]:.1f}"
        write_result(a.out, result)
        print(section(result))
        return 0
    if a.cmd == "engines":
        lib = str(Path(a.lib).resolve())
        load = os.getloadavg()[0]
        rates = engine_rates(
            lib, a.batch, a.per_scene, a.engine_runs, a.strategy, actuator=a.actuator
        )
        if a.out is not None:
            write_result(a.out, rates)
        print(
            f'"{a.strategy}", actuator {a.actuator}: scene-steps per CPU-second, median of '
            f"{a.engine_runs} runs (load average {load:.1f} at the start, "
            f"{os.getloadavg()[0]:.1f} at the end)\n"
        )
        print("\n".join(engine_table(rates)))
        return 0
    if a.cmd == "end-to-end":
        load = os.getloadavg()[0]
        lib = str(Path(a.lib).resolve())
        measured = end_to_end(lib, a.per_family, a.workers, a.repeats)
        print(f"load average {load:.1f} at the start, {os.getloadavg()[0]:.1f} at the end\n")
        print("\n".join(_end_to_end_rows(measured)))
        return 0
    report(a.doc, section(json.loads(a.result.read_text())), BEGIN, END)
    return 0


if __name__ == "__main__":
    sys.exit(main())
