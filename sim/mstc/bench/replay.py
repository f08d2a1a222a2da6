# SPDX-License-Identifier: MIT
"""Replay throughput on a 10-minute recorded log (``make replay-bench``).

Times, in one run and on the same file, the median of N runs (5 by default,
interleaved) of:

- python-can's ``LogReader`` reading the log;
- ``LogReader`` and cantools decoding every frame (``db.decode_message``);
- ``mstc replay``'s work: reading the log, feeding its input frames through
  the in-process firmware and comparing every frame the firmware sends;

and prints a table of frames per second and the ratio of the replay to
LogReader + decode (target: at least 5). The replay must come out bit-exact,
else the figure would mean nothing and the script fails.

The log is the paper's circle scenario run for 600 s through the in-process
firmware, recorded once into build/replay-bench/ (not committed); --record
makes it again, for instance after the firmware changed.

    .venv/bin/python -m mstc.bench.replay [--lib PATH] [--runs N] [--record] [--check]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import can

from mstc.bench import ROOT
from mstc.bench.doc import update_doc
from mstc.can.library import LIB_ENV
from mstc.can.protocol import load_database, wire_limits
from mstc.logs.candump import write_candump
from mstc.logs.read import read_log
from mstc.logs.replay import replay
from mstc.loop.lockstep import CanController, simulate
from mstc.plant.scenario import load_scenario

SCENARIO = ROOT / "sim" / "scenarios" / "paper-circle.toml"
DURATION_S = 600.0
"""Length of the recorded run: 10 minutes."""
LOG = ROOT / "build" / "replay-bench" / "paper-circle-600.log"
RATIO_TARGET = 5.0
"""Replay frames/s over LogReader + cantools decode frames/s."""


def record(path: Path, lib: Path) -> None:
    """Run the circle scenario for DURATION_S through the in-process firmware
    and write every frame to @p path (candump -L)."""
    scenario = load_scenario(SCENARIO, wire_limits())
    scenario = dataclasses.replace(
        scenario, sim=dataclasses.replace(scenario.sim, duration=DURATION_S)
    )
    print(f"recording {path} ({DURATION_S:g} s of {SCENARIO.name}) ...", file=sys.stderr)
    with can.Bus(interface="mstc-sil", channel="sil0", lib=str(lib)) as bus:
        controller = CanController(bus, scenario.params, sim_time_stamps=True)
        simulate(scenario, controller)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_candump(path, [m for m, _ in controller.traffic.frames], "sil0")


def median_times(fns: list[Callable[[], object]], runs: int) -> tuple[list[float], list[object]]:
    """Median wall time of @p runs calls of each of @p fns [s], and each one's
    last result. The calls are interleaved, so that a change of the machine's
    load during the run weighs on all alike."""
    times: list[list[float]] = [[] for _ in fns]
    results: list[object] = [None] * len(fns)
    for _ in range(runs):
        for i, fn in enumerate(fns):
            start = time.perf_counter()
            results[i] = fn()
            times[i].append(time.perf_counter() - start)
    return [statistics.median(t) for t in times], results


DOC_BEGIN = "<!-- bench:replay:begin (written by make bench, mstc.bench.replay) -->"
DOC_END = "<!-- bench:replay:end -->"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m mstc.bench.replay",
        description="Replay throughput on a 10-minute log, beside python-can's LogReader "
        "and cantools decoding (median of N runs).",
    )
    parser.add_argument(
        "--lib",
        type=Path,
        default=Path(os.environ.get(LIB_ENV) or ROOT / "build/host/float/libmstc_sil.so"),
        help=f"firmware library (default: ${LIB_ENV}, else build/host/float/libmstc_sil.so)",
    )
    parser.add_argument("--log", type=Path, default=LOG, help="the log (default: %(default)s)")
    parser.add_argument("--runs", type=int, default=5, help="runs of each (default: 5)")
    parser.add_argument("--record", action="store_true", help="record the log again")
    parser.add_argument(
        "--check", action="store_true", help=f"exit 1 when the ratio is below {RATIO_TARGET:g}"
    )
    parser.add_argument(
        "--doc", type=Path, help="also write the table into this document (docs/performance.md)"
    )
    args = parser.parse_args(argv)
    if not args.lib.is_file():
        print(f"mstc.bench.replay: no library {args.lib} (make lib)", file=sys.stderr)
        return 2
    if args.record or not args.log.is_file():
        record(args.log, args.lib)

    db = load_database()
    frames = sum(1 for _ in can.LogReader(str(args.log)))

    def read_only() -> int:
        n = 0
        for _ in can.LogReader(str(args.log)):
            n += 1
        return n

    def read_decode() -> int:
        n = 0
        decode = db.decode_message
        for msg in can.LogReader(str(args.log)):
            # cantools decodes a bytearray as it does bytes; no copy in the timed loop
            decode(msg.arbitration_id, msg.data)  # type: ignore[arg-type]
            n += 1
        return n

    def replay_file() -> object:
        return replay(read_log(args.log, db), db, args.lib)

    (t_read, t_decode, t_replay), (_, _, result) = median_times(
        [read_only, read_decode, replay_file], args.runs
    )
    if not result.identical:  # type: ignore[attr-defined]
        print(
            f"mstc.bench.replay: {args.log} does not replay bit-exact through {args.lib}: "
            "record it again (--record)",
            file=sys.stderr,
        )
        return 1
    log_span = result.log.duration  # type: ignore[attr-defined]
    rows = [
        ("python-can LogReader", t_read),
        ("LogReader + cantools decode", t_decode),
        ("replay through the firmware", t_replay),
    ]
    ratio = t_decode / t_replay
    print(
        f"replay throughput: {args.log.name}, {frames:,} frames, {log_span:.0f} s of bus time, "
        f"median of {args.runs}"
    )
    print(f"  {'':<30} {'time [s]':>9} {'frames/s':>11}")
    for name, t in rows:
        print(f"  {name:<30} {t:>9.3f} {frames / t:>11,.0f}")
    verdict = "met" if ratio >= RATIO_TARGET else "MISSED"
    print(f"  replay / (LogReader + decode): {ratio:.1f}x (target >= {RATIO_TARGET:g}x: {verdict})")
    if args.doc is not None:
        body = "\n".join(
            [
                "## Replay throughput\n",
                f"A {log_span:.0f} s log of {SCENARIO.name} ({frames:,} frames), median of "
                f"{args.runs} runs, interleaved (`make replay-bench`):\n",
                "| | time [s] | frames per second |",
                "|---|---|---|",
                *(f"| {name} | {t:.3f} | {frames / t:,.0f} |" for name, t in rows),
                "",
                f"Replay through the firmware is {ratio:.1f}× faster than python-can's "
                f"LogReader plus cantools decoding alone (target: at least {RATIO_TARGET:g}×).\n",
            ]
        )
        update_doc(args.doc, body, DOC_BEGIN, DOC_END)
    return 1 if args.check and ratio < RATIO_TARGET else 0


if __name__ == "__main__":
    sys.exit(main())
