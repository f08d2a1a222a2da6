# SPDX-License-Identifier: MIT
"""The firmware's control step in this process: :class:`SilController`.

It calls ``mstc_sil_step`` of ``libmstc_sil.so`` (through the bindings of
:mod:`mstc.can.library`) once per control period, no frames. Its modes and
event kinds are the firmware's ``sup_mode_t`` and ``sup_event_kind_t``, which
the firmware asserts equal to the DBC's STATUS_mode and EVENT_kind values, so
they are decoded with the DBC's value tables (:mod:`mstc.can.dbc`); its sides
are the sign of α (``avd_side_t``: 1 left, -1 right, 0 none), a geometric
convention rather than a wire value.
"""

from __future__ import annotations

import ctypes
import errno
import math
import os
from collections.abc import Sequence
from typing import Any

from mstc.can.dbc import tables
from mstc.can.library import (
    MAX_EVENTS,
    MAX_OBSTACLES,
    InputStruct,
    Library,
    ObstacleStruct,
    OutputStruct,
    ParamsStruct,
    field_packer,
)
from mstc.errors import FirmwareError
from mstc.model import (
    Event,
    Fault,
    Obstacle,
    Params,
    Pose,
    Side,
    Status,
    StepResult,
    StepValues,
    Strategy,
)

_ALIGN = 16
"""Alignment the controller memory needs."""

_TAU, _PI = math.tau, math.pi
_SIDES = {0: None, 1: Side.LEFT, -1: Side.RIGHT}
"""``avd_side_t``, the sign of α in eq. (10)-(12): not a wire value."""

_INPUT = field_packer(InputStruct, ("robot", "ref", "v_r", "w_r", "t_us", "n_obstacles"))
"""The scalars of one step's input, after which its obstacle pointer follows."""
_OBSTACLE = field_packer(ObstacleStruct, ("id", "x", "y", "radius", "vx", "vy"))
_OBSTACLE_SIZE = ctypes.sizeof(ObstacleStruct)
_OUTPUT = field_packer(
    OutputStruct,
    (
        "wheel_left",
        "wheel_right",
        "mode",
        "active_obstacle",
        "side",
        "faults",
        "e1",
        "e2",
        "e3",
        "e",
        "v",
        "w",
        "n_events",
    ),
)
"""One step's output but its obstacle table and events."""


def _c_params(p: Params) -> ParamsStruct:
    return ParamsStruct(
        r_m=p.r_m,
        r_ob=p.r_ob,
        d_det=p.d_det,
        d_act=p.d_act,
        d_s=p.d_s,
        trk_k=(ctypes.c_double * 3)(*p.tracking_gains),
        avd_k=(ctypes.c_double * 2)(*p.avoidance_gains),
        wheel_radius=p.wheel_radius,
        track_width=p.track_width,
        max_wheel_speed=p.max_wheel_speed,
        strategy=tables().strategy.value(str(p.strategy)),
    )


_FAULTS: dict[int, Fault] = {}


def _fault(mask: int) -> Fault:
    """Fault(mask), remembered: building an IntFlag costs more than a step."""
    fault = _FAULTS.get(mask)
    if fault is None:
        fault = _FAULTS[mask] = Fault(mask)
    return fault


