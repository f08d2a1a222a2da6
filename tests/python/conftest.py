# SPDX-License-Identifier: MIT
"""Shared fixtures: the firmware library, and scenario files written from dicts."""

import importlib
import math
import os
import shutil
import subprocess
from collections.abc import Callable, Mapping
from pathlib import Path

import pytest

from mstc.can.protocol import wire_limits
from mstc.errors import MstcError
from mstc.plant.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[2]
"""The repository."""
SCENARIOS = ROOT / "sim" / "scenarios"
TEST_KEY_FILE = ROOT / "tests" / "data" / "test.key"
"""The published test key (RFC 4493's example key): never a device's."""

# Every test runs with the test key, whatever the machine's device key: the
# firmware library and the tools then agree, mstc-fw and the VM inherit it,
# and the committed logs (recorded with it) replay.
os.environ.pop("MSTC_KEY", None)
os.environ["MSTC_KEY_FILE"] = str(TEST_KEY_FILE)

# Fixtures of the bus-log tests (tests/python/logfiles.py).
pytest_plugins = ["logfiles"]


def firmware_cflags() -> list[str]:
    """The host build's compile flags for firmware sources, from the Makefile
    (`make print-cflags`, float mode: the shims link no libfixmath), so that
    the shims compile exactly as the firmware does; fail the test, loudly,
    when make cannot say them."""
    make = shutil.which("make")
    if make is None:
        pytest.fail("make not found: the shims take their flags from the Makefile (Debian: make)")
    # A clean environment for the inner make: without the outer make's
    # MAKEFLAGS (jobserver) and MAKELEVEL, it prints only the flags.
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    cmd = [make, "-s", "--no-print-directory", "NUMERIC=float", "print-cflags"]
    done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    if done.returncode != 0 or not done.stdout.strip():
        pytest.fail(f"`{' '.join(cmd)}` failed:\n{done.stdout}{done.stderr}")
    # Plain words: the host flags hold no quoting.
    return done.stdout.split()


AUTH_SOURCES = [
    "firmware/auth/auth.c",
    "deps/mbedtls/library/aes.c",
    "deps/mbedtls/library/platform_util.c",
]
"""What comm.c's status frame needs (its MAC: auth.c over Mbed TLS's AES,
mk/auth.mk's AUTH_SRCS), for the shims that compile comm.c."""


def build_shim(sources: list[str], out: Path, what: str) -> Path:
    """Compile @p sources (paths from the repository) with the firmware's flags
    into the shared library @p out; fail the test, loudly, when it cannot."""
    cc = os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        pytest.fail(f"C compiler {cc!r} not found: the {what} tests need one (Debian: gcc)")
    cmd = [cc, *firmware_cflags(), "-shared", *sources]
    done = subprocess.run([*cmd, "-lm", "-o", str(out)], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        pytest.fail(f"building the {what} shim failed:\n{' '.join(cmd)}\n{done.stderr}")
    return out


@pytest.fixture(scope="session")
def sil_lib() -> Path:
    """The firmware built as a shared library. Never skipped: without it the
    end-to-end tests fail, loudly."""
    value = os.environ.get("MSTC_SIL_LIB")
    if not value:
        pytest.fail(
            "MSTC_SIL_LIB is not set: the end-to-end tests need the firmware library. "
            "Run `make test-python`, or `make lib` and set "
            "MSTC_SIL_LIB=build/host/float/libmstc_sil.so",
            pytrace=False,
        )
    path = Path(value)
    if not path.is_file():
        pytest.fail(f"MSTC_SIL_LIB={value} does not exist: run `make lib`", pytrace=False)
    return path


@pytest.fixture(scope="session")
def mstc_fw() -> Path:
    """mstc-fw, the firmware on SocketCAN (MSTC_FW, which `make test-python`
    sets); never skipped."""
    value = os.environ.get("MSTC_FW")
    if not value or not Path(value).is_file():
        pytest.fail(
            f"MSTC_FW={value!r}: run `make test-python` (it builds build/host/mstc-fw)",
            pytrace=False,
        )
    return Path(value)


@pytest.fixture(scope="session")
def libs() -> dict[str, Path]:
    """Both numeric modes' firmware libraries, by mode ("float", "fixed"), from
    MSTC_SIL_LIB_FLOAT and MSTC_SIL_LIB_FIXED; never skipped."""
    found = {}
    for mode in ("float", "fixed"):
        var = f"MSTC_SIL_LIB_{mode.upper()}"
        value = os.environ.get(var)
        if not value or not Path(value).is_file():
            pytest.fail(
                f"{var}={value!r}: `make test` builds both libraries and sets it", pytrace=False
            )
        found[mode] = Path(value)
    return found


def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {value!r} as an inline TOML value")


def to_toml(doc: Mapping[str, object]) -> str:
    """A small TOML writer for test documents: top-level scalars, tables of
    scalars and arrays of such tables (a list of dicts becomes [[name]])."""
    lines = [f"{k} = {_toml_value(v)}" for k, v in doc.items() if not _is_table(v)]
    for key, value in doc.items():
        if isinstance(value, dict):
            lines.append(f"\n[{key}]")
            lines += [f"{k} = {_toml_value(v)}" for k, v in value.items()]
        elif _is_table(value):
            for entry in value:  # type: ignore[union-attr]
                lines.append(f"\n[[{key}]]")
                lines += [f"{k} = {_toml_value(v)}" for k, v in entry.items()]
    return "\n".join(lines) + "\n"


def _is_table(value: object) -> bool:
    return isinstance(value, dict) or (
        isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)
    )


def scenario_or_refusal(path: Path, key: str) -> Scenario | None:
    """The scenario in @p path, or None when the loader refuses it, as it
    must then: with one line that names @p key."""
    try:
        return load_scenario(path, wire_limits())
    except MstcError as exc:
        message = str(exc)
        assert "\n" not in message and key in message, message
        return None


@pytest.fixture
def write_scenario(tmp_path: Path) -> Callable[[Mapping[str, object], str], Path]:
    """Write a document as tmp_path/<name>.toml and return the path."""

    def write(doc: Mapping[str, object], name: str = "scenario") -> Path:
        path = tmp_path / f"{name}.toml"
        path.write_text(to_toml(doc))
        return path

    return write


def pytest_configure(config: pytest.Config) -> None:
    """The ``vm`` marker: tests that boot the vcan VM (tools/vm/with-vcan).
    ``make test`` runs them on their own, after the rest, so that nothing
    else competes with the emulated VM's timing (``-m vm``, ``-m "not vm"``)."""
    config.addinivalue_line("markers", "vm: boots the vcan VM (tools/vm/with-vcan)")


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """Print what tests collected for the reader (float vs fixed comparison,
    the parameter sweep's figures, the strategy on the suite)."""
    for module, title in (
        ("test_numeric_modes", "float vs fixed"),
        ("test_param_sweep", "sweep"),
        ("test_strategy", "strategy mstc on the suite"),
    ):
        try:
            report = importlib.import_module(module).REPORT
        except ImportError:
            continue
        if report:
            terminalreporter.section(title)
            for line in report:
                terminalreporter.write_line(line)
