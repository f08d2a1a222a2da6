# SPDX-License-Identifier: MIT
"""What one run is judged by: the metrics of a row of runs.csv.

Every metric is computed from the trace (true poses of robot, reference and
obstacles at each step), so every strategy, the firmware's and the DWA
baseline's, is judged by the same code. Definitions (docs/sweeps.md):

- tracking error e_k: distance between the robot's and the reference's
  centres at step k [m];
- clearance: centre distance minus (R_m + obstacle radius), the gap between
  the two bodies [m]; **contact**: a clearance below 0 at any step;
- **D_s kept**: every centre distance at or above that obstacle's D_s at
  every step;
- **the last obstacle** is left at t_last, the last step at which the robot
  is within any obstacle's D_act or its controller is not tracking it
  (mode ``avoid`` or ``blocked``), 0 when neither ever happens. The mode
  counts because a strategy may go round an obstacle without coming within
  its D_act (a moving obstacle met early): the robot is still busy with it;
- **rejoined**: judged on every *pass*, the free time between leaving an
  obstacle (a busy step as above) and the next busy step or the end of the
  run; a run without a busy step is one pass from t = 0. A pass is *back*
  when from some step no later than 10 s after its start to its end the
  tracking error stays under 0.05 m; it *failed* when it is not back and
  lasts 10 s or more; otherwise (shorter, the robot busy again or the run
  over before its window ends) it cannot tell. The run is rejoined (True)
  when no pass failed and at least one is back or failed, that is, was
  judged; not rejoined (False) when one failed; *not judged* (None) when no
  pass could tell. The last pass alone is the issue's "within 10 s after the
  last obstacle"; the earlier ones judge a circular reference, whose robot
  comes back to an obstacle every lap, up to the end of the run;
- **blocked**: the controller reports mode ``blocked`` at the last step, or
  over the last 5 s the robot travelled less than a tenth of the reference's
  path: it stands while the reference goes on;
- time in avoidance, switches: the periods run in mode ``avoid``, and the
  number of mode changes;
- path ratio: the robot's path length over the reference's;
- ∫|ω|dt: Σ |ω_k| dt over the periods k = 0..N-1 (commanded ω, held);
- step cost: mean wall time of one controller step in the process that ran
  it (a measurement; it differs from run to run).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from mstc.loop.result import RunResult
from mstc.model import EventKind, Mode

REJOIN_ERROR = 0.05
"""Tracking error under which the robot is back on its reference [m]."""
REJOIN_WINDOW = 10.0
"""Time after the last obstacle within which it must be back [s]."""
_BUSY = (Mode.AVOID, Mode.BLOCKED)
"""Modes in which the controller is busy with an obstacle (t_last)."""
BLOCKED_WINDOW = 5.0
"""The end of the run that decides whether the robot is blocked [s]."""
BLOCKED_SHARE = 0.1
"""Blocked: travelled less than this share of the reference's path over the window."""


@dataclass(frozen=True)
class Metrics:
    """The judged outcome of one run (columns of runs.csv, in order)."""

    contact: bool
    min_clearance: float
    """Smallest clearance over the run and obstacles [m]; inf without obstacles."""
    ds_kept: bool
    rejoined: bool | None
    """None: not judged, no pass could tell (the module's docstring)."""
    blocked: bool
    t_last: float
    """When the last obstacle was left [s]."""
    avoid_time: float
    """[s]"""
    rms_error: float
    """RMS of the tracking error over the run [m]."""
    final_error: float
    """Tracking error at the end [m]."""
    path_ratio: float
    """Robot path length / reference path length."""
    int_abs_w: float
    """∫|ω|dt [rad]."""
    switches: int
    max_activations: int
    """Most activate events of one obstacle."""
    step_us: float
    """Mean controller step cost [µs] (a measurement, not reproducible)."""


METRIC_COLUMNS = tuple(f.name for f in fields(Metrics))
"""The metric columns of runs.csv, in order."""


