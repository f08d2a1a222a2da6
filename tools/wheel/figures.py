# SPDX-License-Identifier: MIT
"""figures.py: the wheel loop's figures for docs/wheel.md (make wheel-figures).

Reads what ``wheel_study`` wrote in each numeric mode's directory
(build/wheel/<mode>/: estimator.txt, and step, small, ramp, stall, load .csv),
measures the closed loop's figures from the true speeds of the motor model
(not from the loop's own estimate), draws docs/img/wheel-response.png and
replaces the section of the document between its wheel-figures markers.

    figures.py --doc docs/wheel.md --img docs/img build/wheel/float build/wheel/fixed
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from dataclasses import dataclass
from pathlib import Path

BEGIN = "<!-- wheel-figures:begin (written by make wheel-figures, tools/wheel/figures.py) -->"
END = "<!-- wheel-figures:end -->"
BAND = 0.02  # settling band, of the setpoint
TARGET = 20.0  # rad/s of the step, stall, load runs
STALL_RELEASE_S = 1.3
LOAD_AT_S = 0.5
SMALL_AT_S = 0.5


@dataclass(frozen=True)
class Run:
    t: list[float]
    setpoint: list[float]
    speed: list[float]
    estimate: list[float]
    drive: list[float]


def read_run(path: Path) -> Run:
    with path.open(newline="") as f:
        rows = [[float(x) for x in r] for r in list(csv.reader(f))[1:]]
    cols = list(zip(*rows, strict=True))
    return Run(*(list(c) for c in cols))


def settle_time(run: Run, start: float, target: float, until: float = math.inf) -> float:
    """Last time in [start, until) the true speed is outside ±BAND of @p target,
    less @p start."""
    last = start
    for t, w in zip(run.t, run.speed, strict=True):
        if start <= t < until and abs(w - target) > BAND * abs(target):
            last = t
    return last - start


def rise_63(run: Run, start: float, w0: float, w1: float) -> float:
    """Time after @p start for the true speed to cover 63.2 % of w0 -> w1."""
    level = w0 + (1.0 - math.exp(-1.0)) * (w1 - w0)
    for t, w in zip(run.t, run.speed, strict=True):
        if t >= start and (w - level) * (w1 - w0) >= 0.0:
            return t - start
    return math.nan


def first_order_fit(run: Run, start: float, w0: float, w1: float, span: float) -> float:
    """The first-order lag tau that best fits the step w0 -> w1 at @p start
    over @p span seconds (least squares over a grid of 0.1 ms)."""
    pts = [
        (t - start, w) for t, w in zip(run.t, run.speed, strict=True) if start <= t < start + span
    ]
    best, best_err = math.nan, math.inf
    for i in range(1, 2000):
        tau = i * 1e-4
        err = sum((w - (w1 + (w0 - w1) * math.exp(-dt / tau))) ** 2 for dt, w in pts)
        if err < best_err:
            best, best_err = tau, err
    return best


def noise(run: Run, start: float, end: float) -> float:
    """Rms of the estimate less the true speed over [start, end)."""
    err = [
        e - w for t, e, w in zip(run.t, run.estimate, run.speed, strict=True) if start <= t < end
    ]
    return math.sqrt(sum(x * x for x in err) / len(err))


def figures(d: Path) -> dict[str, float]:
    step, small, ramp = (read_run(d / f"{n}.csv") for n in ("step", "small", "ramp"))
    stall, load = read_run(d / "stall.csv"), read_run(d / "load.csv")
    released = [w for t, w in zip(stall.t, stall.speed, strict=True) if t >= STALL_RELEASE_S]
    loaded = [w for t, w in zip(load.t, load.speed, strict=True) if t >= LOAD_AT_S]
    return {
        "step_settle": settle_time(step, 0.0, TARGET, until=LOAD_AT_S),
        "step_overshoot": (max(step.speed) - TARGET) / TARGET * 100.0,
        "step_63": rise_63(step, 0.0, 0.0, TARGET),
        "step_tau": first_order_fit(step, 0.0, 0.0, TARGET, 0.3),
        "small_63": rise_63(small, SMALL_AT_S, 10.0, 12.0),
        "small_tau": first_order_fit(small, SMALL_AT_S, 10.0, 12.0, 0.3),
        "small_settle": settle_time(small, SMALL_AT_S, 12.0),
        "ramp_error": max(abs(w - s) for w, s in zip(ramp.speed, ramp.setpoint, strict=True)),
        "release_overshoot": (max(released) - TARGET) / TARGET * 100.0,
        "load_dip": TARGET - min(loaded),
        "load_recovery": settle_time(load, LOAD_AT_S, TARGET),
        "noise": noise(small, 0.3, SMALL_AT_S),
    }


ROWS = (
    ("step 0 → 20 rad/s: settled within 2 %", "step_settle", "ms", 1e3, "< 150 ms"),
    ("step 0 → 20 rad/s: overshoot", "step_overshoot", "%", 1.0, "≤ 10 %"),
    ("step 0 → 20 rad/s: 63 % of the way", "step_63", "ms", 1e3, "—"),
    ("step 0 → 20 rad/s: first-order lag fitted", "step_tau", "ms", 1e3, "—"),
    ("step 10 → 12 rad/s: 63 % of the way", "small_63", "ms", 1e3, "—"),
    ("step 10 → 12 rad/s: first-order lag fitted", "small_tau", "ms", 1e3, "—"),
    ("step 10 → 12 rad/s: settled within 2 %", "small_settle", "ms", 1e3, "—"),
    ("ramp 125 rad/s² (0 → 20 → −20 → 0): largest error", "ramp_error", "rad/s", 1.0, "≤ 1 rad/s"),
    ("release after a 1 s hold: overshoot", "release_overshoot", "%", 1.0, "≤ 10 %"),
    ("load step, 30 % of stall torque: dip", "load_dip", "rad/s", 1.0, "—"),
    ("load step, 30 % of stall torque: back within 2 %", "load_recovery", "ms", 1e3, "< 100 ms"),
    ("estimate − true speed at 10 rad/s, rms", "noise", "rad/s", 1.0, "< 0.4 rad/s"),
)


def section(dirs: list[Path], estimator: str, figs: dict[str, dict[str, float]], img: str) -> str:
    out = [BEGIN, ""]
    out.append("### The speed estimate, measured\n")
    out.append(
        "`wheel_study estimator` (tools/wheel/wheel_study.c): the encoder of a shaft turning at "
        "exactly 10 rad/s (64 phases of the count), and of one accelerating at 250 rad/s²; the "
        "window is the firmware's own `whl_step`, the tracking loop ODrive's PLL (encoder.cpp, "
        "gains 2·bw and bw², in double).\n"
    )
    lines = [ln for ln in estimator.splitlines() if ln and not ln.startswith("#")]
    out.append("| " + lines[0] + " |")
    out.append("|---|---|---:|---:|---:|")
    out += ["| " + ln + " |" for ln in lines[1:]]
    out.append("")
    out.append("### The closed loop against the motor model, measured\n")
    out.append(
        "`wheel_study response` in each numeric mode, the defaults of the limits table "
        "(the ramp 125 rad/s² for the ramp and the hold, none for the steps and the load; "
        "stall_time 5 s for the hold, so that the windup is what shows), figures from the "
        "model's true speed at 1 kHz (tools/wheel/figures.py).\n"
    )
    modes = [d.name for d in dirs]
    out.append("| | " + " | ".join(modes) + " | acceptance |")
    out.append("|---|" + "---:|" * len(modes) + "---|")
    for label, key, unit, scale, acc in ROWS:
        digits = 1 if unit in ("ms", "%") else 3
        cells = [f"{figs[m][key] * scale:.{digits}f} {unit}" for m in modes]
        out.append(f"| {label} | " + " | ".join(cells) + f" | {acc} |")
    out.append("")
    out.append(f"![The closed loop in the acceptance's situations]({img})\n")
    out.append("Reproduce: `make wheel-figures`.\n")
    out.append(END)
    return "\n".join(out)


def plot(dirs: list[Path], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [
        ("step", "step 0 → 20 rad/s"),
        ("ramp", "ramp 125 rad/s²"),
        ("stall", "held 0.3–1.3 s, released"),
        ("load", "load 30 % of stall at 0.5 s"),
    ]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharey=False)
    for ax, (name, title) in zip(axes.flat, names, strict=True):
        for d, style in zip(dirs, ("-", "--"), strict=False):
            r = read_run(d / f"{name}.csv")
            ax.plot(r.t, r.speed, style, label=f"wheel speed ({d.name})")
        r = read_run(dirs[0] / f"{name}.csv")
        ax.plot(r.t, r.setpoint, ":", color="black", label="ramped setpoint")
        ax.set_title(title)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("rad/s")
        ax.grid(True, alpha=0.3)
    axes.flat[0].legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--doc", type=Path, required=True)
    ap.add_argument("--img", type=Path, required=True)
    ap.add_argument("dirs", type=Path, nargs="+")
    a = ap.parse_args()
    figs = {d.name: figures(d) for d in a.dirs}
    estimator = (a.dirs[0] / "estimator.txt").read_text()
    png = a.img / "wheel-response.png"
    plot(a.dirs, png)
    body = section(a.dirs, estimator, figs, f"img/{png.name}")
    text = a.doc.read_text(encoding="utf-8")
    start, end = text.find(BEGIN), text.find(END)
    if start < 0 or end < start:
        sys.exit(f"figures.py: {a.doc} has no section between '{BEGIN}' and '{END}'")
    a.doc.write_text(text[:start] + body + text[end + len(END) :], encoding="utf-8")
    print(body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
