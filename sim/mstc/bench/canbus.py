# SPDX-License-Identifier: MIT
"""CAN benchmark of mstc (make bench): steps per second through frames in
process (SIL), and lock-step round trips per second over SocketCAN (HIL)
beside a bare round trip measured in the same run.

    python -m mstc.bench.canbus sil --lib build/host/float/libmstc_sil.so \\
        --out build/bench/can-sil.json
    tools/vm/with-vcan -- .venv/bin/python -m mstc.bench.canbus hil \\
        --fw build/host/mstc-fw --echo build/bench/can_echo --out build/bench/can-hil.json
    python -m mstc.bench.canbus report --doc docs/performance.md build/bench/can-*.json

Every figure is the median of --runs runs. Over vcan the plant sends one STEP
frame and waits for the answer that ends the exchange:
- bare: can_echo answers each frame with one frame (Python, the bus, a C peer);
- same traffic: can_echo answers with three frames, as many as the firmware
  sends per step (STATUS, STATUS_TRK, WHEEL_CMD);
- firmware: mstc-fw runs a control step per STEP and answers with its frames.
The firmware's share is the firmware round trip's time over the bare one.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import can
import numpy as np

from mstc.bench import ROOT
from mstc.bench.doc import report, vcan_where, write_result
from mstc.can.protocol import Protocol, wire_limits
from mstc.can.vmbridge import Bridge
from mstc.firmware.sil import SilController
from mstc.loop.lockstep import CanController, simulate
from mstc.plant.scenario import load_scenario

SCENARIO = ROOT / "sim" / "scenarios" / "paper-line.toml"
BEGIN = "<!-- bench:can:begin (written by make bench, mstc.bench.canbus) -->"
END = "<!-- bench:can:end -->"
WHEEL_CMD = 0x180


def _median_rate(runs: int, one_run: Callable[[], float]) -> tuple[float, list[float]]:
    rates = [one_run() for _ in range(runs)]
    return statistics.median(rates), rates


def bench_sil(lib: Path, runs: int) -> dict[str, object]:
    """Closed-loop steps per second of the paper's line scenario: through
    frames with the mstc-sil interface, and in memory."""
    scenario = load_scenario(SCENARIO, wire_limits())
    steps = scenario.sim.steps + 1

    def frames() -> float:
        with can.Bus(interface="mstc-sil", lib=str(lib)) as bus:
            ctl = CanController(bus, scenario.params, sim_time_stamps=True)
            t = time.perf_counter()
            simulate(scenario, ctl)
            return steps / (time.perf_counter() - t)

    def memory() -> float:
        ctl = SilController(scenario.params, lib)
        t = time.perf_counter()
        simulate(scenario, ctl)
        return steps / (time.perf_counter() - t)

    f, fr = _median_rate(runs, frames)
    m, mr = _median_rate(runs, memory)
    return {
        "kind": "sil",
        "steps": steps,
        "frames_per_s": f,
        "frames_runs": fr,
        "memory_per_s": m,
        "memory_runs": mr,
    }


def _start(cmd: list[str], channel: str) -> subprocess.Popen[str]:
    """Start a peer: in the vcan VM, through its agent, when the bus is the
    VM's bridge."""
    bridge = Bridge.from_env(channel)
    prefix = bridge.runner() if bridge is not None else []
    proc = subprocess.Popen([*prefix, *cmd], stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    line = proc.stderr.readline()
    if " mode on " not in line:
        proc.kill()
        raise SystemExit(f"error: {cmd[0]} did not start: {line.strip()}")
    return proc


def _round_trips(
    bus: can.BusABC, proto: Protocol, last_id: int, count: int, times: list[float] | None = None
) -> float:
    """Send STEP frames; each round trip ends when a frame with @p last_id
    arrives. Only identifiers are looked at, as cheaply as possible. Each
    round trip's time [ms] goes to @p times."""
    t0 = time.perf_counter()
    for i in range(count):
        t = time.perf_counter()
        bus.send(proto.encode("STEP", step=i & 0xFFFF, time=(i * 20000) & 0xFFFFFFFF, raw=True))
        while True:
            msg = bus.recv(1.0)
            if msg is None:
                raise SystemExit(f"error: no answer to round trip {i}")
            if msg.arbitration_id == last_id:
                break
        if times is not None:
            times.append((time.perf_counter() - t) * 1e3)
    return count / (time.perf_counter() - t0)


def _peer_rate(
    cmd: list[str],
    last_id: int,
    firmware: bool,
    channel: str,
    count: int,
    times: list[float] | None = None,
) -> float:
    """Start a peer, measure @p count round trips to it, stop it."""
    bridge = Bridge.from_env(channel)
    proc = _start(cmd, channel)
    try:
        with (
            bridge.open_bus()
            if bridge is not None
            else can.Bus(interface="socketcan", channel=channel)
        ) as bus:
            proto = Protocol()
            if firmware:  # inputs once; every STEP then steps on them
                for frame, values in (
                    ("ODOM_XY", {"x": 0.0, "y": 2.5}),
                    ("ODOM_THETA", {"theta": 0.5}),
                    ("REF_XY", {"x": 0.1, "y": 2.6}),
                    ("REF_MOTION", {"theta": 0.7, "v": 0.5, "w": 0.0}),
                ):
                    bus.send(proto.encode(frame, values))
            _round_trips(bus, proto, last_id, 50)  # warm up
            return _round_trips(bus, proto, last_id, count, times)
    finally:
        proc.terminate()
        proc.wait(timeout=5)


def bench_hil(fw: Path, echo: Path, channel: str, runs: int, count: int) -> dict[str, object]:
    """Round trips per second over @p channel: bare, same traffic, firmware.
    The peers take turns run by run, so that a drift of the machine's speed
    (the VM's, above all) cannot favour one of them."""
    out: dict[str, object] = {
        "kind": "hil",
        "channel": channel,
        "count": count,
        "where": os.environ.get("MSTC_VCAN_WHERE", "host"),
    }
    peers = {
        "bare": ([str(echo), channel, "1"], 0x180),
        "same_traffic": ([str(echo), channel, "3"], 0x182),
        "firmware": ([str(fw), "--can", channel], WHEEL_CMD),
    }
    rates: dict[str, list[float]] = {name: [] for name in peers}
    times: dict[str, list[float]] = {name: [] for name in peers}
    for _ in range(runs):
        for name, (cmd, last_id) in peers.items():
            rates[name].append(
                _peer_rate(cmd, last_id, name == "firmware", channel, count, times[name])
            )
    for name, values in rates.items():
        out[f"{name}_per_s"] = statistics.median(values)
        out[f"{name}_runs"] = values
        p50, p99 = np.percentile(times[name], [50, 99])
        out[f"{name}_round_trip_ms"] = {
            "p50": round(float(p50), 3),
            "p99": round(float(p99), 3),
            "max": round(max(times[name]), 3),
        }
    out["load"] = round(os.getloadavg()[0], 1)
    return out


def section(results: list[dict[str, object]]) -> str:
    lines = ["## CAN: through frames in process and over SocketCAN\n"]
    for r in results:
        if r["kind"] == "sil":
            f, m = float(r["frames_per_s"]), float(r["memory_per_s"])  # type: ignore[arg-type]
            lines += [
                "Closed loop of the paper's line scenario (plant, sensor and firmware; "
                f"{r['steps']} steps), median of {len(r['frames_runs'])} runs:\n",  # type: ignore[arg-type]
                "| path | steps per second |",
                "|---|---|",
                f"| SIL through CAN frames (`mstc-sil`, the default of `make sim`) | {f:,.0f} |",
                f"| the control step in memory (`--bus memory`) | {m:,.0f} |",
                "",
                f"The frames cost {m / f:.1f}× the in-memory loop: per step the plant encodes "
                "and E2E-protects 5 frames and checks and decodes 3 or more in Python.\n",
            ]
        else:
            b, s, fw = (float(r[k]) for k in ("bare_per_s", "same_traffic_per_s", "firmware_per_s"))  # type: ignore[arg-type]
            added = b / fw - 1
            where = vcan_where(r["where"])

            def ms(name: str, r: dict[str, object] = r) -> str:
                t = r.get(f"{name}_round_trip_ms")
                return (
                    f"{t['p50']:.2f} / {t['p99']:.2f} / {t['max']:.2f}"
                    if isinstance(t, dict)
                    else ""
                )

            lines += [
                f"Lock-step round trips over `{r['channel']}` ({where}), {r['count']} per run, "
                f"median of {len(r['firmware_runs'])} runs, "  # type: ignore[arg-type]
                "all measured in the same run, the peers taking turns run by run"
                + (f"; load average {r['load']}" if "load" in r else "")
                + ":\n",
                "| peer answering each STEP frame | round trips per second "
                "| round trip p50 / p99 / max [ms] |",
                "|---|---|---|",
                f"| bare: a C echo, one frame back | {b:,.0f} | {ms('bare')} |",
                f"| same traffic: a C echo, three frames back | {s:,.0f} | {ms('same_traffic')} |",
                f"| the firmware, `mstc-fw`: a control step, then 3 frames | {fw:,.0f} "
                f"| {ms('firmware')} |",
                "",
                f"The firmware's round trip takes {added:+.0%} over the bare one "
                f"(target: under +25 %); against the same traffic without a firmware, "
                f"{s / fw - 1:+.0%}.\n",
            ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m mstc.bench.canbus", description=__doc__.split("\n\n")[0]
    )
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("sil", help="steps per second in process")
    s.add_argument("--lib", type=Path, required=True)
    h = sub.add_parser("hil", help="round trips per second over SocketCAN")
    h.add_argument("--fw", type=Path, required=True)
    h.add_argument("--echo", type=Path, required=True)
    h.add_argument("--channel", default="vcan0")
    h.add_argument("--count", type=int, default=1000)
    for p in (s, h):
        p.add_argument("--runs", type=int, default=5)
        p.add_argument("--out", type=Path, required=True)
    r = sub.add_parser("report", help="print the figures and write them into a document")
    r.add_argument("--doc", type=Path, required=True)
    r.add_argument("results", type=Path, nargs="+")
    a = ap.parse_args(argv)
    if a.cmd == "report":
        report(a.doc, section([json.loads(p.read_text()) for p in a.results]), BEGIN, END)
        return 0
    result = (
        bench_sil(a.lib, a.runs)
        if a.cmd == "sil"
        else bench_hil(a.fw, a.echo, a.channel, a.runs, a.count)
    )
    write_result(a.out, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
