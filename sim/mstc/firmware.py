# SPDX-License-Identifier: MIT
"""The firmware library's bindings, in one place, and its control step in-process.

``libmstc_sil.so`` (``make lib``; the ABI is ``hal/sil/mstc_sil.h``) is reached
through ctypes by three users: the in-memory controller
(:class:`SilController`), the python-can interface ``mstc-sil``
(:mod:`mstc.can.silbus`) and the replay (:mod:`mstc.logs.replay`). All of them
open it with :meth:`Library.open`, which declares the signatures and checks
every structure below against the layout the library exports
(``mstc_sil_layout()``: each struct's size, each field's offset and size), so
a field added or changed on one side only is a :class:`FirmwareError` naming
the struct and the field, never garbage read at the wrong offset. Adding a
field means adding it to the C struct (and its row of the layout table in
mstc_sil.c) and to the struct here.

The library converts to and from the firmware's numeric type at this
boundary: everything here is double or an integer. Its modes and event kinds
are the firmware's ``sup_mode_t`` and ``sup_event_kind_t``, which the firmware
asserts equal to the DBC's STATUS_mode and EVENT_kind values, so they are
decoded with the DBC's value tables (:mod:`mstc.can.dbc`); its sides are the
sign of α (``avd_side_t``: 1 left, -1 right, 0 none), a geometric convention
rather than a wire value.
"""

from __future__ import annotations

import ctypes
import errno
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from struct import Struct
from typing import TYPE_CHECKING, Any, ClassVar

from mstc.can.dbc import tables
from mstc.controller import Event, Fault, Side, Status, StepResult
from mstc.errors import FirmwareError
from mstc.params import Params, Strategy
from mstc.sim.plant import Pose
from mstc.sim.sensor import Obstacle

if TYPE_CHECKING:
    from mstc.sim.run import StepValues

LIB_ENV = "MSTC_SIL_LIB"
"""Environment variable naming the library when no path is given."""

MAX_OBSTACLES = 16
"""MSTC_SIL_MAX_OBSTACLES (checked through the size of ``mstc_sil_output_t.obstacle_id``)."""
MAX_EVENTS = 18
"""MSTC_SIL_MAX_EVENTS (checked through the size of ``mstc_sil_output_t.events``)."""
FRAME_DATA = 8
"""Data bytes of ``mstc_sil_frame_t``."""
_ALIGN = 16
"""Alignment the controller memory needs."""

_TAU, _PI = math.tau, math.pi
_SIDES = {0: None, 1: Side.LEFT, -1: Side.RIGHT}
"""``avd_side_t``, the sign of α in eq. (10)-(12): not a wire value."""


class AbiStruct(ctypes.Structure):
    """A struct of hal/sil/mstc_sil.h; :attr:`c_name` is its name there."""

    c_name: ClassVar[str] = ""


class ParamsStruct(AbiStruct):
    """``mstc_sil_params_t``: parameters, SI units."""

    c_name = "mstc_sil_params_t"
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
        ("strategy", ctypes.c_uint32),
        ("wheel_accel", ctypes.c_double),
        ("wheel_tau", ctypes.c_double),
    ]


class ObstacleStruct(AbiStruct):
    """``mstc_sil_obstacle_t``: a reported obstacle."""

    c_name = "mstc_sil_obstacle_t"
    _fields_ = [
        ("id", ctypes.c_uint32),
        ("x", ctypes.c_double),
        ("y", ctypes.c_double),
        ("radius", ctypes.c_double),
        ("vx", ctypes.c_double),
        ("vy", ctypes.c_double),
    ]


class InputStruct(AbiStruct):
    """``mstc_sil_input_t``: the inputs of one step."""

    c_name = "mstc_sil_input_t"
    _fields_ = [
        ("robot", ctypes.c_double * 3),
        ("ref", ctypes.c_double * 3),
        ("v_r", ctypes.c_double),
        ("w_r", ctypes.c_double),
        ("t_us", ctypes.c_uint64),
        ("n_obstacles", ctypes.c_uint32),
        ("obstacles", ctypes.POINTER(ObstacleStruct)),
        ("wheel_speed", ctypes.c_double * 2),
        ("wheel_measured", ctypes.c_uint32),
    ]


class EventStruct(AbiStruct):
    """``mstc_sil_event_t``: a switching event."""

    c_name = "mstc_sil_event_t"
    _fields_ = [
        ("t_us", ctypes.c_uint64),
        ("kind", ctypes.c_int32),
        ("obstacle", ctypes.c_int32),
        ("side", ctypes.c_int32),
    ]


class OutputStruct(AbiStruct):
    """``mstc_sil_output_t``: the outputs of one step."""

    c_name = "mstc_sil_output_t"
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
        ("events", EventStruct * MAX_EVENTS),
    ]


