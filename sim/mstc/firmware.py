# SPDX-License-Identifier: MIT
"""The firmware's control step, called in-process through its C ABI.

Binds ``libmstc_sil.so`` (``make lib``; the ABI is ``hal/sil/mstc_sil.h``) with
ctypes. The structures below mirror that header field for field; the library
converts to and from the firmware's numeric type at this boundary.
"""

import ctypes
import errno
import os
from collections.abc import Sequence
from pathlib import Path

from mstc.controller import Event, EventKind, Fault, Mode, Side, Status, StepResult
from mstc.errors import FirmwareError
from mstc.params import Params
from mstc.sim.plant import Pose, wrap_angle
from mstc.sim.sensor import Obstacle

LIB_ENV = "MSTC_SIL_LIB"
"""Environment variable naming the library when no path is given."""

MAX_OBSTACLES = 16
"""MSTC_SIL_MAX_OBSTACLES."""
MAX_EVENTS = 18
"""MSTC_SIL_MAX_EVENTS."""
_ALIGN = 16
"""Alignment the controller memory needs."""

_MODES = {0: Mode.TRACK, 1: Mode.AVOID, 2: Mode.STOP}
_KINDS = {1: EventKind.DETECT, 2: EventKind.ACTIVATE, 3: EventKind.COMPLETE}
_SIDES = {0: None, 1: Side.LEFT, -1: Side.RIGHT}


class _Params(ctypes.Structure):
    _fields_ = [
        ("r_m", ctypes.c_double),
        ("r_ob", ctypes.c_double),
        ("d_det", ctypes.c_double),
        ("d_act", ctypes.c_double),
        ("d_s", ctypes.c_double),
        ("trk_k", ctypes.c_double * 3),
        ("avd_k", ctypes.c_double * 2),
        ("wheel_radius", ctypes.c_double),
        ("track_width", ctypes.c_double),
        ("max_wheel_speed", ctypes.c_double),
    ]


class _Obstacle(ctypes.Structure):
    _fields_ = [
        ("id", ctypes.c_uint32),
        ("x", ctypes.c_double),
        ("y", ctypes.c_double),
        ("radius", ctypes.c_double),
    ]


class _Input(ctypes.Structure):
    _fields_ = [
        ("robot", ctypes.c_double * 3),
        ("ref", ctypes.c_double * 3),
        ("v_r", ctypes.c_double),
        ("w_r", ctypes.c_double),
        ("t_us", ctypes.c_uint64),
        ("n_obstacles", ctypes.c_uint32),
        ("obstacles", ctypes.POINTER(_Obstacle)),
    ]


class _Event(ctypes.Structure):
    _fields_ = [
        ("t_us", ctypes.c_uint64),
        ("kind", ctypes.c_int32),
        ("obstacle", ctypes.c_int32),
        ("side", ctypes.c_int32),
    ]


class _Output(ctypes.Structure):
    _fields_ = [
        ("wheel_left", ctypes.c_double),
        ("wheel_right", ctypes.c_double),
        ("mode", ctypes.c_int32),
        ("active_obstacle", ctypes.c_int32),
        ("side", ctypes.c_int32),
        ("faults", ctypes.c_uint32),
        ("e1", ctypes.c_double),
        ("e2", ctypes.c_double),
        ("e3", ctypes.c_double),
        ("e", ctypes.c_double),
        ("v", ctypes.c_double),
        ("w", ctypes.c_double),
        ("n_obstacles", ctypes.c_uint32),
        ("obstacle_id", ctypes.c_uint32 * MAX_OBSTACLES),
        ("distance", ctypes.c_double * MAX_OBSTACLES),
        ("n_events", ctypes.c_uint32),
        ("events", _Event * MAX_EVENTS),
    ]


