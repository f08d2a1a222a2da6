# SPDX-License-Identifier: MIT
"""The worlds of many scenes at once: :class:`BatchWorld`.

What :func:`mstc.plant.world.make_world` makes of one scenario (the robot,
the reference robot, the obstacles, the range sensor and the imperfections)
for N scenarios, held as numpy arrays with one row per scene and stepped by
array operations over all of them. Obstacles are padded to the largest table
of the batch with entries at infinity (never in range, never near); what the
sensor reports is a mask (in range, not dropped) over that table.

Every update is the per-scene code's formula, evaluated in the same order
with the same functions (numpy's ``cos`` and ``sin`` give libm's bits, as
``math``'s do), so a scene moves here as it moves alone, bit for bit. The one
function without a numpy twin is the distance the per-scene code takes,
``math.hypot`` (CPython's own, correctly rounded, where numpy's ``hypot`` is
libm's, within an ulp of it and slow). Distances here are squared,
``dx·dx + dy·dy``, and each decision against a distance (the sensor's range;
D_act in the metrics) is taken on them with a relative margin
(:class:`Within`): the few within it of the threshold are decided again with
``math.hypot``, so every decision is the per-scene one.

The random draws are the per-scene ones too: each scene has the streams of
:func:`mstc.plant.world.random_streams` and draws from them the numbers the
per-scene loop draws, in the same order, a chunk of steps at a time.

Scenes with "lag" wheels (``[actuator] model = "lag"``) are moved by
:class:`BatchActuator`, :class:`mstc.plant.actuator.Actuator`'s substeps over
arrays, the same updates in the same order; the others by the ideal wheels,
masked, in the same batch. Scenes on "dc" wheels (the firmware's wheel loop)
are not modelled here: they run alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from mstc.plant.actuator import substeps
from mstc.plant.plant import Integrator
from mstc.plant.reference import LEAD, ON_PATH, VERTEX_TOLERANCE, PathReference
from mstc.plant.scenario import Scenario
from mstc.plant.world import random_streams

CHUNK = 128
"""Steps of random draws made at once per scene."""

_TAU, _PI = math.tau, math.pi
_SMALL_ANGLE = 1e-4
"""As :mod:`mstc.plant.plant`: below it sin(h)/h is its series."""


def table_width(scenarios: Sequence[Scenario]) -> int:
    """Entries of every scene's obstacle table in a batch of @p scenarios:
    the largest scene's (at least 1); the slots, for scenes with a world."""
    return max([1, *(s.slots or len(s.obstacles) for s in scenarios)])


