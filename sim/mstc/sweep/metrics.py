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
- **infeasible**: the controller reported an obstacle it could not keep
  away within the wheels' limits (an ``infeasible`` event, strategy
  "mstc"); **contact reported**: a contact at a step at or after the first
  such report (the only contacts the issue "Safe on real wheels" allows,
  with moving obstacles);
- ∫|ω|dt: Σ |ω_k| dt over the periods k = 0..N-1 (commanded ω, held);
- step cost: mean wall time of one controller step in the process that ran
  it (a measurement; it differs from run to run).

Sums over the run (path lengths, the RMS error, ∫|ω|dt) are taken in step
order, so that :class:`RunningMetrics`, which adds each step's term as a
batched run goes (:mod:`mstc.loop.batched`), gets the same bits as
:func:`evaluate` from the stored trace.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from mstc.loop.batched import BatchRun, BatchStep
from mstc.loop.result import RunResult
from mstc.model import Event, EventKind, Mode
from mstc.plant.batch import Within
from mstc.plant.scenario import Scenario

REJOIN_ERROR = 0.05
"""Tracking error under which the robot is back on its reference [m]."""
REJOIN_WINDOW = 10.0
"""Time after the last obstacle within which it must be back [s]."""
_BUSY = (Mode.AVOID, Mode.BLOCKED)
"""Modes in which the controller is busy with an obstacle (t_last)."""
ENCOUNTER_REACH = 1.0
"""Two activations of an obstacle belong to one encounter unless the robot
was farther than its D_act + this from it in between [m]: beyond the reach
of any activation of the firmware ("mstc" activates a moving obstacle from
D_act + 1 m + its braking distance on)."""
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
    """Most activate events of one obstacle in one encounter (most_activations)."""
    infeasible: bool
    """An ``infeasible`` event was reported."""
    contact_reported: bool
    """A contact, and the first came at or after the first ``infeasible`` event."""
    step_us: float
    """Mean controller step cost [µs] (a measurement, not reproducible)."""


METRIC_COLUMNS = tuple(f.name for f in fields(Metrics))
"""The metric columns of runs.csv, in order."""


def _in_order(terms: np.ndarray) -> float:
    """The sum of @p terms added one after the other, first to last (as a
    running sum gets it; numpy's ``sum`` adds pairwise)."""
    return float(np.add.accumulate(terms)[-1]) if len(terms) else 0.0


def _path_length(x: np.ndarray, y: np.ndarray) -> float:
    return _in_order(np.hypot(np.diff(x), np.diff(y)))


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
    ref_length = _path_length(xr, yr)
    reports = [e.t_us for e in result.events if e.kind is EventKind.INFEASIBLE]
    contact_reported = False
    if reports and min_clearance < 0.0:
        first = int(np.flatnonzero((clearance < 0.0).any(axis=1))[0])
        contact_reported = round(float(t[first]) * 1e6) >= reports[0]
    return Metrics(
        contact=min_clearance < 0.0,
        min_clearance=min_clearance,
        ds_kept=ds_kept,
        rejoined=rejoined,
        blocked=blocked,
        t_last=t_last,
        avoid_time=avoid_steps * dt,
        rms_error=float(np.sqrt(_in_order(error * error) / len(error))),
        final_error=float(error[-1]),
        path_ratio=_path_length(x, y) / ref_length if ref_length > 0.0 else math.nan,
        int_abs_w=_in_order(np.abs(trace["w"][:-1])) * dt,
        switches=switches,
        max_activations=most_activations(result.events, scenario, trace.distance),
        infeasible=bool(reports),
        contact_reported=contact_reported,
        step_us=result.step_time * 1e6,
    )


def encounter_reach(scenario: Scenario) -> np.ndarray:
    """Each obstacle's D_act + ENCOUNTER_REACH [m], in the scenario's order."""
    p = scenario.params
    return np.array([p.activation_distance(o.radius) + ENCOUNTER_REACH for o in scenario.obstacles])


