# SPDX-License-Identifier: MIT
"""The firmware bindings (mstc.firmware) check their ctypes structs against
the layout the library exports (mstc_sil_layout) when it is loaded: a struct
or field laid out differently, or present on one side only, is refused with
an error naming it."""

from __future__ import annotations

import _ctypes
import ctypes
import os
import shutil
from pathlib import Path

import pytest

from mstc.can.library import (
    ABI_STRUCTS,
    AbiStruct,
    FrameStruct,
    Library,
    ObstacleStruct,
    check_layout,
    library_layout,
)
from mstc.errors import FirmwareError


@pytest.fixture(params=["float", "fixed"])
def any_lib(request: pytest.FixtureRequest) -> Path:
    """Each numeric mode's library: both are checked, they share the ABI."""
    var = f"MSTC_SIL_LIB_{request.param.upper()}"
    value = os.environ.get(var)
    if not value or not Path(value).is_file():
        pytest.fail(f"{var}={value!r}: `make test-python` builds both libraries and sets it")
    return Path(value)


def test_both_builds_export_every_struct_of_the_bindings(any_lib: Path) -> None:
    lib = Library.open(any_lib)
    layout = library_layout(lib.dll)
    assert set(layout) == {s.c_name for s in ABI_STRUCTS}
    check_layout(layout, str(any_lib))  # the load did it too; it passes


def test_the_exported_layout_is_the_c_layout(any_lib: Path) -> None:
    # By hand, from hal/sil/mstc_sil.h and the x86-64 / AArch64 System V ABI:
    # uint32 id at 0, 4 bytes of padding, five doubles; uint32, uint8,
    # uint8[8] padded to a multiple of 4.
    layout = library_layout(Library.open(any_lib).dll)
    assert layout["mstc_sil_obstacle_t"] == {
        None: (0, 48),
        "id": (0, 4),
        "x": (8, 8),
        "y": (16, 8),
        "radius": (24, 8),
        "vx": (32, 8),
        "vy": (40, 8),
    }
    assert layout["mstc_sil_frame_t"] == {
        None: (0, 16),
        "id": (0, 4),
        "dlc": (4, 1),
        "data": (5, 8),
    }


class ObstacleFloatRadius(AbiStruct):
    c_name = "mstc_sil_obstacle_t"
    _fields_ = [
        ("id", ctypes.c_uint32),
        ("x", ctypes.c_double),
        ("y", ctypes.c_double),
        ("radius", ctypes.c_float),
    ]


class ObstacleWithAcceleration(AbiStruct):
    c_name = "mstc_sil_obstacle_t"
    _fields_ = [*ObstacleStruct._fields_, ("ax", ctypes.c_double), ("ay", ctypes.c_double)]


class ObstacleWithoutRadius(AbiStruct):
    c_name = "mstc_sil_obstacle_t"
    _fields_ = ObstacleStruct._fields_[:3]


class NotInTheLibrary(AbiStruct):
    c_name = "mstc_sil_wish_t"
    _fields_ = [("x", ctypes.c_double)]


@pytest.mark.parametrize(
    ("struct", "named"),
    [
        (ObstacleFloatRadius, r"mstc_sil_obstacle_t\.radius: offset 24, size 8 in the library; "),
        (
            ObstacleWithAcceleration,
            r"mstc_sil_obstacle_t: 48 bytes in the library, 64 in the Python",
        ),
        (ObstacleWithAcceleration, r"mstc_sil_obstacle_t\.ax: in the Python binding only"),
        (ObstacleWithoutRadius, r"mstc_sil_obstacle_t\.radius: in the library only"),
        (NotInTheLibrary, r"mstc_sil_wish_t: not in the library's layout table"),
    ],
)
def test_a_struct_that_differs_is_refused_by_name(
    sil_lib: Path, struct: type[AbiStruct], named: str
) -> None:
    layout = library_layout(Library.open(sil_lib).dll)
    with pytest.raises(FirmwareError, match=named):
        check_layout(layout, str(sil_lib), [FrameStruct, struct])


def test_a_library_that_changed_a_struct_is_refused_at_load(
    sil_lib: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The library, seen by bindings whose obstacle struct has two fields more:
    # what a branch adding a field on the Python side only would meet.
    import mstc.can.library as library

    copy = tmp_path / "libmstc_sil.so"  # not opened before in this process
    shutil.copyfile(sil_lib, copy)
    more = tuple(ObstacleWithAcceleration if s is ObstacleStruct else s for s in ABI_STRUCTS)
    monkeypatch.setattr(library, "ABI_STRUCTS", more)
    with pytest.raises(FirmwareError, match=r"mstc_sil_obstacle_t\.ax: in the Python binding only"):
        Library.open(copy)


def test_a_library_without_the_layout_export_is_refused(tmp_path: Path) -> None:
    other = Path(_ctypes.__file__)  # a shared object, not the firmware's
    with pytest.raises(FirmwareError, match="is not the mstc SIL library of this version"):
        Library(other)


def test_a_missing_library_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FirmwareError, match="no such file.*make lib"):
        Library.open(tmp_path / "absent.so")


def test_field_packer_reads_and_writes_what_ctypes_does() -> None:
    # The packer's offsets come from the ctypes descriptors: a value packed at
    # each field reads back through the ctypes attribute, and the reverse.
    from mstc.can.library import OutputStruct, field_packer

    names = ("wheel_left", "mode", "faults", "e", "n_events")
    packer = field_packer(OutputStruct, names)
    out = OutputStruct()
    packer.pack_into(out, 0, 1.5, -3, 7, -0.25, 4)
    assert (out.wheel_left, out.mode, out.faults, out.e, out.n_events) == (1.5, -3, 7, -0.25, 4)
    out.wheel_left, out.mode, out.faults, out.e, out.n_events = -2.0, 5, 9, 0.125, 2
    assert packer.unpack_from(out) == (-2.0, 5, 9, 0.125, 2)
    with pytest.raises(ValueError, match="out of order"):
        field_packer(OutputStruct, ("e", "wheel_left"))


def test_step_values_is_step_as_a_tuple(any_lib: Path) -> None:
    # Two controllers on the same inputs, one through step, one through
    # step_values (the in-memory loop's): the same values, step after step.
    from mstc.firmware.sil import SilController
    from mstc.model import Obstacle, Params, Pose

    a, b = SilController(Params(), any_lib), SilController(Params(), any_lib)
    obstacles = [Obstacle(1, 1.0, 0.05, 0.1), Obstacle(2, 2.5, -0.2, 0.15)]
    seen_events = 0
    for k in range(200):
        robot = Pose(0.01 * k, 0.001 * k, 0.002 * k - 7.0)  # heading unwrapped
        ref = Pose(0.012 * k, 0.0, 0.0)
        r = a.step(robot, ref, 0.6, 0.0, obstacles, k * 20_000)
        values = b.step_values(robot, ref, 0.6, 0.0, obstacles, k * 20_000)
        s = r.status
        assert values == (
            r.wheel_left,
            r.wheel_right,
            s.mode,
            int(s.faults),
            s.e1,
            s.e2,
            s.e3,
            s.e,
            r.events,
        )
        seen_events += len(r.events)
    assert seen_events > 0  # the comparison covered the events too
