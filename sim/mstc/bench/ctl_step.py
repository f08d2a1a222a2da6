# SPDX-License-Identifier: MIT
"""The control step's benchmark: its raw results as the table `make bench`
prints and writes into docs/performance.md.

Inputs are the `key value` lines of tools/bench/bench_target.c (one file per
Cortex-M image, run under QEMU) and tools/bench/bench_host.c (one per numeric
mode). The section between the markers below is replaced in the document, so
other sections (later benchmarks) are kept. Figures and ratios are reported
against the targets of the issue; nothing here fails on a figure: only
missing or malformed results are errors.

With --pil build/pil, the section also gives the instructions per control
step the board images counted in the closed loop under QEMU (`make pil`:
loop_stats.json of each board and scenario), beside ctl_step's.

Usage: python -m mstc.bench.ctl_step --doc docs/performance.md [--pil build/pil] RESULT.txt...
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any

from mstc.bench.doc import report

BEGIN = "<!-- bench:ctl_step:begin (written by make bench, mstc.bench.ctl_step) -->"
END = "<!-- bench:ctl_step:end -->"

# Cortex-M builds: config -> (label, QEMU machine, instruction target).
TARGETS = {
    "m4f-float": ("Cortex-M4F, float (FPU)", "mps2-an386", 1500),
    "m3-fixed": ("Cortex-M3, fixed Q16.16", "mps2-an385", 2500),
    "m3-float": ("Cortex-M3, float (soft float)", "mps2-an385", None),
}
RATIO_TARGET = 4.0  # M3: soft float / fixed
# "mstc" with 8 obstacles in view: instructions per step (issue 19's targets,
# with the wheels' limits, prediction and braking guard; issue 17's were
# 3,000 and 6,000 for the strategy on ideal wheels).
LOAD_TARGETS = {"m4f-float": 3500, "m3-fixed": 7000}

# Board images in the loop (make pil): board -> (label, clock of the real board
# [Hz], the ctl_step build of the same core and numeric mode).
BOARDS = {
    "stm32f405": ("STM32F405, float", 168_000_000, "m4f-float"),
    "stm32f103": ("STM32F103, fixed Q16.16", 72_000_000, "m3-fixed"),
}
Result = dict[str, Any]
"""One build's results, parsed (:func:`parse`)."""

PERIOD_S = 0.020
# The wheel loop (firmware/wheel, issue 20): instructions per period, both
# wheels, and the board that runs each build at 1 kHz.
WHEEL_TARGETS = {"m4f-float": 400, "m3-fixed": 800}
WHEEL_BOARDS = {"m4f-float": ("STM32F405", 168_000_000), "m3-fixed": ("STM32F103", 72_000_000)}
WHEEL_RATE_HZ = 1000
CYCLES_PER_INSTRUCTION = 2  # the assumed upper bound


def parse_pil(pil_dir: Path) -> dict[str, list[Result]]:
    """loop_stats.json of every board and scenario under @p pil_dir, by board."""
    found: dict[str, list[Result]] = {}
    for board in BOARDS:
        for path in sorted((pil_dir / board).glob("*/loop_stats.json")):
            record = json.loads(path.read_text())
            record["scenario"] = path.parent.name
            found.setdefault(board, []).append(record)
    return found