class SilController:
    """The firmware's control step in this process (a :class:`~mstc.model.Controller`).

    Each instance owns one controller's memory, so several can run side by side.

    :param params: controller parameters.
    :param lib_path: path of ``libmstc_sil.so``; None reads it from the
        environment variable ``MSTC_SIL_LIB``.

    :raises FirmwareError: no library, it cannot be loaded, or it rejects ``params``.
    """

    def __init__(self, params: Params, lib_path: str | os.PathLike[str] | None = None) -> None:
        library = Library.open(lib_path)
        self._lib = library.dll
        self.lib_path = library.path
        self.numeric: str = library.numeric
        """The firmware's numeric mode, "float" or "fixed"."""
        self._tables = tables()
        size = self._lib.mstc_sil_size()
        # Caller-owned memory, 16-byte aligned: over-allocate and offset.
        self._mem = (ctypes.c_uint8 * (size + _ALIGN))()
        address = ctypes.addressof(self._mem)
        self._state = ctypes.c_void_p(address + (-address % _ALIGN))
        c_params = _c_params(params)
        rc = self._lib.mstc_sil_init(self._state, ctypes.byref(c_params))
        if rc == -errno.EINVAL:
            raise FirmwareError(
                f"the firmware rejected the parameters (mstc_sil_init returned -EINVAL): {params}"
            )
        if rc != 0:
            raise FirmwareError(f"mstc_sil_init failed with {rc}")
        self._in = InputStruct()
        self._out = OutputStruct()
        self._obstacles = (ObstacleStruct * MAX_OBSTACLES)()
        self._in.obstacles = self._obstacles
        # Made once: byref and the attribute look-ups cost as much as the step.
        self._in_ref = ctypes.byref(self._in)
        self._out_ref = ctypes.byref(self._out)
        self._step = self._lib.mstc_sil_step
        self._modes = self._tables.mode

    @staticmethod
    def defaults(lib_path: str | os.PathLike[str] | None = None) -> Params:
        """The parameters the firmware uses by default (mstc_sil_defaults)."""
        lib = Library.open(lib_path).dll
        c = ParamsStruct()
        lib.mstc_sil_defaults(ctypes.byref(c))
        return Params(
            r_m=c.r_m,
            r_ob=c.r_ob,
            d_det=c.d_det,
            d_act=c.d_act,
            d_s=c.d_s,
            tracking_gains=(c.trk_k[0], c.trk_k[1], c.trk_k[2]),
            avoidance_gains=(c.avd_k[0], c.avd_k[1]),
            wheel_radius=c.wheel_radius,
            track_width=c.track_width,
            max_wheel_speed=c.max_wheel_speed,
            strategy=tables().strategy.members(Strategy)[c.strategy],
        )

    def step(
        self,
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        obstacles: Sequence[Obstacle],
        t_us: int,
    ) -> StepResult:
        """One control step (see :meth:`mstc.model.Controller.step`).

        :raises FirmwareError: more than MAX_OBSTACLES obstacles, or the library
            refused the step or returned a value outside its ABI.
        """
        left, right, mode, active, side, faults, e1, e2, e3, e, v, w, n_events = self._call(
            robot, ref, v_r, w_r, obstacles, t_us
        )
        try:
            status = Status(
                mode=self._modes[mode],
                active_obstacle=active,
                side=_SIDES[side],
                faults=_fault(faults),
                e1=e1,
                e2=e2,
                e3=e3,
                e=e,
                v=v,
                w=w,
            )
        except (KeyError, ValueError) as exc:
            raise FirmwareError(f"the library returned a value outside its ABI: {exc}") from exc
        return StepResult(left, right, status, self._events(n_events))

    def step_values(
        self,
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        obstacles: Sequence[Obstacle],
        t_us: int,
    ) -> StepValues:
        """:meth:`step`, its result as the plain tuple the in-memory loop
        records (:data:`mstc.model.StepValues`): building the Status and
        StepResult objects costs more than the firmware's step.

        :raises FirmwareError: as :meth:`step`.
        """
        left, right, mode, _, side, faults, e1, e2, e3, e, _, _, n_events = self._call(
            robot, ref, v_r, w_r, obstacles, t_us
        )
        try:
            decoded, _ = self._modes[mode], _SIDES[side]
        except KeyError as exc:
            raise FirmwareError(f"the library returned a value outside its ABI: {exc}") from exc
        return left, right, decoded, faults, e1, e2, e3, e, self._events(n_events)

    def _call(
        self,
        robot: Pose,
        ref: Pose,
        v_r: float,
        w_r: float,
        obstacles: Sequence[Obstacle],
        t_us: int,
    ) -> tuple[Any, ...]:
        """Run the step; the scalars of its output (:data:`_OUTPUT`'s fields)."""
        if len(obstacles) > MAX_OBSTACLES:
            raise FirmwareError(f"{len(obstacles)} obstacles reported, at most {MAX_OBSTACLES}")
        # Headings cross the boundary wrapped (wrap_angle, inlined: it costs
        # as much as the step), as a sensor reports them, so float32 keeps
        # its resolution on long runs.
        theta = math.remainder(robot.theta, _TAU)
        theta_r = math.remainder(ref.theta, _TAU)
        _INPUT.pack_into(
            self._in,
            0,
            robot.x,
            robot.y,
            _PI if theta == -_PI else theta,
            ref.x,
            ref.y,
            _PI if theta_r == -_PI else theta_r,
            v_r,
            w_r,
            t_us,
            len(obstacles),
        )
        pack, table = _OBSTACLE.pack_into, self._obstacles
        for i, o in enumerate(obstacles):
            pack(table, i * _OBSTACLE_SIZE, o.id, o.x, o.y, o.radius, o.vx, o.vy)
        rc = self._step(self._state, self._in_ref, self._out_ref)
        if rc != 0:
            raise FirmwareError(f"mstc_sil_step failed with {rc} at t_us={t_us}")
        return _OUTPUT.unpack_from(self._out)

    def _events(self, n_events: int) -> tuple[Event, ...]:
        """The @p n_events events of the last step's output."""
        if not n_events:
            return ()
        kinds = self._tables.event_kind
        try:
            if n_events > MAX_EVENTS:
                raise KeyError(f"n_events {n_events}")
            return tuple(
                Event(ev.t_us, kinds[ev.kind], ev.obstacle, _SIDES[ev.side])
                for ev in self._out.events[:n_events]
            )
        except (KeyError, ValueError) as exc:
            raise FirmwareError(f"the library returned a value outside its ABI: {exc}") from exc