class FrameStruct(AbiStruct):
    """``mstc_sil_frame_t``: a classic CAN frame."""

    c_name = "mstc_sil_frame_t"
    _fields_ = [
        ("id", ctypes.c_uint32),
        ("dlc", ctypes.c_uint8),
        ("data", ctypes.c_uint8 * FRAME_DATA),
    ]


ABI_STRUCTS: tuple[type[AbiStruct], ...] = (
    ParamsStruct,
    ObstacleStruct,
    InputStruct,
    EventStruct,
    OutputStruct,
    FrameStruct,
)
"""Every struct of the ABI, checked at load time."""


class _LayoutEntry(ctypes.Structure):
    """``mstc_sil_layout_t``: the carrier of the check, the one struct it cannot check."""

    _fields_ = [
        ("type", ctypes.c_char_p),
        ("field", ctypes.c_char_p),
        ("offset", ctypes.c_uint32),
        ("size", ctypes.c_uint32),
    ]


Layout = dict[str, dict[str | None, tuple[int, int]]]
"""By struct name: (offset, size) of each field, and of the whole struct under None."""


_FORMAT_CODES: dict[type, str] = {
    ctypes.c_double: "d",
    ctypes.c_uint64: "Q",
    ctypes.c_uint32: "I",
    ctypes.c_int32: "i",
    ctypes.c_uint8: "B",
}
"""struct module codes of the ctypes scalar types the ABI uses."""


def field_packer(c_struct: type[ctypes.Structure], names: Sequence[str]) -> Struct:
    """A :class:`struct.Struct` that reads or writes the fields @p names (in
    offset order) of @p c_struct in one call, each at its ctypes offset (the
    offsets :func:`check_layout` compares with the library's), the bytes in
    between skipped: one ``pack_into`` or ``unpack_from`` costs less than two
    attribute accesses of a ctypes struct."""
    types: dict[str, type] = {f[0]: f[1] for f in c_struct._fields_}
    fmt, at = "=", 0
    for name in names:
        descriptor = getattr(c_struct, name)
        ctype: Any = types[name]  # ctypes' array types are typed loosely
        count = 1
        if issubclass(ctype, ctypes.Array):
            ctype, count = ctype._type_, ctype._length_
        if descriptor.offset < at:
            raise ValueError(f"{c_struct.__name__}.{name}: fields out of order")
        fmt += f"{descriptor.offset - at}x" if descriptor.offset > at else ""
        fmt += f"{count}{_FORMAT_CODES[ctype]}"
        at = descriptor.offset + descriptor.size
    return Struct(fmt)


_INPUT = field_packer(InputStruct, ("robot", "ref", "v_r", "w_r", "t_us", "n_obstacles"))
"""The scalars of one step's input, after which its obstacle pointer follows."""
_WHEELS_AT: int = InputStruct.wheel_speed.offset
"""Where the measured wheel speeds of one step's input start, after the
obstacle pointer: a packer of its own, since pack_into writes the padding it
skips."""
_WHEELS = Struct(
    f"=2d{InputStruct.wheel_measured.offset - _WHEELS_AT - 16}xI"
)

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


def library_layout(dll: ctypes.CDLL) -> Layout:
    """The layout the library exports (``mstc_sil_layout``)."""
    fn = dll["mstc_sil_layout"]
    fn.argtypes = [ctypes.POINTER(ctypes.c_size_t)]
    fn.restype = ctypes.POINTER(_LayoutEntry)
    n = ctypes.c_size_t()
    entries = fn(ctypes.byref(n))
    layout: Layout = {}
    for e in entries[: n.value]:
        struct = (e.type or b"").decode()
        field = e.field.decode() if e.field is not None else None
        layout.setdefault(struct, {})[field] = (int(e.offset), int(e.size))
    return layout


def struct_layout(struct: type[ctypes.Structure]) -> dict[str | None, tuple[int, int]]:
    """The same for a ctypes struct: its fields' offsets and sizes, and its size."""
    fields: dict[str | None, tuple[int, int]] = {None: (0, ctypes.sizeof(struct))}
    for name, *_ in struct._fields_:
        descriptor = getattr(struct, name)
        fields[name] = (descriptor.offset, descriptor.size)
    return fields


def check_layout(
    layout: Layout, where: str, structs: Sequence[type[AbiStruct]] = ABI_STRUCTS
) -> None:
    """Check @p structs against the @p layout of the library at @p where.

    :raises FirmwareError: a struct, or a field of one, that the two sides lay
        out differently (or only one side has), named.
    """
    problems = []
    for struct in structs:
        theirs = layout.get(struct.c_name)
        if theirs is None:
            problems.append(f"{struct.c_name}: not in the library's layout table")
            continue
        ours = struct_layout(struct)
        for field in [*ours, *(f for f in theirs if f not in ours)]:
            name = struct.c_name if field is None else f"{struct.c_name}.{field}"
            if field not in theirs:
                problems.append(f"{name}: in the Python binding only")
            elif field not in ours:
                problems.append(f"{name}: in the library only")
            elif ours[field] != theirs[field]:
                (o_off, o_size), (t_off, t_size) = ours[field], theirs[field]
                problems.append(
                    f"{name}: {t_size} bytes in the library, {o_size} in the Python binding"
                    if field is None
                    else f"{name}: offset {t_off}, size {t_size} in the library; "
                    f"offset {o_off}, size {o_size} in the Python binding"
                )
    if problems:
        raise FirmwareError(
            f"{where} does not match the Python bindings (mstc.firmware against "
            "hal/sil/mstc_sil.h): " + "; ".join(problems)
        )