def pil_section(pil: dict[str, list[Result]], results: dict[str, Result]) -> str:
    """The subsection on the board images in the loop."""
    out = ["### The control step on the board images, in the loop\n"]
    w = out.append
    w(
        "The images `make flash` writes, in their PIL variant (CAN=slcan, and the wheels' "
        "drivers swapped for two simulated motors), run the paper's scenarios and its line "
        'on "dc" wheels under "mstc" under QEMU in lock-step with the plant (`make pil`, '
        "docs/hil.md). Each control "
        "step is timed on the image itself with SysTick from the STEP frame into "
        "`app_on_frame` to its return: decoding the frame, the safety supervisor, "
        "`ctl_step`, encoding and queueing the answers, and the serial line's interrupt "
        "work meanwhile. Under `-icount shift=0` a SysTick count is 10⁹ / f instructions, "
        "f the core clock QEMU models (168 MHz on netduinoplus2, 120 MHz on netduino2). "
        f"The share of the {PERIOD_S * 1000:.0f} ms period is at the real board's clock "
        f"assuming at most {CYCLES_PER_INSTRUCTION} cycles per instruction on average "
        "(an assumption for the budget, not a measurement of cycles).\n"
    )
    w(
        "| image | scenario | QEMU machine | steps | instructions/step (mean) | largest step "
        "| `ctl_step` alone (mean, above) | share of the period (mean / largest) |"
    )
    w("|---|---|---|---:|---:|---:|---:|---|")
    for board, records in pil.items():
        label, hz, cfg = BOARDS[board]
        alone = float(results[cfg]["instr_per_step"]) if cfg in results else None
        for r in records:
            ins = r["instructions_per_step"]
            share = [100 * ins[k] * CYCLES_PER_INSTRUCTION / hz / PERIOD_S for k in ("mean", "max")]
            w(
                f"| {label} (`{board}-pil`, {hz / 1e6:.0f} MHz) | {r['scenario']} "
                f"| {r['machine']} | {r['steps']:,} | **{fmt_int(ins['mean'])}** "
                f"| {fmt_int(ins['max'])} | {fmt_int(alone) if alone else '—'} "
                f"| {share[0]:.2f} % / {share[1]:.2f} % |"
            )
    w("")
    w(
        "- The difference to `ctl_step` alone is the application and the transport: "
        "each step checks and decodes the STEP frame, closes the E2E cycle of five "
        "inputs, encodes three frames or more (CRC-8 over each) and formats them as "
        "slcan lines, byte by byte through the UART interrupt; and the images are "
        "built for size (-Os), the benchmark for speed (-O2)."
    )
    w(
        "- From run to run the figures move by about 1 %: an interrupt (SysTick's, a "
        "byte of the next step's frames) may fall inside a step or not."
    )
    both = [
        (b, r)
        for b, records in pil.items()
        for r in records
        if "figures" in r.get("wheel_loop", {})
    ]
    if both:
        w("")
        w(both_loops_section(both))
    return "\n".join(out) + "\n"


CPU_TARGET_PERCENT = 10.0  # the F103 at 72 MHz, both loops (issue 32)


def both_loops_section(runs: list[tuple[str, Result]]) -> str:
    """Both loops on the board, from the "dc" runs of `make pil`: the wheel
    loop's instructions per millisecond tick and the control step's, and the
    core's share they take at the real board's clock."""
    out = ["#### Both loops on the board: the wheel loop and the control step\n"]
    w = out.append
    w(
        'The "dc" run of `make pil`: the wheel loop closes every millisecond on the '
        'image\'s simulated motors (docs/hil.md, "The wheels in the loop"), the control '
        "step runs on its measurements every 20 ms. A wheel period is timed from the "
        "encoder read to the motor command (`wheel_cmd_period()`: `whl_step` for both "
        "wheels and the glue), the simulated motors' own instructions counted apart and "
        "left out; a control step as above. The share of the core is per second at the "
        f"real board's clock: 1,000 wheel periods and 50 control steps, at 1 and at "
        f"{CYCLES_PER_INSTRUCTION} cycles per instruction.\n"
    )
    w(
        "| image | wheel period (mean / largest) | control step (mean / largest) "
        "| share of the core (1 / 2 cycles per instruction) | target |"
    )
    w("|---|---:|---:|---|---|")
    for board, r in runs:
        label, hz, _ = BOARDS[board]
        per = r["wheel_loop"]["instructions_per_period"]
        step = r["instructions_per_step"]
        per_s = per["mean"] * WHEEL_RATE_HZ + step["mean"] / PERIOD_S
        share = [100 * per_s * cpi / hz for cpi in (1, CYCLES_PER_INSTRUCTION)]
        target = (
            f"< {CPU_TARGET_PERCENT:g} %: {'met' if share[1] < CPU_TARGET_PERCENT else 'not met'}"
            if board == "stm32f103"
            else "—"
        )
        w(
            f"| {label} (`{board}-pil`, {hz / 1e6:.0f} MHz) "
            f"| **{fmt_int(per['mean'])}** / {fmt_int(per['max'])} "
            f"| **{fmt_int(step['mean'])}** / {fmt_int(step['max'])} "
            f"| {share[0]:.2f} % / {share[1]:.2f} % | {target} |"
        )
    w("")
    w(
        "The wheel loop's figures from the board's motors in the same runs, against the "
        "plant's twin of them in the host library (docs/hil.md; `test_pil` holds them "
        "within 5 % of a run in process): the time each wheel first reaches 63 % and 90 % "
        "of the command in force, the largest and RMS difference to the command ramped at "
        "`wheel_accel`, over the run's first second, left / right wheel.\n"
    )
    w("| image | | 63 % [ms] | 90 % [ms] | largest error [rad/s] | RMS error [rad/s] |")
    w("|---|---|---|---|---|---|")
    for board, r in runs:
        for who, fig in r["wheel_loop"]["figures"].items():
            cells = " | ".join(
                " / ".join(f"{v:.{d}f}" for v in fig[k])
                for k, d in (
                    ("rise_63_ms", 1),
                    ("rise_90_ms", 1),
                    ("track_max", 3),
                    ("track_rms", 3),
                )
            )
            w(f"| `{board}-pil` | {who} | {cells} |")
    return "\n".join(out) + "\n"


