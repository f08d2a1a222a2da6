# SPDX-License-Identifier: MIT
"""The wheel installs alone: ``pip install mstc-*.whl`` into a fresh virtual
environment, with nothing but the dependencies pyproject.toml declares, gives
a working ``mstc``.

The wheel is built from a copy of what it is made of (pyproject.toml,
sim/mstc with its symbolic links to the DBC and the limits table, and those
two files), so the test leaves no build files in the repository. It is
installed into a virtual environment made here, with its own pip, which takes
the declared dependencies from the package registry (or pip's cache), at the
versions requirements.txt pins (a constraints file: it installs nothing that
is not asked for). The development environment (.venv) is not reachable from
it: a dependency the package imports but does not declare fails here.
Nothing from the source tree is on the installed command's path: it runs in a
temporary folder, without $MSTC_SIL_LIB; the firmware library and the test
key are named on its command line.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from conftest import ROOT, SCENARIOS, TEST_KEY_FILE

DBC = ROOT / "firmware" / "comm" / "mstc.dbc"
LIMITS = ROOT / "firmware" / "ctrl" / "ctl_params.toml"
LOG = ROOT / "tests" / "data" / "paper-line.log"
DEV_PURELIB = Path(sysconfig.get_paths()["purelib"])
"""Where the development environment's packages are."""


def run(
    cmd: list[str | Path], cwd: Path, env: dict[str, str], timeout: float = 600
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
    )


