# SPDX-License-Identifier: MIT
"""Real-time HIL benchmark of mstc (make bench, make hil-load): real-time runs
of the paper scenarios against mstc-fw --realtime over SocketCAN, and their
timing figures.

    tools/vm/with-vcan --bridge -- .venv/bin/python -m mstc.bench.realtime run \\
        --fw build/host/mstc-fw --out build/bench/can-realtime.json
    python -m mstc.bench.realtime report --doc docs/performance.md build/bench/can-realtime.json
    tools/vm/with-vcan --bridge -- .venv/bin/python -m mstc.bench.realtime load \\
        --fw build/host/mstc-fw --busy 0 1 2 --runs 5 --out build/bench/hil-load.json
    python -m mstc.bench.realtime load-report --doc docs/hil.md build/bench/hil-load.json

The run is `mstc hil --realtime` (mstc.loop.realtime): the figures are those
of its timing.json (docs/hil.md, "Real time"). ``load`` repeats the runs with
0, 1, 2... CPU-bound processes at normal priority beside them (docs/hil.md,
"Load"), and, in the vcan VM, measures what the emulated side costs.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import can

from mstc.bench import ROOT
from mstc.bench.doc import report, vcan_where, write_result
from mstc.can import secoc
from mstc.can.protocol import wire_limits
from mstc.can.vmbridge import Bridge
from mstc.firmware.process import start_firmware, stop_firmware
from mstc.loop.realtime import RealtimeLink, simulate_realtime
from mstc.plant.scenario import load_scenario
from mstc.report.table import match_events

SCENARIOS = [ROOT / "sim" / "scenarios" / f"{n}.toml" for n in ("paper-line", "paper-circle")]
BEGIN = "<!-- bench:realtime:begin (written by make bench, mstc.bench.realtime) -->"
END = "<!-- bench:realtime:end -->"


def run_one(fw: Path, channel: str, path: Path) -> dict[str, object]:
    """One real-time run of the scenario @p path on a fresh mstc-fw: through
    the vcan VM's bridge when there is one (the firmware in the VM)."""
    scenario = load_scenario(path, wire_limits())
    bridge = Bridge.from_env(channel)
    bus = (
        bridge.open_bus() if bridge is not None else can.Bus(interface="socketcan", channel=channel)
    )
    before = bridge.counters() if bridge is not None else {}
    # The firmware gets the key the plant authenticates with (mstc hil does the same).
    proc = start_firmware(
        fw,
        channel,
        secoc.key_file(),
        period_ms=20,
        prefix=bridge.runner() if bridge is not None else (),
    )
    vm0, t0 = Bridge.vm_cpu_s(), time.monotonic()
    crossed = None
    try:
        link = RealtimeLink(bus, scenario.params)
        result = simulate_realtime(
            scenario, link, boost=bridge.vm_threads() if bridge is not None else ()
        )
    finally:
        vm1, t1 = Bridge.vm_cpu_s(), time.monotonic()
        stop_firmware(proc)
        if bridge is not None:
            crossed = bridge.tally(bus, before)  # type: ignore[arg-type]
        bus.shutdown()
    assert result.timing is not None
    timing = result.timing.to_json()
    del timing["series"]
    matched = [
        m
        for m in match_events(result.events, scenario.expected)
        if m.simulated is not None and m.expected is not None
    ]
    shifts = [
        round((m.simulated.t - m.expected.t) / scenario.sim.dt, 2)  # type: ignore[union-attr]
        for m in matched
    ]
    run: dict[str, object] = {
        "scenario": scenario.name,
        "timing": timing,
        "events": len(matched),
        "expected": len(scenario.expected),
        "event_shift_periods": shifts,
        "min_distance": [round(d, 4) for d in result.min_distance],
        "halt": result.halt,
    }
    if crossed is not None:
        run["bridge"] = crossed
    if vm0 is not None and vm1 is not None:
        # The emulated side's cost: QEMU's CPU time per control period, from
        # the firmware's start to the run's end (arming included).
        run["vm_cpu_ms_per_period"] = round(1e3 * (vm1 - vm0) / ((t1 - t0) * 50.0), 3)
    return run


def _machine() -> dict[str, object]:
    return {
        "where": os.environ.get("MSTC_VCAN_WHERE", "host"),
        "machine": platform.machine(),
        "load": round(os.getloadavg()[0], 1),
        "date": time.strftime("%Y-%m-%d"),
    }


def bench(fw: Path, channel: str) -> dict[str, object]:
    """One real-time run per scenario, each on a fresh mstc-fw."""
    return {
        "kind": "realtime",
        "channel": channel,
        **_machine(),
        "runs": [run_one(fw, channel, path) for path in SCENARIOS],
    }