def parse(path: Path) -> Result:
    """One result file: scalars by key, and the repeated keys as lists."""
    r: Result = {"scenario": [], "events": [], "by_mode": {}, "prim": {}, "load": []}
    for line in path.read_text().splitlines():
        key, _, rest = line.partition(" ")
        if key == "scenario":
            f = rest.split()
            r["scenario"].append(
                {
                    "name": f[0],
                    "steps": int(f[2]),
                    "events_match": f[4] == "1",
                    "replay_differs": int(f[6]),
                    "min_distance": [float(x) for x in f[8:]],
                }
            )
        elif key == "events":
            name, *ev = rest.split()
            r["events"].append((name, ev))
        elif key == "by_mode":
            f = rest.split()
            r["by_mode"][f[0]] = {"steps": int(f[2]), "mean": float(f[4]), "max": float(f[6])}
        elif key == "load":
            f = rest.split()
            r["load"].append(
                {
                    "name": f[0],
                    "strategy": f[2],
                    "obstacles": int(f[4]),
                    "in_view": float(f[6]),
                    "steps": int(f[8]),
                    "replay_differs": int(f[10]),
                    "mean": float(f[12]),
                    "max": float(f[14]),
                    "min_clearance": float(f[16]),
                }
            )
        elif key in ("load_mode", "load_checksum"):
            pass  # per-mode figures and hashes of the loads: in the raw results only
        elif key == "prim":
            name, value, domain = rest.split(" ", 2)
            r["prim"][name] = (float(value), domain)
        elif key:
            r[key] = rest
    return r


def tool_version(cmd: list[str]) -> str:
    """First line of a tool's version output, or '?'."""
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, check=False).stdout
    except OSError:
        return "?"
    return out.splitlines()[0].strip() if out else "?"