def checked(done: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    if done.returncode != 0:
        pytest.fail(
            f"{' '.join(done.args)} failed ({done.returncode}):\n{done.stdout}{done.stderr}"
        )
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """The fresh virtual environment with the wheel and its declared
    dependencies, and the environment variables to run it with."""
    top = tmp_path_factory.mktemp("install")
    src = top / "src"
    shutil.copytree(
        ROOT / "sim" / "mstc",
        src / "sim" / "mstc",
        symlinks=True,
        ignore=shutil.ignore_patterns("__pycache__"),
    )
    # The two files the package ships from the firmware's tree: links in the
    # source tree, copied into the wheel.
    assert (src / "sim" / "mstc" / "can" / "mstc.dbc").is_symlink()
    assert (src / "sim" / "mstc" / "ctl_params.toml").is_symlink()
    (src / "firmware" / "comm").mkdir(parents=True)
    shutil.copyfile(DBC, src / "firmware" / "comm" / "mstc.dbc")
    (src / "firmware" / "ctrl").mkdir(parents=True)
    shutil.copyfile(LIMITS, src / "firmware" / "ctrl" / "ctl_params.toml")
    shutil.copyfile(ROOT / "pyproject.toml", src / "pyproject.toml")

    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("MSTC_SIL_LIB", "MSTC_KEY", "MSTC_KEY_FILE", "PYTHONPATH", "VIRTUAL_ENV")
    }
    # Building the wheel takes the build backend of the running environment.
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
    wheels = top / "wheels"
    checked(run([*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", wheels, src], top, env))
    [wheel] = wheels.glob("mstc-*.whl")

    target = top / "venv"
    venv.create(target, with_pip=True)
    python = target / "bin" / "python"
    install = [python, "-m", "pip", "--disable-pip-version-check", "install"]
    checked(run([*install, "--constraint", ROOT / "requirements.txt", wheel], top, env, 1200))
    return target, env


def test_the_environment_holds_the_declared_dependencies_alone(
    installed: tuple[Path, dict[str, str]],
) -> None:
    target, env = installed
    python = target / "bin" / "python"
    probe = (
        "import json, sys, importlib.util as u; "
        "print(json.dumps([sys.path, [m for m in ('mstc', 'cryptography', 'serial', "
        "'distributed', 'pytest', 'mypy') if u.find_spec(m)]]))"
    )
    path, found = json.loads(checked(run([python, "-c", probe], target, env)).stdout)
    assert not any(Path(p).is_relative_to(DEV_PURELIB) for p in path if p), path
    # Declared: the package, cryptography (SecOC), pyserial (python-can's
    # slcan); not: Dask (the extra mstc[cluster]) and the development tools.
    assert found == ["mstc", "cryptography", "serial"]


def test_mstc_runs_from_the_installed_package(installed: tuple[Path, dict[str, str]]) -> None:
    target, env = installed
    bin_ = target / "bin"
    version = checked(run([bin_ / "mstc", "--version"], target, env))
    assert version.stdout.strip() == "mstc 0.1.0"
    helped = checked(run([bin_ / "mstc", "--help"], target, env)).stdout
    for command in ("sim", "hil", "replay", "play", "plot", "sweep", "export"):
        assert command in helped
    where = checked(
        run(
            [
                bin_ / "python",
                "-c",
                "import mstc.can.dbc as d; print(d.__file__); print(d.DBC_PATH)",
            ],
            target,
            env,
        )
    ).stdout.split()
    assert all(Path(p).is_relative_to(target) for p in where), where
    shipped = Path(where[1])
    assert not shipped.is_symlink() and shipped.read_bytes() == DBC.read_bytes()


SESSION_FRAMES = {"122", "186", "187"}
"""PARAM_AUTH, AUTH_STATUS, AUTH_CHALLENGE: their bytes depend on the session."""


def _same_but_the_session(written: str, committed: str) -> None:
    """@p written is @p committed, line by line, but for the data of the frames
    whose bytes depend on the firmware's session."""
    got, want = written.splitlines(), committed.splitlines()
    assert len(got) == len(want)
    for a, b in zip(got, want, strict=True):
        head_a, _, data_a = a.partition("#")
        head_b, _, data_b = b.partition("#")
        assert head_a == head_b, (a, b)
        if head_a.rsplit(" ", 1)[-1] not in SESSION_FRAMES:
            assert data_a == data_b, (a, b)


def test_the_installed_mstc_simulates_a_paper_scenario_and_exports_it(
    installed: tuple[Path, dict[str, str]], tmp_path: Path, float_lib: Path
) -> None:
    # The paper's line scenario through CAN in process, with a built library:
    # the committed regression log (recorded with the test key by the source
    # tree's mstc, make replay-logs) is what it must write, byte for byte but
    # for the frames that carry the firmware's session, which every start
    # draws anew (docs/safety.md, "Sessions"): PARAM_AUTH's MAC, AUTH_STATUS,
    # AUTH_CHALLENGE, at the same places.
    target, env = installed
    mstc = target / "bin" / "mstc"
    out = tmp_path / "out"
    lib = float_lib.resolve()
    scenario = SCENARIOS / "paper-line.toml"
    cmd = [mstc, "sim", "--lib", lib, "--key-file", TEST_KEY_FILE, "--out", out, scenario]
    done = checked(run(cmd, tmp_path, env))
    assert "activate  O1        right       6.82            6.82          0" in done.stdout
    _same_but_the_session((out / "paper-line" / "bus.log").read_text(), LOG.read_text())
    assert (out / "paper-line" / "overview.png").stat().st_size > 20_000
    mcap = tmp_path / "run.mcap"
    exported = checked(
        run([mstc, "export", out / "paper-line", "--mcap", mcap, "-q"], tmp_path, env)
    )
    assert f"-> {mcap}" in exported.stdout
    assert mcap.read_bytes().startswith(b"\x89MCAP")


def test_the_installed_mstc_decodes_a_committed_log(
    installed: tuple[Path, dict[str, str]], tmp_path: Path
) -> None:
    target, env = installed
    done = checked(run([target / "bin" / "mstc", "plot", "--out", tmp_path, LOG], tmp_path, env))
    assert "activate  O1" in done.stdout
    assert (tmp_path / "paper-line" / "overview.png").is_file()


def test_the_installed_mstc_needs_a_library_named(
    installed: tuple[Path, dict[str, str]], tmp_path: Path, float_lib: Path
) -> None:
    target, env = installed
    scenario = SCENARIOS / "paper-line.toml"
    key = ["--key-file", TEST_KEY_FILE]
    done = run(
        [target / "bin" / "mstc", "sim", *key, "--out", tmp_path / "out", scenario], tmp_path, env
    )
    assert done.returncode == 1
    assert "installed outside its source tree" in done.stderr
    assert "--lib" in done.stderr and "MSTC_SIL_LIB" in done.stderr
    # Named, the library works; the replay reaches it through the installed
    # package, and python-can finds the installed "mstc-sil" interface.
    lib = float_lib.resolve()
    with_lib = {**env, "MSTC_SIL_LIB": str(lib), "MSTC_KEY_FILE": str(TEST_KEY_FILE)}
    replayed = checked(run([target / "bin" / "mstc", "replay", "-q", LOG], tmp_path, with_lib))
    assert "bit-exact" in replayed.stdout
    probe = "import can; print(can.Bus(interface='mstc-sil').channel_info)"
    bus = checked(run([target / "bin" / "python", "-c", probe], tmp_path, with_lib))
    assert str(lib) in bus.stdout


def test_a_sweep_on_a_cluster_says_in_one_line_that_dask_is_missing(
    installed: tuple[Path, dict[str, str]], tmp_path: Path
) -> None:
    target, env = installed
    scenario = SCENARIOS / "paper-line.toml"
    cmd = [target / "bin" / "mstc", "sweep", "--scheduler", "tcp://127.0.0.1:9", scenario]
    done = run([*cmd, "--strategy", "dwa", "--out", tmp_path / "sweep"], tmp_path, env)
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        "error: a Dask cluster needs Dask's distributed, which is not installed: "
        "pip install 'mstc[cluster]' (docs/sweeps.md)"
    ]
    assert not (tmp_path / "sweep").exists()