def judge(run: dict[str, object]) -> list[str]:
    """What a real-time run missed of the timing a HIL rig promises
    (tests/python/test_hil.py asserts the same): empty when it held."""
    t = run["timing"]
    assert isinstance(t, dict)
    missed = []
    if t["plant"]["missed_periods"]:
        missed.append(f"plant missed {t['plant']['missed_periods']}")
    if t["firmware"]["stale_steps"]:
        missed.append(f"stale {t['firmware']['stale_steps']}")
    if abs(t["wheel_cmd_period_ms"]["p99"] - 20.0) > 2.0:
        missed.append(f"WHEEL_CMD p99 {t['wheel_cmd_period_ms']['p99']:.2f} ms")
    shifts = run["event_shift_periods"]
    assert isinstance(shifts, list)
    if run["events"] != run["expected"] or any(abs(d) > 2 for d in shifts):
        missed.append(f"events {run['events']} of {run['expected']} {shifts}")
    crossed = run.get("bridge")
    if isinstance(crossed, dict) and (crossed["dropped_to_vcan"] or crossed["dropped_to_plant"]):
        missed.append(f"bridge dropped {crossed}")
    return missed


def load(fw: Path, channel: str, busy: list[int], runs: int) -> dict[str, object]:
    """@p runs real-time runs of each scenario with each count of @p busy
    CPU-bound processes (normal priority) running beside them."""
    out: list[dict[str, object]] = []
    for n in busy:
        hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]
        try:
            for i in range(runs):
                for path in SCENARIOS:
                    run = run_one(fw, channel, path)
                    run["busy"] = n
                    run["load"] = round(os.getloadavg()[0], 1)
                    missed = judge(run)
                    run["missed"] = missed
                    print(
                        f"busy {n} run {i + 1} {run['scenario']}: "
                        f"{'; '.join(missed) or 'ok'} "
                        f"(p99 {run['timing']['wheel_cmd_period_ms']['p99']:.2f} ms, "  # type: ignore[index]
                        f"load {run['load']})",
                        flush=True,
                    )
                    out.append(run)
        finally:
            for h in hogs:
                h.kill()
                h.wait()
    return {"kind": "hil-load", "channel": channel, **_machine(), "runs": out}


LOAD_BEGIN = "<!-- bench:hil-load:begin (written by make hil-load, mstc.bench.realtime) -->"
LOAD_END = "<!-- bench:hil-load:end -->"