def host_cpu() -> str:
    """The host CPU's model name."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def fmt_int(x: float) -> str:
    return f"{x:,.0f}"


def section(results: dict[str, Result]) -> str:
    """The Markdown section."""
    out: list[str] = []
    w = out.append
    w("## Control step: instructions on Cortex-M, time on the host\n")
    w(
        "One full control step, `ctl_step` (input check, supervisor, the active "
        "controller, kinematics and saturation, distances for telemetry), replayed over "
        'a recorded closed loop of the paper\'s two scenarios under the `"paper"` '
        "strategy "
        "(sim/scenarios/paper-line.toml and paper-circle.toml: forward-Euler unicycle, "
        "0.02 s period, Table 1 parameters; tools/bench/bench_core.c). Each build records "
        "its own closed loop, checks that the replay reproduces it and that the events "
        "are the paper's, then replays it timed. Instructions are counted on the target "
        "ISA under `qemu-system-arm -icount shift=0`, where SysTick (processor clock) "
        "advances once per 40 executed instructions; the loop around the call is "
        "measured the same way with an empty step and subtracted. A benchmark, not a "
        "test: nothing fails on these figures.\n"
    )
    any_cfg = next(iter(results.values()))
    n_steps = int(any_cfg["steps"])
    modes = any_cfg["by_mode"]
    words = {"track": "tracking", "avoid": "avoiding", "stop": "stopped", "blocked": "blocked"}
    w(
        f"Input sequence: {n_steps} steps, "
        + ", ".join(f"{v['steps']} {words.get(k, k)}" for k, v in modes.items())
        + ".\n"
    )
    w(
        "| build | QEMU machine | instructions/step (mean) | mean over tracking steps "
        "| mean over avoiding steps | largest step (±40) | target | paper events reproduced |"
    )
    w("|---|---|---:|---:|---:|---:|---|---|")
    for cfg, (label, machine, target) in TARGETS.items():
        r = results.get(cfg)
        if r is None:
            continue
        ips = float(r["instr_per_step"])
        bm = r["by_mode"]
        largest = max(v["max"] for v in bm.values())
        events = all(s["events_match"] and s["replay_differs"] == 0 for s in r["scenario"])
        if target is None:
            tgt = "—"
        else:
            tgt = f"≤ {target:,}: {'met' if ips <= target else '**missed**'}"
        w(
            f"| {label} (`{cfg}`) | {machine} | **{fmt_int(ips)}** "
            f"| {fmt_int(bm['track']['mean']) if 'track' in bm else '—'} "
            f"| {fmt_int(bm['avoid']['mean']) if 'avoid' in bm else '—'} "
            f"| {fmt_int(largest)} | {tgt} | {'yes' if events else '**no**'} |"
        )
    w("")
    if "m3-fixed" in results and "m3-float" in results:
        fixed = float(results["m3-fixed"]["instr_per_step"])
        soft = float(results["m3-float"]["instr_per_step"])
        ratio = soft / fixed
        verdict = "met" if ratio >= RATIO_TARGET else "**missed**"
        w(
            f"- Cortex-M3, soft float / fixed: **{ratio:.2f}×** fewer instructions in fixed "
            f"point (target ≥ {RATIO_TARGET:.0f}×: {verdict})."
        )
    for mode, cfg in (("fixed", "m3-fixed"), ("float", "m4f-float"), ("float", "m3-float")):
        host = results.get(f"host-{mode}")
        if host is not None and cfg in results:
            same = host.get("checksum") == results[cfg].get("checksum")
            w(
                f"- `{cfg}` and the host's {mode} build ran the closed loop "
                + (
                    "bit for bit alike"
                    if same
                    else "with different bits (float results depend on the libm and the "
                    "FPU, and the double-precision plant on the libm)"
                )
                + f" (hash of every pose and wheel command: {results[cfg].get('checksum')}"
                + ("" if same else f" against {host.get('checksum')}")
                + ")."
            )
    if "m3-fixed" in results and "m4f-float" in results:
        fixed = float(results["m3-fixed"]["instr_per_step"])
        m4f = float(results["m4f-float"]["instr_per_step"])
        w(f"- Cortex-M3 fixed / Cortex-M4F float: {fixed / m4f:.2f}× the instructions.")
    w(
        "- Instructions are not cycles: a Cortex-M4F VDIV.F32 or VSQRT.F32 is one "
        "instruction of 14 cycles, a Cortex-M3 UDIV one of 2–12, SMULL/UMULL 3–5."
    )
    w("")

    hosts = {m: results[f"host-{m}"] for m in ("float", "fixed") if f"host-{m}" in results}
    if hosts:
        w(
            f"Host ({host_cpu()}, {tool_version(['cc', '--version'])}, -O2): time per step, "
            f"thread CPU time, median of {next(iter(hosts.values()))['host_runs']} replays of "
            "the whole sequence, less the empty loop.\n"
        )
        w("| mode | ns/step (median) | ns/step (fastest replay) |")
        w("|---|---:|---:|")
        for m, r in hosts.items():
            median, fastest = float(r["host_ns_per_step"]), float(r["host_ns_per_step_min"])
            w(f"| {m} | {median:.0f} | {fastest:.0f} |")
        w("")

    prim_names: list[str] = []
    for r in results.values():
        for name in r["prim"]:
            if name not in prim_names:
                prim_names.append(name)
    cfgs = [c for c in TARGETS if c in results]
    if prim_names:
        w("### Primitives: instructions per call\n")
        w(
            "firmware/num's primitives as the controllers call them (inlined where they are "
            "inline), over 1024 calls with arguments spread over the domain given, less the "
            "same loop without the call. `fix16_*` are libfixmath's, measured for "
            "comparison; the firmware does not use them (docs/numerics.md gives their "
            "accuracy).\n"
        )
        w("| primitive | arguments | " + " | ".join(f"`{c}`" for c in cfgs) + " |")
        w("|---|---|" + "---:|" * len(cfgs))
        for name in prim_names:
            domain = next(r["prim"][name][1] for r in results.values() if name in r["prim"])
            cells = [
                f"{results[c]['prim'][name][0]:.0f}" if name in results[c]["prim"] else "—"
                for c in cfgs
            ]
            w(f"| `{name}` | {domain.replace('|', chr(92) + '|')} | " + " | ".join(cells) + " |")
        w("")

    loads = [(c, results[c]["load"]) for c in TARGETS if c in results and results[c]["load"]]
    if loads:
        w("### With 1, 4, 8 and 48 obstacles in view, both strategies\n")
        w(
            'The control step under `"paper"` and `"mstc"` (docs/strategy.md) on the '
            "paper's scenarios and on four load scenes (tools/bench/bench_core.c): a "
            "circular reference of radius 1.8 m with 1, 4 or 8 obstacles on and inside "
            "it, all within D_det nearly all the time; and load-48, a full table: a "
            "straight reference at 0.5 m/s for 14 s along a corridor through a BARN-like "
            "field of cylinders of radius 0.075 m on a 0.15 m grid (a quarter of the "
            "cells), past a pair of them in the corridor, the sensor reporting the 48 "
            "nearest each step, each under an id it keeps while the cylinder stays "
            "reported (so ids come back elsewhere as the robot moves). *In view* is the "
            "mean number reported per step. Each run is its own closed loop under its "
            "strategy, replayed as above. Clearance: the smallest centre distance less "
            "D_s over the run (negative: D_s violated; below −0.05 m: contact).\n"
        )
        w(
            "| build | scene | strategy | in view | instructions/step (mean) "
            "| largest step (±40) | clearance [m] | target |"
        )
        w("|---|---|---|---:|---:|---:|---:|---|")
        for cfg, runs in loads:
            for ld in runs:
                tgt = "—"
                if ld["name"] == "load-8" and ld["strategy"] == "mstc" and cfg in LOAD_TARGETS:
                    t = LOAD_TARGETS[cfg]
                    tgt = f"≤ {t:,}: {'met' if ld['mean'] <= t else '**missed**'}"
                ok = "" if ld["replay_differs"] == 0 else " (**replay differs**)"
                w(
                    f"| `{cfg}` | {ld['name']}{ok} | {ld['strategy']} | {ld['in_view']:.2f} "
                    f"| **{fmt_int(ld['mean'])}** | {fmt_int(ld['max'])} "
                    f"| {ld['min_clearance']:+.3f} | {tgt} |"
                )
        w("")

    wheel = wheel_section(results)
    if wheel:
        w(wheel)

    w("### Events and distances each build produced\n")
    w("| build | scenario | events (t [s]: kind, obstacle, side) | min distance [m] |")
    w("|---|---|---|---|")
    kinds = {
        "1": "detect",
        "2": "activate",
        "3": "complete",
        "4": "blocked",
        "5": "resume",
        "6": "filter",
    }
    sides = {"1": " left", "-1": " right", "0": ""}
    for cfg in cfgs:
        r = results[cfg]
        for s, (name, ev) in zip(r["scenario"], r["events"], strict=True):
            evs = []
            for e in ev:
                t, k, o, side = e.split(":")
                evs.append(f"{t} {kinds.get(k, k)} O{o}{sides.get(side, side)}")
            w(
                f"| `{cfg}` | {name} | {'; '.join(evs)} | "
                + ", ".join(f"{d:.4f}" for d in s["min_distance"])
                + " |"
            )
    w("")
    w(
        "Tools: "
        + tool_version(["arm-none-eabi-gcc", "--version"])
        + " (-O2, firmware/*/*.c and libfixmath as `make cross` builds them); "
        + tool_version(["qemu-system-arm", "--version"])
        + ". Reproduce: `make bench` (results cached in build/bench/; delete them to "
        "measure again)."
    )
    return "\n".join(out) + "\n"


def wheel_section(results: dict[str, Result]) -> str:
    """The wheel loop's figures (tools/bench/bench_wheel.c), or "" without."""
    rows = []
    for cfg, (label, machine, _) in TARGETS.items():
        r = results.get(cfg)
        if r is None or "wheel" not in r:
            continue
        f = r["wheel"].split()
        mean, largest, differ = float(f[5]), float(f[7]), int(f[3])
        target = WHEEL_TARGETS.get(cfg)
        tgt = "—" if target is None else f"≤ {target}: {'met' if mean <= target else '**missed**'}"
        share = "—"
        if cfg in WHEEL_BOARDS:
            board, clock = WHEEL_BOARDS[cfg]
            one = mean * WHEEL_RATE_HZ / clock * 100.0
            share = f"{board} at {clock / 1e6:.0f} MHz: {one:.2f} % ({2 * one:.2f} % at 2 cycles)"
        ok = "" if differ == 0 else " (**replay differs**)"
        rows.append(
            f"| {label} (`{cfg}`){ok} | {machine} | **{fmt_int(mean)}** | {fmt_int(largest)} "
            f"| {tgt} | {share} |"
        )
    if not rows:
        return ""
    head = [
        "### Wheel loop: instructions per period, both wheels\n",
        "`whl_step` for both wheels (firmware/wheel: speed from the encoder counts, "
        "setpoint ramp, PI with feed-forward, anti-windup, the fault checks), replayed over "
        "3,000 recorded periods of its closed loop at 1 kHz against two DC motor models "
        "(tools/bench/bench_wheel.c: the default motor of docs/wheel.md through a start, a "
        "turn with a 30 %-of-stall load, a reversal and a stop), timed like the control step "
        "above, less the same loop around an empty step. The share of the core is at the "
        "board's clock and the default rate, 1 kHz, at one cycle per instruction (and at "
        "two, the bound the board images' budget assumes).\n",
        "| build | QEMU machine | instructions/period (mean) | largest period (±40) "
        "| target | share of the core at 1 kHz |",
        "|---|---|---:|---:|---|---|",
    ]
    return "\n".join(head + rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m mstc.bench.ctl_step", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--doc", type=Path, required=True)
    ap.add_argument(
        "--pil",
        type=Path,
        metavar="DIR",
        help="build/pil: add the board images' figures in the loop (make pil)",
    )
    ap.add_argument("results", type=Path, nargs="+")
    a = ap.parse_args(argv)
    results = {}
    for p in a.results:
        r = parse(p)
        if "config" not in r or "steps" not in r:
            sys.exit(f"error: {p}: not a benchmark result")
        results[r["config"]] = r
    body = section(results)
    if a.pil is not None:
        pil = parse_pil(a.pil)
        if not pil:
            sys.exit(f"error: {a.pil}: no loop_stats.json (make pil writes them)")
        body += "\n" + pil_section(pil, results)
    report(a.doc, body, BEGIN, END)
    return 0


if __name__ == "__main__":
    sys.exit(main())
