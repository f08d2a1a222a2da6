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

from mstc.errors import FirmwareError
from mstc.firmware import (
    ABI_STRUCTS,
    AbiStruct,
    FrameStruct,
    Library,
    ObstacleStruct,
    check_layout,
    library_layout,
)


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
    # uint32 id at 0, 4 bytes of padding, three doubles; uint32, uint8,
    # uint8[8] padded to a multiple of 4.
    layout = library_layout(Library.open(any_lib).dll)
    assert layout["mstc_sil_obstacle_t"] == {
        None: (0, 32),
        "id": (0, 4),
        "x": (8, 8),
        "y": (16, 8),
        "radius": (24, 8),
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


class ObstacleWithVelocity(AbiStruct):
    c_name = "mstc_sil_obstacle_t"
    _fields_ = [*ObstacleStruct._fields_, ("vx", ctypes.c_double), ("vy", ctypes.c_double)]


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
        (ObstacleWithVelocity, r"mstc_sil_obstacle_t: 32 bytes in the library, 48 in the Python"),
        (ObstacleWithVelocity, r"mstc_sil_obstacle_t\.vx: in the Python binding only"),
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
    import mstc.firmware as firmware

    copy = tmp_path / "libmstc_sil.so"  # not opened before in this process
    shutil.copyfile(sil_lib, copy)
    more = tuple(ObstacleWithVelocity if s is ObstacleStruct else s for s in ABI_STRUCTS)
    monkeypatch.setattr(firmware, "ABI_STRUCTS", more)
    with pytest.raises(FirmwareError, match=r"mstc_sil_obstacle_t\.vx: in the Python binding only"):
        Library.open(copy)


def test_a_library_without_the_layout_export_is_refused(tmp_path: Path) -> None:
    other = Path(_ctypes.__file__)  # a shared object, not the firmware's
    with pytest.raises(FirmwareError, match="is not the mstc SIL library of this version"):
        Library(other)


def test_a_missing_library_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FirmwareError, match="no such file.*make lib"):
        Library.open(tmp_path / "absent.so")