class BatchSlots:
    """:class:`mstc.plant.sensor.SlotSensor` over N scenes (a batch of
    scenes with worlds): the same reports, slots and count of unreported
    periods, from the same distances (``np.hypot``) and the same rules.

    :param radius: (N, M) the obstacles' radii (the padding's anything).
    :param reach: (N, M) each obstacle's range, d_det + (r − r_ob) (-inf for
        the padding).
    :param near: (N, M) r_m + r + d_act (-inf for the padding).
    :param slots: the slot ids 1..slots.
    """

    def __init__(self, radius: np.ndarray, reach: np.ndarray, near: np.ndarray, slots: int) -> None:
        self.radius, self.reach, self.near, self.slots = radius, reach, near, slots
        n, m = radius.shape
        self.slot_of = np.zeros((n, m), dtype=np.int64)
        """Slot of each obstacle reported last period (0: none)."""
        self.held = np.full((n, slots + 1), -1, dtype=np.int64)
        """Obstacle in each slot (-1: free); column 0 unused."""
        self.unreported = np.zeros(n, dtype=np.int64)
        """Periods with an obstacle within d_act of the robot's surface not reported."""
        self._rows = np.arange(n)

    def scan(self, d: np.ndarray, active: np.ndarray) -> np.ndarray:
        """The reports of a period from the centre distances @p d (N, M):
        which obstacles are reported (N, M) (slots updated); the unreported
        count grows for the @p active scenes."""
        n, m = d.shape
        k = self.slots
        inside = d <= self.reach
        seen = inside
        counts = inside.sum(axis=1)
        full = np.flatnonzero(counts > k)
        if len(full):
            # Nearest first by surface distance, ties by index: a stable sort.
            seen = inside.copy()
            surface = np.where(inside[full], d[full] - self.radius[full], np.inf)
            order = np.argsort(surface, axis=1, kind="stable")[:, k:]
            seen[full[:, None], order] = False
        missed = (d <= self.near) & ~seen
        self.unreported += missed.any(axis=1) & active
        # Slots: the reported keep theirs; the others free them.
        leaving = (self.slot_of > 0) & ~seen
        li, lj = np.nonzero(leaving)
        self.held[li, self.slot_of[li, lj]] = -1
        self.slot_of[li, lj] = 0
        new = seen & (self.slot_of == 0)
        for i in np.flatnonzero(new.any(axis=1)).tolist():
            js = np.flatnonzero(new[i])
            js = js[np.argsort(d[i, js] - self.radius[i, js], kind="stable")]
            free = np.flatnonzero(self.held[i, 1:] < 0)[: len(js)] + 1
            self.held[i, free] = js
            self.slot_of[i, js] = free
        return seen

    def table(
        self, ox: np.ndarray, oy: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The firmware's table, slot by slot (N, slots): reported, x, y, radius."""
        held = self.held[:, 1:]
        reported = held >= 0
        at = np.where(reported, held, 0)
        take = np.take_along_axis
        return reported, take(ox, at, 1), take(oy, at, 1), take(self.radius, at, 1)


class BatchPaths:
    """:class:`mstc.plant.reference.PathReference` over N scenes, each
    waiting (:meth:`~mstc.plant.reference.PathReference.follow`) or on the
    clock (:meth:`~mstc.plant.reference.PathReference.at`): the same
    formulas in the same order over padded arrays (numpy's functions, libm's
    bits as ``math``'s), so each target is the per-scene one bit for bit.

    :param paths: one path per scene.
    """

    def __init__(self, paths: Sequence[PathReference]) -> None:
        n = len(paths)
        segs = max(len(p.headings) for p in paths)
        self.n = n
        self.wait = np.array([p.wait for p in paths])
        self.speed = np.array([p.speed for p in paths])
        self.period = np.array([p.period for p in paths])
        self.length = np.array([p.length for p in paths])
        self.count = np.array([len(p.headings) for p in paths])
        self.ax = np.zeros((n, segs))
        self.ay = np.zeros((n, segs))
        self.ux = np.zeros((n, segs))
        self.uy = np.zeros((n, segs))
        self.seg = np.zeros((n, segs))
        self.start = np.full((n, segs), np.inf)
        """Arc length at each segment's start; inf for the padding."""
        self.heading = np.zeros((n, segs))
        for i, p in enumerate(paths):
            c = len(p.headings)
            self.ax[i, :c], self.ay[i, :c] = p._a[:, 0], p._a[:, 1]
            self.ux[i, :c], self.uy[i, :c] = p._u[:, 0], p._u[:, 1]
            self.seg[i, :c] = p._len
            self.start[i, :c] = p._start
            self.heading[i, :c] = p.headings
        self._real = np.isfinite(self.start)
        self.s = np.zeros(n)
        self.q = np.zeros(n)
        self._rows = np.arange(n)

    def _segment(self, s: np.ndarray) -> np.ndarray:
        """bisect_right(starts, s + tolerance) − 1, clamped to the segments."""
        i: np.ndarray = (self.start <= (s + VERTEX_TOLERANCE)[:, None]).sum(axis=1) - 1
        clipped: np.ndarray = np.clip(i, 0, self.count - 1)
        return clipped

    def _pose(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = np.minimum(np.maximum(s, 0.0), self.length)
        i = self._segment(s)
        r = self._rows
        theta = self.heading[r, i]
        along = s - self.start[r, i]
        return self.ax[r, i] + along * np.cos(theta), self.ay[r, i] + along * np.sin(theta), theta

    def _progress(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        rx = x[:, None] - self.ax
        ry = y[:, None] - self.ay
        t = np.clip(rx * self.ux + ry * self.uy, 0.0, self.seg)
        near = (np.hypot(rx - t * self.ux, ry - t * self.uy) <= ON_PATH) & self._real
        best: np.ndarray = np.where(near, self.start + t, -np.inf).max(axis=1)
        return best

    def sample(
        self, k: int, x: np.ndarray, y: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The references of step @p k for robots measured at (@p x, @p y):
        x_r, y_r, θ_r, v_r, ω_r; the waiting targets move to their next arc
        length (sample and step of the per-scene reference in one)."""
        self.q = np.where(self.wait, np.maximum(self.q, self._progress(x, y)), self.q)
        clock = np.minimum(np.maximum(self.speed * (k * self.period), 0.0), self.length)
        s = np.where(self.wait, self.s, clock)
        px, py, theta = self._pose(s)
        end = s >= self.length - VERTEX_TOLERANCE
        step = self.speed * self.period
        follow = np.minimum(
            np.maximum(np.maximum(s, np.minimum(s + step, self.q + LEAD)), self.q), self.length
        )
        ahead_s = np.where(self.wait, follow, np.minimum(s + step, self.length))
        ahead = np.where(
            self.wait, self._pose(ahead_s)[2], self.heading[self._rows, self._segment(ahead_s)]
        )
        turn = wrap(ahead - theta) / self.period
        self.s = np.where(self.wait & ~end, follow, self.s)
        v = np.where(end, 0.0, self.speed)
        w = np.where(end, 0.0, turn)
        return px, py, theta, v, w


def exact_hypot(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """``math.hypot`` of each pair (the per-scene code's distance), one by one."""
    return np.array(list(map(math.hypot, dx.tolist(), dy.tolist())), dtype=float)


MARGIN = 1e-12
"""Relative margin on a squared threshold within which :class:`Within` asks
``math.hypot``: far wider than the rounding of dx·dx + dy·dy and of the
threshold's square (a few 1e-16), far narrower than the distance moves in a
step."""


class Within:
    """``math.hypot(dx, dy) <= threshold``, decided from squared distances.

    :param threshold: (N, width) or broadcastable: the thresholds [m].
    """

    def __init__(self, threshold: np.ndarray) -> None:
        self.threshold = threshold
        square = threshold * threshold
        # A negative threshold holds no distance: nothing is within it.
        self._sure = np.where(threshold >= 0.0, square * (1.0 - MARGIN), -1.0)
        self._maybe = np.where(threshold >= 0.0, square * (1.0 + MARGIN), -1.0)

    def __call__(self, d2: np.ndarray, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
        """Which squared distances @p d2 (of @p dx, @p dy) are within."""
        return self._inside(d2, dx, dy)[0]

    def rows(self, d2: np.ndarray, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
        """Which rows of @p d2 (N, width) have a distance within: the
        ``any(axis=1)`` of :meth:`__call__`, from the indices of the entries
        within (numpy's reduction along a short row costs as much as several
        elementwise passes)."""
        out = np.zeros(d2.shape[0], dtype=bool)
        out[self._inside(d2, dx, dy)[1] // d2.shape[1]] = True
        return out

    def _inside(
        self, d2: np.ndarray, dx: np.ndarray, dy: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The entries within: as a mask of @p d2's shape, and as indices
        into it flattened in C order. Those within the margin of their
        threshold are decided by ``math.hypot``."""
        within = np.less_equal(d2, self._maybe, order="C")
        flat = np.flatnonzero(within)
        if len(flat):
            shape = within.shape
            sure = d2.reshape(-1)[flat] <= self._flat(self._sure, shape)[flat]
            if not sure.all():
                doubt = flat[~sure]
                exact = exact_hypot(dx.reshape(-1)[doubt], dy.reshape(-1)[doubt])
                out = doubt[exact > self._flat(self.threshold, shape)[doubt]]
                within.reshape(-1)[out] = False
                flat = np.setdiff1d(flat, out, assume_unique=True)
        return within, flat

    @staticmethod
    def _flat(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        """@p a over @p shape, flat in C order (a view when @p a has that
        shape and is C-contiguous)."""
        return a.reshape(-1) if a.shape == shape else np.broadcast_to(a, shape).reshape(-1)


def wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped into (-π, π] as :func:`mstc.model.wrap_angle`, bit for
    bit: fmod is exact, and so is the subtraction of 2π from a remainder
    above π (Sterbenz); ±π at a tie becomes π either way."""
    if len(a) and -_PI < a.min() and a.max() < _PI:  # fmod and the wraps keep such angles
        return a
    r = np.fmod(a, _TAU)
    r = np.where(r > _PI, r - _TAU, r)
    r = np.where(r < -_PI, r + _TAU, r)
    return np.where(r == -_PI, _PI, r)


def displacement(
    theta: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    dt: np.ndarray,
    euler: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """What :func:`mstc.plant.plant.integrate` adds to x and y over @p dt
    from the heading @p theta at (@p v, @p w), over arrays: forward Euler
    where @p euler (None: everywhere), the exact arc elsewhere; the same
    operations in the same order."""
    if euler is None or euler.any():
        edx = np.cos(theta)  # v·cos θ·dt
        edx *= v
        edx *= dt
        edy = np.sin(theta)
        edy *= v
        edy *= dt
        if euler is None:
            return edx, edy
    half = 0.5 * w * dt
    with np.errstate(invalid="ignore", divide="ignore"):
        sinc = np.where(np.abs(half) < _SMALL_ANGLE, 1.0 - half * half / 6.0, np.sin(half) / half)
    chord = v * dt * sinc
    mid = theta + half
    adx = chord * np.cos(mid)
    ady = chord * np.sin(mid)
    if not euler.any():
        return adx, ady
    return np.where(euler, edx, adx), np.where(euler, edy, ady)


def integrate(
    x: np.ndarray,
    y: np.ndarray,
    theta: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    dt: np.ndarray,
    euler: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`mstc.plant.plant.integrate` over arrays (:func:`displacement`)."""
    dx, dy = displacement(theta, v, w, dt, euler)
    return x + dx, y + dy, theta + w * dt


class _Group(NamedTuple):
    """Scenes of a :class:`BatchActuator` with as many substeps a period, and
    their constants; those of both wheels (``*2``) left then right."""

    where: slice | np.ndarray
    """Their positions in the actuator's arrays."""
    n: int
    substeps: int
    euler: np.ndarray | None
    h: np.ndarray
    radius: np.ndarray
    track: np.ndarray
    h2: np.ndarray
    k2: np.ndarray
    limit2: np.ndarray
    low2: np.ndarray


class BatchActuator:
    """The "lag" wheels of some scenes of a batch: :class:`mstc.plant.actuator.Actuator`
    over arrays, its substeps' updates in its order with its constants
    (``k = math.exp(-h / τ)``, computed per scene by ``math``), so that each
    scene's wheels, pose and measured speeds are the per-scene ones bit for
    bit. The wheels' state is held as (2, L) arrays, left and right, of the
    L scenes that have such wheels; scenes with as many substeps a period
    (the same dt) are stepped together.

    :param scenarios: the batch's scenes.
    :param rows: the batch's rows of the scenes with "lag" wheels.
    :param euler: the batch's forward-Euler mask (None: every scene).
    """

    def __init__(
        self, scenarios: Sequence[Scenario], rows: np.ndarray, euler: np.ndarray | None
    ) -> None:
        self.rows = rows
        """The batch's rows of these wheels' scenes (the order of every array)."""
        sc = [scenarios[i] for i in rows.tolist()]
        specs = [s.actuator for s in sc]
        dts = [s.sim.dt for s in sc]
        counts = [substeps(dt) for dt in dts]
        h = [dt / c for dt, c in zip(dts, counts, strict=True)]
        self.dt = np.array(dts)
        self.radius = np.array([s.params.wheel_radius for s in sc])
        self.track = np.array([s.params.track_width for s in sc])
        self.h = np.array(h)
        self.k = np.array(
            [
                math.exp(-hh / a.time_constant) if a.time_constant > 0.0 else 0.0
                for hh, a in zip(h, specs, strict=True)
            ]
        )
        """exp(-h/τ) of each scene, by ``math.exp`` as the per-scene wheels'."""
        self.limit = np.array([a.max_accel * hh for hh, a in zip(h, specs, strict=True)])
        self.counts_per_rad = np.array([a.encoder_counts / math.tau for a in specs])
        self._quantised = self.counts_per_rad != 0.0
        self._any_quantised = bool(self._quantised.any())
        self._all_quantised = bool(self._quantised.all())
        ew = None if euler is None else euler[rows]
        self._groups: list[_Group] = []
        """The scenes with as many substeps, each group stepped together."""
        for c in sorted(set(counts)):
            at = np.flatnonzero(np.array(counts) == c)
            where: slice | np.ndarray = slice(None) if len(at) == len(sc) else at
            e = None if ew is None else ew[at]
            h2, k2 = np.tile(self.h[at], 2), np.tile(self.k[at], 2)
            limit2 = np.tile(self.limit[at], 2)
            self._groups.append(
                _Group(
                    where,
                    len(at),
                    c,
                    None if e is None or e.all() else e,
                    self.h[at],
                    self.radius[at],
                    self.track[at],
                    h2,
                    k2,
                    limit2,
                    -limit2,
                )
            )
        n = len(sc)
        self.speed = np.zeros((2, n))
        """Wheel speeds now, left and right [rad/s]."""
        self.angle = np.zeros((2, n))
        """Wheel angles since the start [rad]."""
        self.count = np.zeros((2, n))
        """Encoder counts at the end of the last period (whole numbers)."""
        self.measured = np.zeros((2, n))
        """The speeds the drivers reported at the end of the last period [rad/s]."""

    def step(
        self,
        left: np.ndarray,
        right: np.ndarray,
        x: np.ndarray,
        y: np.ndarray,
        theta: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One period with the setpoints (@p left, @p right) [rad/s] (the
        commands, already delayed) of these scenes, from the poses (@p x,
        @p y, @p theta) of these scenes; the poses at its end (and
        :attr:`measured`, the speeds the drivers report).

        The wheels' speeds go through the substeps one after the other (both
        wheels of every scene in one array); what depends on them alone then
        takes every substep at once (the mean speeds, each substep's (v, ω),
        cos and sin of its heading), and the sums over the substeps (heading,
        position, wheel angles) are added one substep after the other, in the
        per-scene loop's order."""
        u = np.stack((left, right))
        x, y, theta = x.copy(), y.copy(), theta.copy()
        before = self.angle
        speed, angle = self.speed.copy(), self.angle.copy()
        for g in self._groups:
            where, n, count = g.where, g.n, g.substeps
            # Both wheels of every scene flat, left then right.
            uu = u[:, where].reshape(-1)
            speeds = np.empty((count + 1, 2 * n))
            speeds[0] = speed[:, where].reshape(-1)
            step = np.empty(2 * n)
            for s in range(count):
                w = speeds[s]
                np.subtract(w, uu, out=step)
                step *= g.k2
                step += uu  # the lag's target, u + (w - u)·k
                step -= w
                np.minimum(step, g.limit2, out=step)
                np.maximum(step, g.low2, out=step)
                np.add(w, step, out=speeds[s + 1])
            speed[:, where] = speeds[-1].reshape(2, n)
            means = speeds[:-1] + speeds[1:]
            means *= 0.5
            ml, mr = means[:, :n], means[:, n:]
            v = mr + ml  # r·(m_R + m_L) / 2
            v *= g.radius
            v /= 2.0
            om = mr - ml  # r·(m_R − m_L) / L
            om *= g.radius
            om /= g.track
            turn = om * g.h
            headings = np.empty((count + 1, n))
            headings[0] = theta[where]
            for s in range(count):
                np.add(headings[s], turn[s], out=headings[s + 1])
            # Each substep's wheel angles, x and y added in one array.
            sums = np.concatenate((angle[:, where].reshape(-1), x[where], y[where]))
            terms = np.empty((count, 4 * n))
            np.multiply(g.h2, means, out=terms[:, : 2 * n])
            terms[:, 2 * n : 3 * n], terms[:, 3 * n :] = displacement(
                headings[:-1], v, om, g.h, g.euler
            )
            for s in range(count):
                sums += terms[s]
            angle[:, where] = sums[: 2 * n].reshape(2, n)
            x[where], y[where] = sums[2 * n : 3 * n], sums[3 * n :]
            theta[where] = headings[-1]
        self.speed, self.angle = speed, angle
        if self._any_quantised:
            with np.errstate(divide="ignore", invalid="ignore"):
                c = np.floor(angle * self.counts_per_rad)
                quantised = (c - self.count) / self.counts_per_rad / self.dt
            if self._all_quantised:
                self.measured, self.count = quantised, c
            else:
                exact = (angle - before) / self.dt
                self.measured = np.where(self._quantised, quantised, exact)
                self.count = np.where(self._quantised, c, self.count)
        else:
            self.measured = (angle - before) / self.dt
        return x, y, theta


class BatchWorld:
    """N scenes' robots, references, obstacles and sensors as arrays.

    :param scenarios: the scenes (any lengths, periods and integrators).
    :param chunk: steps of random draws made at once per noisy scene.
    """

    def __init__(self, scenarios: Sequence[Scenario], chunk: int = CHUNK) -> None:
        self.scenarios = tuple(scenarios)
        n = len(self.scenarios)
        self.n = n
        self.width = table_width(self.scenarios)
        """Entries of every scene's obstacle table (the largest scene's)."""
        m = self.width
        sc = self.scenarios

        def col(values: Sequence[float]) -> np.ndarray:
            return np.array(values, dtype=float)

        self.wheel_radius = col([s.params.wheel_radius for s in sc])
        self.track_width = col([s.params.track_width for s in sc])
        self.dt = col([s.sim.dt for s in sc])
        self.dt_us = np.array([s.sim.dt_us for s in sc], dtype=np.int64)
        self.steps = np.array([s.sim.steps for s in sc], dtype=np.int64)
        """N of each scene: its steps are k = 0..N."""
        exact = np.array([s.sim.integrator is not Integrator.EULER for s in sc])
        self.euler = ~exact if exact.any() else None
        """Forward Euler per scene (None: every scene)."""
        self.x = col([s.robot.x for s in sc])
        self.y = col([s.robot.y for s in sc])
        self.theta = col([s.robot.theta for s in sc])
        with_path = [bool(s.reference.path) for s in sc]
        if any(with_path) and not all(with_path):
            raise ValueError("a batch mixes path references with others")
        self.paths = (
            BatchPaths(
                [
                    PathReference(s.reference.path, s.reference.v, s.sim.dt, wait=s.reference.wait)
                    for s in sc
                ]
            )
            if all(with_path) and n
            else None
        )
        """The scenes' path references (None: the paper's virtual robots)."""
        self.goal = col(
            [math.inf if s.reference.goal_radius is None else s.reference.goal_radius for s in sc]
        )
        """The goal radius of each scene's path end (inf: none)."""
        self.goal_x = col([s.reference.path[-1][0] if s.reference.path else 0.0 for s in sc])
        self.goal_y = col([s.reference.path[-1][1] if s.reference.path else 0.0 for s in sc])
        self.x_r = col([s.reference.pose.x for s in sc])
        self.y_r = col([s.reference.pose.y for s in sc])
        self.theta_r = col([s.reference.pose.theta for s in sc])
        self.v_r = col([s.reference.v for s in sc])
        self.w_r = col([s.reference.w for s in sc])

        with_slots = [s.slots > 0 for s in sc]
        if any(with_slots) and not all(with_slots):
            raise ValueError("a batch mixes scenes with worlds and without")
        self.slot_sensor: BatchSlots | None = None
        """The slot sensor of scenes with worlds (None: obstacle i is reported as id i)."""
        if all(with_slots) and n:
            m = max(len(s.obstacles) for s in sc)
        self.world_width = m
        """Obstacles of every scene's world (the largest's); :attr:`width` when
        there are no worlds."""
        self.count = np.array([len(s.obstacles) for s in sc], dtype=np.uint32)
        self.obstacle_id = np.zeros((n, m), dtype=np.uint32)
        self.ox0 = np.full((n, m), math.inf)
        self.oy0 = np.full((n, m), math.inf)
        self.radius = np.ones((n, m))
        self.vx = np.zeros((n, m))
        self.vy = np.zeros((n, m))
        moving = np.zeros((n, m), dtype=bool)
        for i, s in enumerate(sc):
            for j, o in enumerate(s.obstacles):
                self.obstacle_id[i, j] = o.id
                self.ox0[i, j], self.oy0[i, j], self.radius[i, j] = o.x, o.y, o.radius
                self.vx[i, j], self.vy[i, j] = o.vx, o.vy
                moving[i, j] = o.moving
        self.moving = moving if moving.any() else None
        """Which obstacles move (None: none does)."""
        self.r_m = col([s.params.r_m for s in sc])

        imp = [s.imperfections for s in sc]
        self.sensor_range = col(
            [
                s.params.d_det if m_.sensor_range is None else m_.sensor_range
                for s, m_ in zip(sc, imp, strict=True)
            ]
        )
        r_ob = col([s.params.r_ob for s in sc])
        # Each obstacle's reach as the per-scene sensor has it: the range plus
        # how much larger than R_ob it is (d + (r - R_ob), the same bits).
        reach = self.sensor_range[:, None] + (self.radius - r_ob[:, None])
        self._in_range = Within(reach)
        if all(with_slots) and n:
            d_act = col([s.params.d_act for s in sc])
            pad = ~np.isfinite(self.ox0)
            near = self.r_m[:, None] + self.radius + d_act[:, None]
            self.slot_sensor = BatchSlots(
                self.radius,
                np.where(pad, -np.inf, reach),
                np.where(pad, -np.inf, near),
                int(sc[0].slots),
            )
            if any(s.slots != sc[0].slots for s in sc):
                raise ValueError("a batch mixes scenes with different slots")
        self.delay = np.array(
            [
                m_.delay + (s.actuator.delay if s.actuator.model == "lag" else 0)
                for s, m_ in zip(sc, imp, strict=True)
            ],
            dtype=np.int64,
        )
        """Whole periods from a command to the wheels: the imperfection's,
        plus the actuator's own for "lag" wheels (:func:`mstc.plant.world.make_world`)."""
        lag = np.flatnonzero([s.actuator.model == "lag" for s in sc])
        self.actuator = BatchActuator(sc, lag, self.euler) if len(lag) else None
        """The "lag" wheels of the scenes that have them (None: no scene has)."""
        self._all_lag = len(lag) == n
        depth = int(self.delay.max(initial=0)) + 1
        self._commands = np.zeros((n, depth, 2))
        """Wheel commands of the last periods, step k at k mod depth."""
        self._chunk = max(1, chunk)
        self._odometry_sigma = np.array(
            [(m_.position_noise, m_.position_noise, m_.heading_noise) for m_ in imp]
        )
        self._obstacle_sigma = col([m_.obstacle_noise for m_ in imp])
        self._dropout = col([m_.dropout for m_ in imp])
        self._odometry_noisy = np.array([bool(m_.position_noise or m_.heading_noise) for m_ in imp])
        self._sensor_noisy = np.array([bool(m_.obstacle_noise or m_.dropout) for m_ in imp])
        self._streams = [
            random_streams(m_.seed) if (self._odometry_noisy[i] or self._sensor_noisy[i]) else None
            for i, m_ in enumerate(imp)
        ]
        self._odometry: np.ndarray | None = None
        self._obstacle_noise: np.ndarray | None = None
        self._kept: np.ndarray | None = None
        self._chunk_start = -1
        self.noisy = bool(self._odometry_noisy.any() or self._sensor_noisy.any())
        """Whether any scene draws random numbers."""
        self._ref_step: tuple[np.ndarray, np.ndarray] | None = None
        if self.paths is None and not self.w_r.any():
            # ω_r = 0 everywhere: θ_r + 0·dt is θ_r, so each period adds the
            # same terms to x_r and y_r that integrate() adds (v cos θ dt, or
            # the chord's), computed once with its formulas.
            zero = np.zeros(n)
            nx, ny, _ = integrate(zero, zero, self.theta_r, self.v_r, self.w_r, self.dt, self.euler)
            self._ref_step = (nx, ny)

    # -------------------------------------------------------------- random draws

    def _draw(self, k0: int) -> None:
        """The random draws of steps k0 .. k0 + chunk - 1 of every noisy scene,
        from its own streams, the numbers the per-scene loop draws: the
        odometry's ``standard_normal((steps + 1, 3)) * σ`` (a chunk of its
        rows); the sensor's ``standard_normal((n, 2)) * σ`` and its dropouts'
        ``random(n)`` a step, each from its stream (n: the scene's obstacles,
        in range or not). A stream's draws of consecutive calls are those of
        one call of their total size, so a chunk of steps is one call."""
        c, n, m = self._chunk, self.n, self.width
        if self._odometry is None:
            self._odometry = np.zeros((n, c, 3))
            self._obstacle_noise = np.zeros((n, c, m, 2))
            self._kept = np.ones((n, c, m), dtype=bool)
        odo, noise, kept = self._odometry, self._obstacle_noise, self._kept
        assert noise is not None and kept is not None
        for i, streams in enumerate(self._streams):
            if streams is None:
                continue
            odometry_rng, noise_rng, dropout_rng = streams
            if self._odometry_noisy[i]:
                odo[i] = odometry_rng.standard_normal((c, 3)) * self._odometry_sigma[i]
            count = int(self.count[i])
            if self._obstacle_sigma[i]:
                draws = noise_rng.standard_normal((c, count, 2))
                noise[i, :, :count] = draws * self._obstacle_sigma[i]
            if self._dropout[i]:
                kept[i, :, :count] = dropout_rng.random((c, count)) >= self._dropout[i]
        self._chunk_start = k0

    # -------------------------------------------------------------- one step

    def obstacles_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every obstacle's centre at the scenes' times @p t [s] (N, width):
        ``x + vx·t`` for those that move (Obstacle.at), the file's for the others."""
        if self.moving is None:
            return self.ox0, self.oy0
        tt = t[:, None]
        ox = np.where(self.moving, self.ox0 + self.vx * tt, self.ox0)
        oy = np.where(self.moving, self.oy0 + self.vy * tt, self.oy0)
        return ox, oy

    def scan(
        self,
        k: int,
        d2: np.ndarray,
        dx: np.ndarray,
        dy: np.ndarray,
        ox: np.ndarray,
        oy: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What the sensor reports at step @p k, from the squared centre
        distances @p d2 (of @p dx, @p dy) and the centres @p ox, @p oy: the
        reported mask (in range, ``<=``, and not dropped) and the reported
        centres (with their noise)."""
        seen = self._in_range(d2, dx, dy)
        if not self.noisy:
            return seen, ox, oy
        j = self._step_draws(k)
        assert self._kept is not None and self._obstacle_noise is not None
        seen &= self._kept[:, j]
        noise = self._obstacle_noise[:, j]
        noisy = (self._obstacle_sigma != 0.0)[:, None]
        return (
            seen,
            np.where(noisy, ox + noise[..., 0], ox),
            np.where(noisy, oy + noise[..., 1], oy),
        )

    def _step_draws(self, k: int) -> int:
        """The row of step @p k in the current chunk of draws (drawing the next)."""
        if self._chunk_start < 0 or k >= self._chunk_start + self._chunk:
            self._draw(k)
        return k - self._chunk_start

    def measured(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The robot's pose as its odometry reports it at step @p k (with noise)."""
        if not self._odometry_noisy.any():
            return self.x, self.y, self.theta
        j = self._step_draws(k)
        assert self._odometry is not None
        d = self._odometry[:, j]
        on = self._odometry_noisy
        return (
            np.where(on, self.x + d[:, 0], self.x),
            np.where(on, self.y + d[:, 1], self.y),
            np.where(on, self.theta + d[:, 2], self.theta),
        )

    def references(self, k: int, x: np.ndarray, y: np.ndarray) -> None:
        """Step @p k's path references for robots measured at (@p x, @p y)
        (x_r, y_r, θ_r, v_r, ω_r set); nothing for the virtual robots, which
        :meth:`advance` moves."""
        if self.paths is not None:
            self.x_r, self.y_r, self.theta_r, self.v_r, self.w_r = self.paths.sample(k, x, y)

    def body_velocity(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(v, ω) of wheel speeds [rad/s], :func:`mstc.plant.plant.body_velocity`."""
        v = self.wheel_radius * (right + left) / 2.0
        w = self.wheel_radius * (right - left) / self.track_width
        return v, w

    def advance(
        self,
        k: int,
        left: np.ndarray,
        right: np.ndarray,
        v: np.ndarray | None = None,
        w: np.ndarray | None = None,
    ) -> None:
        """Step @p k's commands (left, right wheel speeds [rad/s], and their
        body velocity @p v, @p w when the caller has it) given: move every
        robot over its period with the commands of ``delay`` periods before
        (standing still before the first), by its "lag" wheels in substeps
        where it has them (:attr:`actuator`, whose ``measured`` speeds are then
        the next step's), and every reference."""
        if self._commands.shape[1] > 1:
            depth = self._commands.shape[1]
            rows = np.arange(self.n)
            self._commands[rows, k % depth, 0] = left
            self._commands[rows, k % depth, 1] = right
            back = k - self.delay
            old = self._commands[rows, back % depth]
            late = back >= 0
            left = np.where(self.delay > 0, np.where(late, old[:, 0], 0.0), left)
            right = np.where(self.delay > 0, np.where(late, old[:, 1], 0.0), right)
            v = w = None
        act = self.actuator
        x0, y0, theta0 = self.x, self.y, self.theta
        if act is None or not self._all_lag:
            if v is None or w is None:
                v, w = self.body_velocity(left, right)
            self.x, self.y, self.theta = integrate(
                self.x, self.y, self.theta, v, w, self.dt, self.euler
            )
        if act is not None:
            rows = act.rows
            if self._all_lag:
                self.x, self.y, self.theta = act.step(left, right, x0, y0, theta0)
            else:
                nx, ny, nt = act.step(left[rows], right[rows], x0[rows], y0[rows], theta0[rows])
                self.x[rows], self.y[rows], self.theta[rows] = nx, ny, nt
        if self.paths is not None:
            pass  # the targets move in references()
        elif self._ref_step is not None:  # straight: the same increments every period
            self.x_r = self.x_r + self._ref_step[0]
            self.y_r = self.y_r + self._ref_step[1]
        else:
            self.x_r, self.y_r, self.theta_r = integrate(
                self.x_r, self.y_r, self.theta_r, self.v_r, self.w_r, self.dt, self.euler
            )