def load_section(r: dict[str, object]) -> str:
    """docs/hil.md's table of the load test."""
    runs = r["runs"]
    assert isinstance(runs, list)
    lines = [
        f"`make hil-load` ({r['date']}, {r['where']}; load average {r['load']} at the end): "
        "real-time runs of both paper scenarios, each on a fresh firmware, with 0, 1, 2 "
        "CPU-bound processes at normal priority beside them. A run holds when no plant "
        "sample is missed, no step is stale, the WHEEL_CMD period's p99 is within 2 ms of "
        "20 ms, every event is within two periods of the paper's and the bridge lost "
        "nothing.\n",
        "| busy cores | runs held | plant samples missed | stale steps | WHEEL_CMD p99 "
        "[ms] (worst) | latency p50 [ms] | event shift [periods] (worst) | bridge dropped "
        "| plant CPU per sample [ms] | emulated side, QEMU CPU per period [ms] | host load |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n in sorted({int(x["busy"]) for x in runs}):
        rs = [x for x in runs if x["busy"] == n]
        t = [x["timing"] for x in rs]
        p99 = [x["wheel_cmd_period_ms"]["p99"] for x in t]
        lat = [x["latency_ms"]["p50"] for x in t]
        shift = max((abs(d) for x in rs for d in x["event_shift_periods"]), default=0.0)
        dropped = sum(
            x["bridge"]["dropped_to_vcan"] + x["bridge"]["dropped_to_plant"]
            for x in rs
            if "bridge" in x
        )
        cpu = [x["plant_cpu_ms_per_sample"] for x in t]
        vm = [x["vm_cpu_ms_per_period"] for x in rs if "vm_cpu_ms_per_period" in x]
        loads = [x["load"] for x in rs]
        lines.append(
            f"| {n} | {sum(not x['missed'] for x in rs)} of {len(rs)} | "
            f"{sum(x['plant']['missed_periods'] for x in t)} | "
            f"{sum(x['firmware']['stale_steps'] for x in t)} | "
            f"{sorted(p99)[len(p99) // 2]:.2f} ({max(p99):.2f}) | "
            f"{sorted(lat)[len(lat) // 2]:.2f} | {shift:.2f} | {dropped} | "
            f"{sorted(cpu)[len(cpu) // 2]:.2f} | "
            + (f"{sorted(vm)[len(vm) // 2]:.2f}" if vm else "n/a")
            + f" | {min(loads)}–{max(loads)} |"
        )
    lines.append("")
    return "\n".join(lines)


def section(r: dict[str, object]) -> str:
    """The document's section."""
    where = vcan_where(r["where"], "mstc-fw")
    lines = [
        "## Real time: the plant on the wall clock, mstc-fw on its own timer\n",
        f"One `mstc hil --realtime` run per paper scenario over `{r['channel']}` ({where}; "
        f"load average {r['load']} when it ran), against `mstc-fw --realtime --period-ms "
        "20`, each on a fresh firmware; the figures are the runs' timing.json (docs/hil.md). "
        "Period: between WHEEL_CMD arrivals at the plant. Latency: from sending an ODOM_XY frame "
        "to the arrival of the first wheel command computed from it (paired through the "
        "STATUS_TRK_odom_counter echo).\n",
        "| scenario | period mean / p50 / p99 / max [ms] | latency p50 / p99 / max [ms] "
        "| missed, doubled periods | plant samples missed | stale steps | plant CPU per "
        "sample [ms] | events: shift from the paper's [periods] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for run in r["runs"]:  # type: ignore[attr-defined]
        t = run["timing"]
        p, lat, fw, plant = t["wheel_cmd_period_ms"], t["latency_ms"], t["firmware"], t["plant"]
        shifts = ", ".join(f"{s:+g}" for s in run["event_shift_periods"]) or "none"
        lines.append(
            f"| {run['scenario']} | {p['mean']:.2f} / {p['p50']:.2f} / {p['p99']:.2f} / "
            f"{p['max']:.2f} | {lat['p50']:.2f} / {lat['p99']:.2f} / {lat['max']:.2f} | "
            f"{fw['missed_periods']}, {fw['doubled_periods']} | {plant['missed_periods']} of "
            f"{plant['samples']} | {fw['stale_steps']} | {t['plant_cpu_ms_per_sample']:.1f} | "
            f"{run['events']} of {run['expected']}: {shifts} |"
        )
    lines += [
        "",
        "Through the bridge only vcan0 and the firmware run on the emulated CPU; the plant "
        "runs on the host (the plant CPU column), and the run holds the plant and the VM at "
        'the real-time priority SCHED_RR 1 while it lasts (docs/hil.md, "The bridge"). '
        "The bridge's own latency and what the emulated side costs per period are in "
        "docs/hil.md; the load test (`make hil-load`) repeats these runs beside busy cores.",
        "",
        "On a workstation with a host vcan (docs/hil.md) there is no emulation: the same run "
        "should show a period within a fraction of a millisecond of 20 ms, a latency of about "
        "three quarters of a period (the plant samples a quarter of a period after the "
        "firmware's wheel commands) plus well under a millisecond of bus and processing, and "
        "no missed or stale periods. "
        "Measure it there with `make bench` or `make hil REALTIME=1`.\n",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m mstc.bench.realtime", description=__doc__.split("\n\n")[0]
    )
    sub = ap.add_subparsers(dest="cmd", required=True)
    run = sub.add_parser("run", help="one real-time run per scenario over SocketCAN")
    lo = sub.add_parser("load", help="real-time runs beside CPU-bound processes")
    for p in (run, lo):
        p.add_argument("--fw", type=Path, required=True)
        p.add_argument("--channel", default="vcan0")
        p.add_argument("--out", type=Path, required=True)
    lo.add_argument("--busy", type=int, nargs="+", default=[0, 1, 2])
    lo.add_argument("--runs", type=int, default=5, help="runs of each scenario per busy count")
    rep = sub.add_parser("report", help="print the figures and write them into a document")
    lrep = sub.add_parser("load-report", help="the load test's table into a document")
    for p in (rep, lrep):
        p.add_argument("--doc", type=Path, required=True)
        p.add_argument("result", type=Path)
    a = ap.parse_args(argv)
    if a.cmd == "report":
        report(a.doc, section(json.loads(a.result.read_text())), BEGIN, END)
        return 0
    if a.cmd == "load-report":
        report(a.doc, load_section(json.loads(a.result.read_text())), LOAD_BEGIN, LOAD_END)
        return 0
    if a.cmd == "load":
        result = load(a.fw, a.channel, a.busy, a.runs)
        write_result(a.out, result)
        runs = result["runs"]
        assert isinstance(runs, list)
        return 0 if all(not r["missed"] for r in runs) else 1
    write_result(a.out, bench(a.fw, a.channel))
    return 0


if __name__ == "__main__":
    sys.exit(main())