def library_path(path: str | os.PathLike[str] | None = None) -> Path:
    """@p path, else the library named by ``$MSTC_SIL_LIB``.

    :raises FirmwareError: neither names one.
    """
    if path is None or str(path) == "":
        path = os.environ.get(LIB_ENV)
        if not path:
            raise FirmwareError(
                f"no firmware library: pass its path (--lib) or set {LIB_ENV} "
                "(build it with `make lib`)"
            )
    return Path(path)


def _declare(dll: ctypes.CDLL) -> None:
    """Declare the signatures of the library's functions."""
    c_int, c_void_p, pointer = ctypes.c_int, ctypes.c_void_p, ctypes.POINTER
    signatures: list[tuple[str, list[type], type | None]] = [
        ("mstc_sil_size", [], ctypes.c_size_t),
        ("mstc_sil_numeric", [], ctypes.c_char_p),
        ("mstc_sil_defaults", [pointer(ParamsStruct)], None),
        ("mstc_sil_init", [c_void_p, pointer(ParamsStruct)], c_int),
        ("mstc_sil_step", [c_void_p, pointer(InputStruct), pointer(OutputStruct)], c_int),
        ("mstc_sil_fw_init", [pointer(ParamsStruct)], c_int),
        ("mstc_sil_fw_set_key", [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_uint32], c_int),
        ("mstc_sil_fw_send", [pointer(FrameStruct)], c_int),
        ("mstc_sil_fw_recv", [pointer(FrameStruct)], c_int),
    ]
    for name, argtypes, restype in signatures:
        fn = getattr(dll, name)
        fn.argtypes = argtypes
        fn.restype = restype


class Library:
    """``libmstc_sil.so``, loaded, its functions declared and its structs checked.

    Open it with :meth:`open`: one object per file and process, as the
    dynamic loader keeps one copy of the library, and so one firmware
    instance of the frame path, per process.

    :param path: the library.
    :raises FirmwareError: it cannot be loaded, is not the mstc SIL library, or
        its structs differ from the bindings'.
    """

    _opened: ClassVar[dict[Path, Library]] = {}

    def __init__(self, path: Path) -> None:
        self.path = path
        if not path.is_file():
            raise FirmwareError(
                f"cannot load firmware library {path}: no such file (make lib builds it)"
            )
        try:
            self.dll = ctypes.CDLL(str(path.resolve()))
        except OSError as exc:
            raise FirmwareError(f"cannot load firmware library {path}: {exc}") from exc
        try:
            _declare(self.dll)
            layout = library_layout(self.dll)
        except AttributeError as exc:
            raise FirmwareError(
                f"{path} is not the mstc SIL library of this version: {exc}"
            ) from exc
        check_layout(layout, str(path), ABI_STRUCTS)
        self.numeric: str = self.dll.mstc_sil_numeric().decode("ascii")
        """The firmware's numeric mode, "float" or "fixed"."""

    @classmethod
    def open(cls, path: str | os.PathLike[str] | None = None) -> Library:
        """The library at @p path (default: ``$MSTC_SIL_LIB``), loaded once per process.

        :raises FirmwareError: see :class:`Library`.
        """
        given = library_path(path)
        key = given.resolve()
        lib = cls._opened.get(key)
        if lib is None:
            lib = cls(given)
            cls._opened[key] = lib
        return lib

    def address_function(self, name: str) -> Callable[[int], int]:
        """@p name as a function taking one address (``void *``): for callers
        that pass pointers into their own buffers (the replay's frame arrays)."""
        fn = self.dll[name]
        fn.argtypes = [ctypes.c_void_p]
        fn.restype = ctypes.c_int
        return fn


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
    """The firmware's control step in this process (a :class:`~mstc.controller.Controller`).

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
        """One control step (see :meth:`mstc.controller.Controller.step`).

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
        records (:data:`mstc.sim.run.StepValues`): building the Status and
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
        if wheel_speeds is None:
            if self._measured:
                _WHEELS.pack_into(self._in, _WHEELS_AT, 0.0, 0.0, 0)
                self._measured = False
        else:
            _WHEELS.pack_into(self._in, _WHEELS_AT, wheel_speeds[0], wheel_speeds[1], 1)
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
