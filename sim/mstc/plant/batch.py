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
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from mstc.plant.plant import Integrator
from mstc.plant.scenario import Scenario
from mstc.plant.world import random_streams

CHUNK = 128
"""Steps of random draws made at once per scene."""

_TAU, _PI = math.tau, math.pi
_SMALL_ANGLE = 1e-4
"""As :mod:`mstc.plant.plant`: below it sin(h)/h is its series."""


def table_width(scenarios: Sequence[Scenario]) -> int:
    """Entries of every scene's obstacle table in a batch of @p scenarios:
    the largest scene's (at least 1)."""
    return max([1, *(len(s.obstacles) for s in scenarios)])


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
        within = d2 <= self._sure
        unsure = (d2 <= self._maybe) ^ within
        if unsure.any():
            idx = np.nonzero(unsure)
            limit = np.broadcast_to(self.threshold, d2.shape)[idx]
            within[idx] = exact_hypot(dx[idx], dy[idx]) <= limit
        return within


def wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped into (-π, π] as :func:`mstc.model.wrap_angle`, bit for
    bit: fmod is exact, and so is the subtraction of 2π from a remainder
    above π (Sterbenz); ±π at a tie becomes π either way."""
    r = np.fmod(a, _TAU)
    r = np.where(r > _PI, r - _TAU, r)
    r = np.where(r < -_PI, r + _TAU, r)
    return np.where(r == -_PI, _PI, r)


def integrate(
    x: np.ndarray,
    y: np.ndarray,
    theta: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    dt: np.ndarray,
    euler: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`mstc.plant.plant.integrate` over arrays: forward Euler where
    @p euler (None: everywhere), the exact arc elsewhere; the same
    operations in the same order."""
    vdt = v * np.cos(theta) * dt
    nx = x + vdt
    ny = y + v * np.sin(theta) * dt
    nt = theta + w * dt
    if euler is None:
        return nx, ny, nt
    half = 0.5 * w * dt
    with np.errstate(invalid="ignore", divide="ignore"):
        sinc = np.where(np.abs(half) < _SMALL_ANGLE, 1.0 - half * half / 6.0, np.sin(half) / half)
    chord = v * dt * sinc
    mid = theta + half
    ax = x + chord * np.cos(mid)
    ay = y + chord * np.sin(mid)
    return np.where(euler, nx, ax), np.where(euler, ny, ay), nt


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
        self.x_r = col([s.reference.pose.x for s in sc])
        self.y_r = col([s.reference.pose.y for s in sc])
        self.theta_r = col([s.reference.pose.theta for s in sc])
        self.v_r = col([s.reference.v for s in sc])
        self.w_r = col([s.reference.w for s in sc])

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
        self._in_range = Within(self.sensor_range[:, None] + (self.radius - r_ob[:, None]))
        self.delay = np.array([m_.delay for m_ in imp], dtype=np.int64)
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
        if not self.w_r.any():
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
        (standing still before the first), and every reference."""
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
        if v is None or w is None:
            v, w = self.body_velocity(left, right)
        self.x, self.y, self.theta = integrate(
            self.x, self.y, self.theta, v, w, self.dt, self.euler
        )
        if self._ref_step is not None:  # straight: the same increments every period
            self.x_r = self.x_r + self._ref_step[0]
            self.y_r = self.y_r + self._ref_step[1]
        else:
            self.x_r, self.y_r, self.theta_r = integrate(
                self.x_r, self.y_r, self.theta_r, self.v_r, self.w_r, self.dt, self.euler
            )