def most_activations(events: tuple[Event, ...], scenario: Scenario, distance: np.ndarray) -> int:
    """The most activate events of one obstacle in one encounter: activations
    of an obstacle count together unless, at a step from one to the step
    before the next, the robot was farther than encounter_reach() from it.

    :param distance: (N+1, obstacles) the centre distances of each step.
    """
    column = {o.id: j for j, o in enumerate(scenario.obstacles)}
    far = distance > encounter_reach(scenario)
    last: dict[int, int] = {}
    count: dict[int, int] = {}
    most = 0
    for e in events:
        if e.kind is not EventKind.ACTIVATE or e.obstacle not in column:
            continue
        j = column[e.obstacle]
        k = e.t_us // scenario.sim.dt_us  # events are stamped with their step's time
        before = last.get(j)
        again = before is not None and not far[before:k, j].any()
        count[j] = count[j] + 1 if again else 1
        last[j] = k
        most = max(most, count[j])
    return most


class RunningMetrics:
    """The metrics of many runs of a batched loop (:func:`evaluate`'s, the
    same bits), computed from each step's arrays as the run goes (a
    :data:`mstc.loop.batched.Watch`): sums in step order, counters, and each
    scene's rejoin passes judged as they end; contact, clearance and D_s
    from the loop's smallest distance to each obstacle (D_s is kept at every
    step exactly when it is kept at the closest). Nothing is kept per step.

    :param scenarios: the batch's scenes, in its order.
    :param width: the batch's obstacle table width.
    :param modes: the firmware's mode numbers (:attr:`mstc.firmware.sil.SilBatch.modes`).
    """

    def __init__(self, scenarios: tuple[Scenario, ...], width: int, modes: dict[int, Mode]) -> None:
        n = len(scenarios)
        self.scenarios = scenarios
        self.steps = np.array([s.sim.steps for s in scenarios], dtype=np.int64)
        self.dt_us = np.array([s.sim.dt_us for s in scenarios], dtype=np.int64)
        act = np.full((n, width), -1.0)  # the padding: never near
        for i, s in enumerate(scenarios):
            for j, o in enumerate(s.obstacles):
                act[i, j] = s.params.activation_distance(o.radius)
        self._near = Within(act)
        """Within D_act, as the per-scene code decides it."""
        touch = np.full((n, width), -1.0)
        for i, s in enumerate(scenarios):
            for j, o in enumerate(s.obstacles):
                touch[i, j] = s.params.r_m + o.radius
        self._touch = Within(touch)
        """Within R_m + r of an obstacle: a contact (:func:`evaluate`'s
        clearance below 0, up to a distance of exactly R_m + r)."""
        self._first_touch = np.full(n, -1, dtype=np.int64)
        reach = np.full((n, width), -1.0)  # the padding: never within, never activated
        for i, s in enumerate(scenarios):
            reach[i, : len(s.obstacles)] = encounter_reach(s)
        self._reach = Within(reach)
        """Within encounter_reach() of an obstacle (most_activations)."""
        self._column = [{o.id: j for j, o in enumerate(s.obstacles)} for s in scenarios]
        self._away = np.zeros((n, width), dtype=bool)
        """Beyond encounter_reach() at a step since the obstacle's last activation."""
        self._count = np.zeros((n, width), dtype=np.int64)
        self._most = np.zeros(n, dtype=np.int64)
        self._watching = False
        """An obstacle of the batch was activated: its encounters are watched."""
        top = max(modes) + 1
        self._busy_mode = np.zeros(top, dtype=bool)
        self._avoid_mode = np.zeros(top, dtype=np.int64)
        for number, mode in modes.items():
            self._busy_mode[number] = mode in _BUSY
            self._avoid_mode[number] = mode is Mode.AVOID
        self._blocked = next(k for k, m in modes.items() if m is Mode.BLOCKED)
        # The first step of each scene's window of BLOCKED_WINDOW at its end.
        self._window = np.empty(n, dtype=np.int64)
        for i, s in enumerate(scenarios):
            t = np.arange(s.sim.steps + 1) * s.sim.dt_us / 1e6
            self._window[i] = int(np.flatnonzero(t >= t[-1] - BLOCKED_WINDOW)[0])
        self._uniform_window = (
            int(self._window[0]) if (self._window == self._window[0]).all() else None
        )
        self._last_busy = np.full(n, -1, dtype=np.int64)
        self._prev_busy = np.zeros(n, dtype=bool)
        self._in_pass = np.zeros(n, dtype=bool)
        self._initial = np.zeros(n, dtype=bool)
        self._pass_t0 = np.zeros(n)
        self._pass_a = np.zeros(n, dtype=np.int64)
        self._last_bad = np.full(n, -1, dtype=np.int64)
        """The last step with a tracking error of REJOIN_ERROR or more."""
        self._judged = np.zeros(n, dtype=bool)
        self._failed = np.zeros(n, dtype=bool)
        self._err2 = np.zeros(n)
        self._path = np.zeros(n)
        self._ref_path = np.zeros(n)
        self._win_path = np.zeros(n)
        self._win_ref_path = np.zeros(n)
        self._abs_w = np.zeros(n)
        self._avoid_steps = np.zeros(n, dtype=np.int64)
        self._switches = np.zeros(n, dtype=np.int64)
        self._prev_mode = np.zeros(n, dtype=np.int32)
        self._final_error = np.zeros(n)
        self._final_mode = np.zeros(n, dtype=np.int32)
        self._prev: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._last = int(self.steps.max(initial=0))
        self._uniform = bool((self.steps == self._last).all())

    def _t(self, k: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Step @p k's time of the scenes @p rows [s], as the trace has it."""
        t: np.ndarray = k * self.dt_us[rows] / 1e6
        return t

    def _encounters(self, s: BatchStep) -> None:
        """Count this step's activations per encounter, then note which
        obstacles the robot is beyond encounter_reach() of (most_activations)."""
        for i, emitted in s.events:
            for e in emitted:
                j = self._column[i].get(e.obstacle) if e.kind is EventKind.ACTIVATE else None
                if j is None:
                    continue
                again = self._count[i, j] > 0 and not self._away[i, j]
                self._count[i, j] = self._count[i, j] + 1 if again else 1
                self._away[i, j] = False
                self._most[i] = max(self._most[i], self._count[i, j])
                self._watching = True
        if self._watching:
            self._away |= ~self._reach(s.distance2, s.dx, s.dy)

    def _close(self, rows: np.ndarray, b: int) -> None:
        """Judge the passes of @p rows, which end at step @p b (_rejoined)."""
        if not len(rows):
            return
        t0, a, bad = self._pass_t0[rows], self._pass_a[rows], self._last_bad[rows]
        back_from = np.where(bad < a, a, bad + 1)
        back = (back_from <= b) & (self._t(back_from, rows) <= t0 + REJOIN_WINDOW + 1e-9)
        failed = ~back & (self._t(np.full(len(rows), b), rows) >= t0 + REJOIN_WINDOW - 1e-9)
        self._judged[rows] |= back
        self._failed[rows] |= failed
        self._in_pass[rows] = False

    def __call__(self, s: BatchStep) -> None:
        """Take step @p s of the batch."""
        k = s.k
        uniform = self._uniform
        active = s.active
        near = self._near.rows(s.distance2, s.dx, s.dy)
        touched = self._touch.rows(s.distance2, s.dx, s.dy)
        if not uniform:
            touched &= active
        if touched.any():
            np.copyto(self._first_touch, k, where=touched & (self._first_touch < 0))
        self._encounters(s)
        mode = s.mode
        busy = near | self._busy_mode[mode]
        if not uniform:
            busy &= active
        error = np.hypot(s.x - s.x_r, s.y - s.y_r)

        # Rejoin passes (_rejoined): a busy step ends the pass under way (the
        # stretch before a run's first busy step is no pass); a free step
        # after a busy one starts one; a run without a busy step is one pass.
        if k == 0:
            free = ~busy if uniform else active & ~busy
            self._in_pass |= free
            self._initial |= free
        else:
            change = busy != self._prev_busy
            if not uniform:
                change &= active
            if change.any():
                closing = change & busy & self._in_pass
                self._close(np.flatnonzero(closing & ~self._initial), k - 1)
                dropped = closing & self._initial
                self._in_pass &= ~dropped
                self._initial &= ~dropped
                starting = np.flatnonzero(change & ~busy)
                if len(starting):
                    self._in_pass[starting] = True
                    self._pass_t0[starting] = self._t(np.full(len(starting), k - 1), starting)
                    self._pass_a[starting] = k
        np.copyto(self._last_bad, k, where=error >= REJOIN_ERROR)
        np.copyto(self._last_busy, k, where=busy)
        ends: np.ndarray | None = None if uniform else np.asarray(k == self.steps)
        if uniform and k == self._last:
            self._close(np.flatnonzero(self._in_pass), k)
        elif ends is not None and ends.any():
            rows = np.flatnonzero(ends & self._in_pass)
            for b in np.unique(self.steps[rows]).tolist():
                self._close(rows[self.steps[rows] == b], int(b))
        self._prev_busy = busy if uniform else np.where(active, busy, self._prev_busy)

        # Sums in step order, counters.
        if uniform:
            self._err2 += error * error
        else:
            self._err2 += np.where(active, error * error, 0.0)
        if self._prev is not None:
            px, py, prx, pry = self._prev
            seg = np.hypot(s.x - px, s.y - py)
            ref_seg = np.hypot(s.x_r - prx, s.y_r - pry)
            changed = mode != self._prev_mode
            if uniform:
                self._path += seg
                self._ref_path += ref_seg
                self._switches += changed
            else:
                self._path += np.where(active, seg, 0.0)
                self._ref_path += np.where(active, ref_seg, 0.0)
                self._switches += changed & active
            if self._uniform_window is not None and uniform:
                if k - 1 >= self._uniform_window:
                    self._win_path += seg
                    self._win_ref_path += ref_seg
            else:
                window = active & (k - 1 >= self._window)
                self._win_path += np.where(window, seg, 0.0)
                self._win_ref_path += np.where(window, ref_seg, 0.0)
        self._prev = (s.x, s.y, s.x_r, s.y_r)
        if uniform:
            if k < self._last:
                self._abs_w += np.abs(s.w)
                self._avoid_steps += self._avoid_mode[mode]
            self._prev_mode = np.array(mode, dtype=np.int32)
            if k == self._last:
                self._final_error = error
                self._final_mode = np.array(mode, dtype=np.int32)
        else:
            running = active & (k < self.steps)
            self._abs_w += np.where(running, np.abs(s.w), 0.0)
            self._avoid_steps += np.where(running, self._avoid_mode[mode], 0)
            self._prev_mode = np.where(active, mode, self._prev_mode)
            assert ends is not None
            self._final_error = np.where(ends, error, self._final_error)
            self._final_mode = np.where(ends, mode, self._final_mode)

    def result(self, i: int, run: BatchRun) -> Metrics:
        """The metrics of scene @p i, whose run left @p run."""
        s = self.scenarios[i]
        p = s.params
        dt = s.sim.dt
        radii = [o.radius for o in s.obstacles]
        pairs = list(zip(run.min_distance, radii, strict=True))
        min_clearance = min((d - (p.r_m + r) for d, r in pairs), default=math.inf)
        last_busy = int(self._last_busy[i])
        ref_moved, moved = float(self._win_ref_path[i]), float(self._win_path[i])
        ref_length = float(self._ref_path[i])
        rejoined = False if self._failed[i] else True if self._judged[i] else None
        reports = [e.t_us for e in run.events if e.kind is EventKind.INFEASIBLE]
        first_touch = int(self._first_touch[i])
        contact_reported = bool(
            reports
            and min_clearance < 0.0
            and first_touch >= 0
            and first_touch * int(self.dt_us[i]) >= reports[0]
        )
        return Metrics(
            contact=min_clearance < 0.0,
            min_clearance=min_clearance,
            ds_kept=all(d >= p.safe_distance(r) for d, r in pairs),
            rejoined=rejoined,
            blocked=int(self._final_mode[i]) == self._blocked
            or (ref_moved > 0.0 and moved < BLOCKED_SHARE * ref_moved),
            t_last=last_busy * int(self.dt_us[i]) / 1e6 if last_busy >= 0 else 0.0,
            avoid_time=int(self._avoid_steps[i]) * dt,
            rms_error=float(np.sqrt(self._err2[i] / (int(self.steps[i]) + 1))),
            final_error=float(self._final_error[i]),
            path_ratio=float(self._path[i]) / ref_length if ref_length > 0.0 else math.nan,
            int_abs_w=float(self._abs_w[i]) * dt,
            switches=int(self._switches[i]),
            max_activations=int(self._most[i]),
            infeasible=bool(reports),
            contact_reported=contact_reported,
            step_us=run.step_time * 1e6,
        )
