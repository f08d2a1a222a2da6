# SPDX-License-Identifier: MIT
"""The firmware's control step in this process: :class:`SilController`, and
many controllers stepped in one call, :class:`SilBatch`.

It calls ``mstc_sil_step`` of ``libmstc_sil.so`` (through the bindings of
:mod:`mstc.can.library`) once per control period, no frames; the batch calls
``mstc_sil_step_batch`` once per period for all its controllers, on numpy
structured arrays. Its modes and
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
from struct import Struct
from typing import TYPE_CHECKING, Any

import numpy as np

from mstc.can.dbc import tables
from mstc.can.library import (
    BATCH_INPUT_DTYPE,
    MAX_EVENTS,
    MAX_OBSTACLES,
    OUTPUT_DTYPE,
    InputStruct,
    Library,
    ObstacleStruct,
    OutputStruct,
    ParamsStruct,
    field_packer,
)
from mstc.errors import FirmwareError

if TYPE_CHECKING:
    from mstc.firmware.wheels import DcWheels
from mstc.model import (
    Event,
    Fault,
    Mode,
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
_WHEELS_AT: int = InputStruct.wheel_speed.offset
"""Where the measured wheel speeds of one step's input start, after the
obstacle pointer: a packer of its own, since pack_into writes the padding it
skips."""
_WHEELS = Struct(f"=2d{InputStruct.wheel_measured.offset - _WHEELS_AT - 16}xII")
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
        wheel_accel=p.wheel_accel,
        wheel_tau=p.wheel_tau,
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
    :param wheels: the board's own wheels (the plant's "dc" actuator), for an
        integrated board (docs/wheel.md, "Two topologies"): each step takes
        their wheel loop's estimate and its age, as a board's main loop hands
        them, and the ``wheel_speeds`` a step is given (WHEEL_SPEED, external
        drives) are not its input. None: external drives.

    :raises FirmwareError: no library, it cannot be loaded, or it rejects ``params``.
    """

    def __init__(
        self,
        params: Params,
        lib_path: str | os.PathLike[str] | None = None,
        wheels: DcWheels | None = None,
    ) -> None:
        self._wheels = wheels
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
        self._measured = False
        """The input holds measured wheel speeds (packed by the last step)."""

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
            wheel_accel=c.wheel_accel,
            wheel_tau=c.wheel_tau,
        )

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
        """One control step (see :meth:`mstc.model.Controller.step`).

        :raises FirmwareError: more than MAX_OBSTACLES obstacles, or the library
            refused the step or returned a value outside its ABI.
        """
        left, right, mode, active, side, faults, e1, e2, e3, e, v, w, n_events = self._call(
            robot, ref, v_r, w_r, obstacles, t_us, wheel_speeds
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
        wheel_speeds: tuple[float, float] | None = None,
    ) -> StepValues:
        """:meth:`step`, its result as the plain tuple the in-memory loop
        records (:data:`mstc.model.StepValues`): building the Status and
        StepResult objects costs more than the firmware's step.

        :raises FirmwareError: as :meth:`step`.
        """
        left, right, mode, _, side, faults, e1, e2, e3, e, _, _, n_events = self._call(
            robot, ref, v_r, w_r, obstacles, t_us, wheel_speeds
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
        wheel_speeds: tuple[float, float] | None,
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
        if self._wheels is not None:
            # The board's own: the wheel loop's estimate now, of its age.
            state = self._wheels.state
            measured = state.periods > 0
            left, right = state.measured if measured else (0.0, 0.0)
            _WHEELS.pack_into(self._in, _WHEELS_AT, left, right, int(measured), state.age_us)
        elif wheel_speeds is None:
            if self._measured:
                _WHEELS.pack_into(self._in, _WHEELS_AT, 0.0, 0.0, 0, 0)
                self._measured = False
        else:
            _WHEELS.pack_into(self._in, _WHEELS_AT, wheel_speeds[0], wheel_speeds[1], 1, 0)
            self._measured = True
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


class SilBatch:
    """@p params' controllers of the firmware, side by side in one block of
    memory, stepped together by ``mstc_sil_step_batch``: controller i steps on
    :attr:`inputs` [i] into :attr:`outputs` [i], exactly as a
    :class:`SilController` would on the same values.

    :attr:`inputs` is a ``mstc_sil_batch_input_t`` array: the caller fills it
    (poses wrapped into (-π, π], as :meth:`SilController.step` passes them;
    the obstacle table with ``in.n_obstacles`` entries and the ``reported``
    mask) before each :meth:`step`.

    :param params: one controller's parameters per entry.
    :param lib_path: as :class:`SilController`'s.

    :raises FirmwareError: no library, or it rejects a controller's parameters
        (:attr:`rejected` says which instead when @p strict is False).
    """

    def __init__(
        self,
        params: Sequence[Params],
        lib_path: str | os.PathLike[str] | None = None,
        *,
        strict: bool = True,
    ) -> None:
        library = Library.open(lib_path)
        lib = library.dll
        self.lib_path = library.path
        self.numeric: str = library.numeric
        self.n = len(params)
        stride = int(lib.mstc_sil_batch_stride())
        self._mem = np.zeros(self.n * stride + _ALIGN, dtype=np.uint8)
        base = self._mem.ctypes.data
        self._base = base + (-base % _ALIGN)
        self.rejected: dict[int, str] = {}
        """Controllers whose parameters the firmware refused, with why."""
        for i, p in enumerate(params):
            rc = lib.mstc_sil_init(
                ctypes.c_void_p(self._base + i * stride), ctypes.byref(_c_params(p))
            )
            if rc != 0:
                why = (
                    f"the firmware rejected the parameters (mstc_sil_init returned -EINVAL): {p}"
                    if rc == -errno.EINVAL
                    else f"mstc_sil_init failed with {rc}"
                )
                if strict:
                    raise FirmwareError(why)
                self.rejected[i] = why
        self.inputs = np.zeros(self.n, dtype=BATCH_INPUT_DTYPE)
        self.outputs = np.zeros(self.n, dtype=OUTPUT_DTYPE)
        table = self.outputs["events"]
        self._event_columns = (
            self.outputs["n_events"],
            table["t_us"],
            table["kind"],
            table["obstacle"],
            table["side"],
        )
        """Views of the outputs' event table (read in :meth:`events`)."""
        self._step = lib.mstc_sil_step_batch
        t = tables()
        self.modes: dict[int, Mode] = t.mode
        """Mode by the firmware's number (the output's ``mode``)."""
        self._kinds = t.event_kind

    def step(self, active: np.ndarray | None = None) -> None:
        """One control step of every controller (of those where @p active, a
        bool array, is True).

        :raises FirmwareError: the library refused the inputs (an obstacle
            table too long, or a reported bit beyond it).
        """
        mask = None if active is None else np.ascontiguousarray(active, dtype=np.uint8)
        rc = self._step(
            ctypes.c_void_p(self._base),
            self.n,
            self.inputs.ctypes.data,
            None if mask is None else mask.ctypes.data,
            self.outputs.ctypes.data,
        )
        if rc != 0:
            raise FirmwareError(f"mstc_sil_step_batch failed with {rc}")

    def events(self, rows: Sequence[int]) -> list[tuple[Event, ...]]:
        """The events each controller of @p rows emitted in the last step
        (its output's table read once, whole columns at a time).

        :raises FirmwareError: a value outside the ABI.
        """
        if not len(rows):
            return []
        at = np.asarray(rows, dtype=np.intp)
        n_events, *columns = self._event_columns
        counts = n_events[at].tolist()
        t_us, kind, obstacle, side = (c[at].tolist() for c in columns)
        kinds = self._kinds
        try:
            got = []
            for r, n in enumerate(counts):
                if n > MAX_EVENTS:
                    raise KeyError(f"n_events {n}")
                got.append(
                    tuple(
                        Event(t_us[r][j], kinds[kind[r][j]], obstacle[r][j], _SIDES[side[r][j]])
                        for j in range(n)
                    )
                )
            return got
        except (KeyError, ValueError) as exc:
            raise FirmwareError(f"the library returned a value outside its ABI: {exc}") from exc