def _load(path: str | os.PathLike[str] | None) -> tuple[ctypes.CDLL, Path]:
    """Open the library and declare the signatures of its functions."""
    if path is None:
        path = os.environ.get(LIB_ENV)
        if not path:
            raise FirmwareError(
                f"no firmware library: pass its path (--lib) or set {LIB_ENV} "
                "(build it with `make lib`)"
            )
    lib_path = Path(path)
    try:
        lib = ctypes.CDLL(str(lib_path.resolve()))
        lib.mstc_sil_size.argtypes = []
        lib.mstc_sil_size.restype = ctypes.c_size_t
        lib.mstc_sil_numeric.argtypes = []
        lib.mstc_sil_numeric.restype = ctypes.c_char_p
        lib.mstc_sil_defaults.argtypes = [ctypes.POINTER(_Params)]
        lib.mstc_sil_defaults.restype = None
        lib.mstc_sil_init.argtypes = [ctypes.c_void_p, ctypes.POINTER(_Params)]
        lib.mstc_sil_init.restype = ctypes.c_int
        lib.mstc_sil_step.argtypes = [
            ctypes.c_void_p,
            ctypes.POINTER(_Input),
            ctypes.POINTER(_Output),
        ]
        lib.mstc_sil_step.restype = ctypes.c_int
    except OSError as exc:
        raise FirmwareError(f"cannot load firmware library {lib_path}: {exc}") from exc
    except AttributeError as exc:
        raise FirmwareError(f"{lib_path} is not the mstc SIL library: {exc}") from exc
    return lib, lib_path


def _c_params(p: Params) -> _Params:
    return _Params(
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
    )


class SilController:
    """The firmware's control step in this process (a :class:`~mstc.controller.Controller`).

    Each instance owns one controller's memory, so several can run side by side.

    :param params: controller parameters.
    :param lib_path: path of ``libmstc_sil.so``; None reads it from the
        environment variable ``MSTC_SIL_LIB``.

    :raises FirmwareError: no library, it cannot be loaded, or it rejects ``params``.
    """

    def __init__(self, params: Params, lib_path: str | os.PathLike[str] | None = None) -> None:
        self._lib, self.lib_path = _load(lib_path)
        self.numeric: str = self._lib.mstc_sil_numeric().decode("ascii")
        """The firmware's numeric mode, "float" or "fixed"."""
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
        self._in = _Input()
        self._out = _Output()
        self._obstacles = (_Obstacle * MAX_OBSTACLES)()
        self._in.obstacles = self._obstacles

    @staticmethod
    def defaults(lib_path: str | os.PathLike[str] | None = None) -> Params:
        """The parameters the firmware uses by default (mstc_sil_defaults)."""
        lib, _ = _load(lib_path)
        c = _Params()
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
        """One control step (see :meth:`mstc.controller.Controller.step`).

        :raises FirmwareError: more than MAX_OBSTACLES obstacles, or the library
            refused the step or returned a value outside its ABI.
        """
        if len(obstacles) > MAX_OBSTACLES:
            raise FirmwareError(f"{len(obstacles)} obstacles reported, at most {MAX_OBSTACLES}")
        inp = self._in
        # Headings cross the boundary wrapped, as a sensor reports them, so
        # float32 keeps its resolution on long runs.
        inp.robot[:] = (robot.x, robot.y, wrap_angle(robot.theta))
        inp.ref[:] = (ref.x, ref.y, wrap_angle(ref.theta))
        inp.v_r = v_r
        inp.w_r = w_r
        inp.t_us = t_us
        inp.n_obstacles = len(obstacles)
        for slot, o in zip(self._obstacles, obstacles, strict=False):
            slot.id, slot.x, slot.y, slot.radius = o.id, o.x, o.y, o.radius
        rc = self._lib.mstc_sil_step(self._state, ctypes.byref(inp), ctypes.byref(self._out))
        if rc != 0:
            raise FirmwareError(f"mstc_sil_step failed with {rc} at t_us={t_us}")
        return self._result()

    def _result(self) -> StepResult:
        out = self._out
        try:
            status = Status(
                mode=_MODES[out.mode],
                active_obstacle=out.active_obstacle,
                side=_SIDES[out.side],
                faults=Fault(out.faults),
                e1=out.e1,
                e2=out.e2,
                e3=out.e3,
                e=out.e,
                v=out.v,
                w=out.w,
            )
            if out.n_events > MAX_EVENTS:
                raise KeyError(f"n_events {out.n_events}")
            events = tuple(
                Event(ev.t_us, _KINDS[ev.kind], ev.obstacle, _SIDES[ev.side])
                for ev in out.events[: out.n_events]
            )
        except (KeyError, ValueError) as exc:
            raise FirmwareError(f"the library returned a value outside its ABI: {exc}") from exc
        return StepResult(out.wheel_left, out.wheel_right, status, events)
