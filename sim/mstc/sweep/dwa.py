# SPDX-License-Identifier: MIT
"""The Dynamic Window Approach: the baseline a user would pick instead of mstc.

PythonRobotics' ``dynamic_window_approach.py`` (Atsushi Sakai), vectorised
with numpy and adapted to this robot and to a moving goal. It runs in Python
behind the same :class:`~mstc.model.Controller` as the firmware, so the
sweep judges it on the same plant, sensor, scenes and metrics. Kept in
Python on purpose: it is a reference to compare against, not firmware.

What is PythonRobotics' and what is adapted (docs/sweeps.md, "DWA"):

- kept: the cost 0.15·heading + 1.0·speed + 1.0·obstacle, the obstacle cost
  1/(smallest centre distance along the predicted trajectory), infinite on
  contact; a decision every 0.1 s (its dt), the command held for the five
  control periods in between; the prediction at 0.1 s steps over 3.0 s; max
  speed 1.0 m/s, min speed −0.5 m/s; the turn that gets a stuck robot going
  (chosen and current speed under 0.001 m/s);
- robot: radius R_m (contact: centre distance ≤ R_m + the obstacle's
  radius); speeds and turn rates limited by the wheels (|ω_wheel| ≤
  max_wheel_speed) as well;
- dynamics: PythonRobotics' limits (40°/s, 0.2 m/s², 40°/s²) leave a robot
  that meets a cluster creeping for the whole run; the paper's controller
  turns at up to 7 rad/s and accelerates at about 3 m/s² on the paper's
  scenarios, but with such limits DWA's 3 s arcs loop and it weaves. Taken:
  90°/s, 1 m/s², 180°/s², which follow every reference of the suite
  (|ω_r| ≤ 0.5 rad/s) without weaving; resolutions 0.02 m/s and 2°/s
  (PythonRobotics: 0.01 m/s and 0.1°/s, thousands of trajectories a decision
  in this window, milliseconds in numpy);
- obstacle cost counted inside the obstacle's D_act only, as 1/d − 1/D_act
  (PythonRobotics' 1/d everywhere makes a robot that meets a cluster stop
  at its edge for good: every move costs more than standing);
- moving goal: the goal is where the reference robot will be at the end of
  the horizon (its motion is known: constant v_r, ω_r); the speed cost is
  |v_goal − v| with v_goal the speed that reaches the goal over the horizon
  (PythonRobotics' v_max − v drives past a moving goal); the heading cost is
  PythonRobotics' angle from the trajectory's end to the reference one
  horizon further on (to the goal itself, a trajectory ending on it gets a
  random angle);
- moving obstacles are predicted with their reported velocity.

The mode it reports is ``avoid`` on the steps where the obstacles changed
its choice (the best command without the obstacle cost differs), so time in
avoidance and switches mean the same as for the firmware's strategies.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mstc.model import Fault, Mode, Obstacle, Params, Pose, Status, StepResult, wrap_angle


@dataclass(frozen=True)
class DwaConfig:
    """DWA's parameters (PythonRobotics' names), adapted as the module says."""

    max_speed: float = 1.0
    """[m/s]"""
    min_speed: float = -0.5
    """[m/s]"""
    max_yaw_rate: float = math.radians(90.0)
    """[rad/s]"""
    max_accel: float = 1.0
    """[m/s²]"""
    max_delta_yaw_rate: float = math.radians(180.0)
    """[rad/s²]"""
    v_resolution: float = 0.02
    """[m/s]"""
    yaw_rate_resolution: float = math.radians(2.0)
    """[rad/s]"""
    period: float = 0.1
    """Time between two decisions, the command held in between [s]
    (PythonRobotics' dt); also the step of the predicted trajectories."""
    stuck_speed: float = 0.001
    """Below this speed, chosen and current, the robot is stuck and turns
    (PythonRobotics' robot_stuck_flag_cons) [m/s]."""
    predict_time: float = 3.0
    """Horizon [s]."""
    to_goal_cost_gain: float = 0.15
    speed_cost_gain: float = 1.0
    obstacle_cost_gain: float = 1.0


class DwaController:
    """DWA behind :class:`mstc.model.Controller`.

    :param params: the robot (R_m, wheel radius, track width, wheel limit).
    :param config: DWA's parameters.
    """

    numeric = "python"

    def __init__(self, params: Params, config: DwaConfig | None = None) -> None:
        self.params = params
        self.config = c = config or DwaConfig()
        wheel_v = params.max_wheel_speed * params.wheel_radius
        self.max_speed = min(c.max_speed, wheel_v)
        self.min_speed = max(c.min_speed, -wheel_v)
        self.max_yaw_rate = min(c.max_yaw_rate, 2.0 * wheel_v / params.track_width)
        self.steps = round(c.predict_time / c.period)
        self.period_us = round(c.period * 1e6)
        self.reset()

    def reset(self) -> None:
        """Start again from standstill."""
        self.v = self.w = 0.0
        self._next_us: int | None = None
        self._wheels = (0.0, 0.0)
        self._mode = Mode.TRACK
        self._faults = Fault(0)

    def _window(self) -> tuple[np.ndarray, np.ndarray]:
        """The v and ω samples of the dynamic window around the last command."""
        c = self.config
        dv, dw = c.max_accel * c.period, c.max_delta_yaw_rate * c.period
        v_lo, v_hi = max(self.min_speed, self.v - dv), min(self.max_speed, self.v + dv)
        w_lo, w_hi = max(-self.max_yaw_rate, self.w - dw), min(self.max_yaw_rate, self.w + dw)
        # np.arange as PythonRobotics, on integers so the count is exact.
        vs = v_lo + c.v_resolution * np.arange(int((v_hi - v_lo) / c.v_resolution + 1e-9) + 1)
        ws = w_lo + c.yaw_rate_resolution * np.arange(
            int((w_hi - w_lo) / c.yaw_rate_resolution + 1e-9) + 1
        )
        return vs, ws

    def _decide(
        self, robot: Pose, ref: Pose, v_r: float, w_r: float, obstacles: Sequence[Obstacle]
    ) -> tuple[float, float, bool]:
        """The best (v, ω) of the window, and whether obstacles changed the choice."""
        c = self.config
        p = self.params
        vs, ws = self._window()
        # Predicted trajectories, forward Euler at the period like
        # PythonRobotics. The heading depends on ω only, so the unit-speed
        # path is computed per ω and scaled by each v: (v, ω, k) arrays.
        k = np.arange(1, self.steps + 1)
        theta = robot.theta + np.outer(ws, k) * c.period
        ux = np.cumsum(np.cos(theta), axis=1) * c.period
        uy = np.cumsum(np.sin(theta), axis=1) * c.period
        x = robot.x + vs[:, None, None] * ux[None]
        y = robot.y + vs[:, None, None] * uy[None]
        v = np.repeat(vs, len(ws))
        w = np.tile(ws, len(vs))

        goal = _reference_ahead(ref, v_r, w_r, c.predict_time)
        # The heading is scored towards a carrot one horizon further on:
        # towards ``goal`` itself, a trajectory that ends on it would get a
        # random angle.
        carrot = _reference_ahead(ref, v_r, w_r, 2.0 * c.predict_time)
        angle = np.arctan2(carrot[1] - y[:, :, -1], carrot[0] - x[:, :, -1])
        diff = angle - theta[None, :, -1]
        heading_cost = np.abs(np.arctan2(np.sin(diff), np.cos(diff))).ravel()
        v_goal = min(
            math.hypot(goal[0] - robot.x, goal[1] - robot.y) / c.predict_time, self.max_speed
        )
        cost = c.to_goal_cost_gain * heading_cost + c.speed_cost_gain * np.abs(v_goal - v)
        best_free = int(np.argmin(cost))
        if obstacles:
            t_pred = k * c.period
            ox = np.array([o.x for o in obstacles])[:, None] + np.outer(
                [o.vx for o in obstacles], t_pred
            )
            oy = np.array([o.y for o in obstacles])[:, None] + np.outer(
                [o.vy for o in obstacles], t_pred
            )
            # Squared centre distances (v, ω, obstacle, k); one sqrt per obstacle.
            d2 = (x[:, :, None, :] - ox) ** 2 + (y[:, :, None, :] - oy) ** 2
            radii = np.array([o.radius for o in obstacles])
            reach = p.r_m + radii
            hit = (d2 <= (reach * reach)[:, None]).any(axis=(2, 3)).ravel()
            # PythonRobotics' 1/d, counted inside each obstacle's D_act only
            # (see the module): 1/d − 1/D_act, the largest over the obstacles.
            d_min = np.sqrt(d2.min(axis=3))
            influence = p.d_act + radii - p.r_ob
            ob_cost = np.maximum(1.0 / d_min - 1.0 / influence, 0.0).max(axis=2).ravel()
            cost = cost + c.obstacle_cost_gain * np.where(hit, np.inf, ob_cost)
        best = int(np.argmin(cost))
        if not np.isfinite(cost[best]):
            return 0.0, 0.0, True  # every trajectory collides: stop
        best_v, best_w = float(v[best]), float(w[best])
        if abs(best_v) < c.stuck_speed and abs(self.v) < c.stuck_speed:
            best_w = float(ws[0])  # PythonRobotics: turn to get unstuck
        return best_v, best_w, best != best_free

    def step(
        self,
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        obstacles: Sequence[Obstacle],
        t_us: int,
        wheel_speeds: tuple[float, float] | None = None,
    ) -> StepResult:
        """One control period (see :meth:`mstc.model.Controller.step`): a
        new decision every ``config.period``, the last one held in between."""
        p = self.params
        if self._next_us is None or t_us >= self._next_us:
            self._next_us = t_us + self.period_us
            self.v, self.w, avoiding = self._decide(robot, ref, v_r, w_r, obstacles)
            self._mode = Mode.AVOID if avoiding else Mode.TRACK
            r, half = p.wheel_radius, p.track_width / 2.0
            right, left = (self.v + self.w * half) / r, (self.v - self.w * half) / r
            self._faults = Fault(0)
            peak = max(abs(left), abs(right))
            if peak > p.max_wheel_speed:
                left, right = left * p.max_wheel_speed / peak, right * p.max_wheel_speed / peak
                self._faults = Fault.SATURATED
            self._wheels = (left, right)
        left, right = self._wheels
        dx, dy = ref.x - robot.x, ref.y - robot.y
        cos_t, sin_t = math.cos(robot.theta), math.sin(robot.theta)
        status = Status(
            mode=self._mode,
            active_obstacle=0,
            side=None,
            faults=self._faults,
            e1=cos_t * dx + sin_t * dy,
            e2=-sin_t * dx + cos_t * dy,
            e3=wrap_angle(ref.theta - robot.theta),
            e=0.0,
            v=p.wheel_radius * (left + right) / 2.0,
            w=p.wheel_radius * (right - left) / p.track_width,
        )
        return StepResult(left, right, status, ())


def _reference_ahead(ref: Pose, v_r: float, w_r: float, horizon: float) -> tuple[float, float]:
    """Where the reference robot (constant v_r, ω_r) will be after @p horizon [s]."""
    if abs(w_r) < 1e-9:
        return (
            ref.x + v_r * horizon * math.cos(ref.theta),
            ref.y + v_r * horizon * math.sin(ref.theta),
        )
    th = ref.theta + w_r * horizon
    return (
        ref.x + v_r / w_r * (math.sin(th) - math.sin(ref.theta)),
        ref.y - v_r / w_r * (math.cos(th) - math.cos(ref.theta)),
    )
