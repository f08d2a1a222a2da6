# SPDX-License-Identifier: MIT
"""The firmware library's bindings, in one place.

``libmstc_sil.so`` (``make lib``; the ABI is ``hal/sil/mstc_sil.h``) is reached
through ctypes by three users: the in-memory controller
(:class:`mstc.firmware.sil.SilController`), the python-can interface
``mstc-sil`` (:mod:`mstc.can.silbus`) and the replay (:mod:`mstc.logs.replay`).
All of them open it with :meth:`Library.open`, which declares the signatures
and checks every structure below against the layout the library exports
(``mstc_sil_layout()``: each struct's size, each field's offset and size), so
a field added or changed on one side only is a :class:`FirmwareError` naming
the struct and the field, never garbage read at the wrong offset. Adding a
field means adding it to the C struct (and its row of the layout table in
mstc_sil.c) and to the struct here.

The batched step takes and fills numpy structured arrays: their dtypes
(:data:`BATCH_INPUT_DTYPE`, :data:`OUTPUT_DTYPE`) are made from the same
ctypes structs (:func:`numpy_dtype`) and checked against the library's layout
at load time too.

The library converts to and from the firmware's numeric type at this
boundary: everything here is double or an integer.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from struct import Struct
from typing import Any, ClassVar

import numpy as np

from mstc.errors import FirmwareError

LIB_ENV = "MSTC_SIL_LIB"
"""Environment variable naming the library when no path is given."""

MAX_OBSTACLES = 48
"""MSTC_SIL_MAX_OBSTACLES (checked through the size of ``mstc_sil_output_t.obstacle_id``)."""
MAX_EVENTS = 50
"""MSTC_SIL_MAX_EVENTS (checked through the size of ``mstc_sil_output_t.events``)."""
FRAME_DATA = 8
"""Data bytes of ``mstc_sil_frame_t``."""


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
        ("wheel_age_us", ctypes.c_uint32),
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


class BatchInputStruct(AbiStruct):
    """``mstc_sil_batch_input_t``: one scene of a batched step, its obstacle
    table inline and the reported entries as a mask (a byte each)."""

    c_name = "mstc_sil_batch_input_t"
    _fields_ = [
        ("in", InputStruct),
        ("reported", ctypes.c_uint8 * MAX_OBSTACLES),
        ("table", ObstacleStruct * MAX_OBSTACLES),
    ]


ABI_STRUCTS: tuple[type[AbiStruct], ...] = (
    ParamsStruct,
    ObstacleStruct,
    InputStruct,
    EventStruct,
    OutputStruct,
    FrameStruct,
    BatchInputStruct,
)
"""Every struct of the ABI, checked at load time."""


def numpy_dtype(ctype: Any) -> np.dtype[Any]:
    """The numpy dtype laid out as the ctypes type @p ctype: a struct's fields
    at their ctypes offsets (nested structs and arrays alike), a pointer as an
    address (``uintp``), the struct's size as the item size."""
    if isinstance(ctype, type) and issubclass(ctype, ctypes.Structure):
        names = [f[0] for f in ctype._fields_]
        return np.dtype(
            {
                "names": names,
                "formats": [numpy_dtype(f[1]) for f in ctype._fields_],
                "offsets": [getattr(ctype, n).offset for n in names],
                "itemsize": ctypes.sizeof(ctype),
            }
        )
    if isinstance(ctype, type) and issubclass(ctype, ctypes.Array):
        return np.dtype((numpy_dtype(ctype._type_), (ctype._length_,)))
    if isinstance(ctype, type) and issubclass(ctype, ctypes._Pointer):
        return np.dtype(np.uintp)
    scalar: np.dtype[Any] = np.dtype(ctype)
    return scalar


BATCH_INPUT_DTYPE = numpy_dtype(BatchInputStruct)
"""``mstc_sil_batch_input_t`` as a numpy structured dtype."""
OUTPUT_DTYPE = numpy_dtype(OutputStruct)
"""``mstc_sil_output_t`` as a numpy structured dtype."""
NUMPY_DTYPES: dict[str, np.dtype[Any]] = {
    BatchInputStruct.c_name: BATCH_INPUT_DTYPE,
    OutputStruct.c_name: OUTPUT_DTYPE,
}
"""The dtypes of the batched step by their struct's name, checked at load time."""


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


def library_layout(dll: ctypes.CDLL, function: str = "mstc_sil_layout") -> Layout:
    """The layout the library exports (``mstc_sil_layout``, or @p function,
    a table of the same kind: ``mstc_sil_wheels_layout``)."""
    fn = dll[function]
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


def dtype_layout(dtype: np.dtype[Any]) -> dict[str | None, tuple[int, int]]:
    """The same for a numpy structured dtype (:func:`struct_layout`)."""
    fields: dict[str | None, tuple[int, int]] = {None: (0, dtype.itemsize)}
    for name in dtype.names or ():
        sub, offset = dtype.fields[name][:2]  # type: ignore[index]
        fields[name] = (offset, sub.itemsize)
    return fields


def check_layout(
    layout: Layout,
    where: str,
    structs: Sequence[type[AbiStruct]] = ABI_STRUCTS,
    dtypes: Mapping[str, np.dtype[Any]] | None = None,
) -> None:
    """Check @p structs and the numpy @p dtypes (by struct name) against the
    @p layout of the library at @p where.

    :raises FirmwareError: a struct, or a field of one, that the two sides lay
        out differently (or only one side has), named.
    """
    problems = []
    ours_by_name = [(s.c_name, struct_layout(s), "Python binding") for s in structs]
    ours_by_name += [(n, dtype_layout(d), "numpy dtype") for n, d in (dtypes or {}).items()]
    for c_name, ours, side in ours_by_name:
        theirs = layout.get(c_name)
        if theirs is None:
            problems.append(f"{c_name}: not in the library's layout table")
            continue
        for field in [*ours, *(f for f in theirs if f not in ours)]:
            name = c_name if field is None else f"{c_name}.{field}"
            if field not in theirs:
                problems.append(f"{name}: in the {side} only")
            elif field not in ours:
                problems.append(f"{name}: in the library only")
            elif ours[field] != theirs[field]:
                (o_off, o_size), (t_off, t_size) = ours[field], theirs[field]
                problems.append(
                    f"{name}: {t_size} bytes in the library, {o_size} in the {side}"
                    if field is None
                    else f"{name}: offset {t_off}, size {t_size} in the library; "
                    f"offset {o_off}, size {o_size} in the {side}"
                )
    if problems:
        raise FirmwareError(
            f"{where} does not match the Python bindings (mstc.can.library against "
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
        ("mstc_sil_batch_stride", [], ctypes.c_size_t),
        (
            "mstc_sil_step_batch",
            [c_void_p, ctypes.c_size_t, c_void_p, c_void_p, c_void_p],
            c_int,
        ),
        ("mstc_sil_fw_init", [pointer(ParamsStruct)], c_int),
        ("mstc_sil_fw_set_key", [ctypes.c_char_p, ctypes.c_size_t], c_int),
        ("mstc_sil_fw_set_node", [ctypes.c_uint8], c_int),
        ("mstc_sil_fw_set_session", [ctypes.c_uint32], c_int),
        ("mstc_sil_fw_send", [pointer(FrameStruct)], c_int),
        ("mstc_sil_fw_recv", [pointer(FrameStruct)], c_int),
        ("mstc_sil_fw_wheels", [ctypes.c_void_p], c_int),
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
        check_layout(layout, str(path), ABI_STRUCTS, NUMPY_DTYPES)
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