def _path_length(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.hypot(np.diff(x), np.diff(y)).sum())


def _rejoined(t: np.ndarray, error: np.ndarray, busy: np.ndarray) -> bool | None:
    """Every pass judged (the module's docstring): False when one failed,
    True when none failed and one was back, None when none could tell."""
    ends = np.flatnonzero(busy[:-1] & ~busy[1:])  # the last busy step of each
    starts = np.flatnonzero(~busy[:-1] & busy[1:]) + 1  # the first busy step of each
    if not busy.any():
        passes = [(0.0, 0, len(t) - 1)]
    else:
        passes = []
        for e in ends:
            nxt = starts[starts > e]
            passes.append((float(t[e]), int(e) + 1, int(nxt[0]) - 1 if len(nxt) else len(t) - 1))
    judged = False
    for t0, a, b in passes:
        deadline = t0 + REJOIN_WINDOW + 1e-9
        bad = np.flatnonzero(error[a : b + 1] >= REJOIN_ERROR)
        back_from = a if not len(bad) else a + int(bad[-1]) + 1
        if back_from <= b and t[back_from] <= deadline:
            judged = True
        elif t[b] >= t0 + REJOIN_WINDOW - 1e-9:
            return False
    return True if judged else None


def evaluate(result: RunResult) -> Metrics:
    """The metrics of a run (definitions: this module's docstring)."""
    scenario = result.scenario
    p = scenario.params
    trace = result.trace
    t = trace["t"]
    x, y, xr, yr = trace["x"], trace["y"], trace["x_r"], trace["y_r"]
    dt = scenario.sim.dt
    error = np.hypot(x - xr, y - yr)

    radii = np.array([o.radius for o in scenario.obstacles])
    if len(radii):
        clearance = trace.distance - (p.r_m + radii)
        min_clearance = float(clearance.min())
        safe = np.array([p.safe_distance(r) for r in radii])
        active = np.array([p.activation_distance(r) for r in radii])
        ds_kept = bool((trace.distance >= safe).all())
        near = (trace.distance <= active).any(axis=1)
    else:
        min_clearance, ds_kept = math.inf, True
        near = np.zeros(len(t), dtype=bool)
    busy = near | np.array([m in _BUSY for m in trace.mode], dtype=bool)
    t_last = float(t[np.flatnonzero(busy)[-1]]) if busy.any() else 0.0

    rejoined = _rejoined(t, error, busy)

    window = t >= t[-1] - BLOCKED_WINDOW
    moved = _path_length(x[window], y[window])
    ref_moved = _path_length(xr[window], yr[window])
    blocked = str(trace.mode[-1]) == "blocked" or (
        ref_moved > 0.0 and moved < BLOCKED_SHARE * ref_moved
    )

    modes = trace.mode
    avoid_steps = sum(1 for m in modes[:-1] if m is Mode.AVOID)
    switches = sum(1 for a, b in zip(modes, modes[1:], strict=False) if a is not b)
    activations: dict[int, int] = {}
    for e in result.events:
        if e.kind is EventKind.ACTIVATE:
            activations[e.obstacle] = activations.get(e.obstacle, 0) + 1
    ref_length = _path_length(xr, yr)
    return Metrics(
        contact=min_clearance < 0.0,
        min_clearance=min_clearance,
        ds_kept=ds_kept,
        rejoined=rejoined,
        blocked=blocked,
        t_last=t_last,
        avoid_time=avoid_steps * dt,
        rms_error=float(np.sqrt(np.mean(error * error))),
        final_error=float(error[-1]),
        path_ratio=_path_length(x, y) / ref_length if ref_length > 0.0 else math.nan,
        int_abs_w=float(np.abs(trace["w"][:-1]).sum() * dt),
        switches=switches,
        max_activations=max(activations.values(), default=0),
        step_us=result.step_time * 1e6,
    )
