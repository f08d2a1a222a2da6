# SPDX-License-Identifier: MIT
"""``pip install .`` into a clean virtual environment gives a working ``mstc``.

The wheel is built from a copy of what it is made of (pyproject.toml,
sim/mstc with its symbolic link to the DBC, and the DBC), so the test leaves
no build files in the repository; it is installed with ``--no-deps`` into a
virtual environment made without the project's packages, and the pinned
dependencies are the ones of the running environment (.venv), reached
through a .pth file (no registry needed). Nothing from the source tree is on
the installed command's path: it runs in a temporary folder, without
$MSTC_SIL_LIB.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from conftest import ROOT

DBC = ROOT / "firmware" / "comm" / "mstc.dbc"
LIMITS = ROOT / "firmware" / "ctrl" / "ctl_params.toml"


def run(cmd: list[str | Path], cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=300
    )


def checked(done: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    if done.returncode != 0:
        pytest.fail(
            f"{' '.join(done.args)} failed ({done.returncode}):\n{done.stdout}{done.stderr}"
        )
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """The virtual environment with mstc installed from a wheel, and the
    environment variables to run it with."""
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

    env = {k: v for k, v in os.environ.items() if k not in ("MSTC_SIL_LIB", "PYTHONPATH")}
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
    wheels = top / "wheels"
    checked(run([*pip, "wheel", "--no-deps", "--no-build-isolation", "-w", wheels, src], top, env))
    [wheel] = wheels.glob("mstc-*.whl")

    target = top / "venv"
    venv.create(target, with_pip=False)
    python = target / "bin" / "python"
    checked(run([*pip, "--python", python, "install", "--no-deps", "--no-index", wheel], top, env))
    # The pinned dependencies: those of the environment running the tests.
    site = run(
        [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], top, env
    )
    (Path(site.stdout.strip()) / "mstc-test-deps.pth").write_text(
        sysconfig.get_paths()["purelib"] + "\n"
    )
    return target, env


def test_mstc_runs_from_the_installed_package(installed: tuple[Path, dict[str, str]]) -> None:
    target, env = installed
    bin_ = target / "bin"
    version = checked(run([bin_ / "mstc", "--version"], target, env))
    assert version.stdout.strip() == "mstc 0.1.0"
    helped = checked(run([bin_ / "mstc", "--help"], target, env)).stdout
    for command in ("sim", "hil", "replay", "play", "plot", "export"):
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


def test_the_installed_mstc_decodes_a_committed_log(
    installed: tuple[Path, dict[str, str]], tmp_path: Path
) -> None:
    target, env = installed
    log = ROOT / "tests" / "data" / "paper-line.log"
    done = checked(run([target / "bin" / "mstc", "plot", "--out", tmp_path, log], tmp_path, env))
    assert "activate  O1" in done.stdout
    assert (tmp_path / "paper-line" / "overview.png").is_file()
    mcap = tmp_path / "run.mcap"
    checked(run([target / "bin" / "mstc", "export", log, "--mcap", mcap, "-q"], tmp_path, env))
    assert mcap.stat().st_size > 0


def test_the_installed_mstc_needs_a_library_named(
    installed: tuple[Path, dict[str, str]], tmp_path: Path, float_lib: Path
) -> None:
    target, env = installed
    scenario = ROOT / "sim" / "scenarios" / "paper-line.toml"
    done = run([target / "bin" / "mstc", "sim", "--out", tmp_path / "out", scenario], tmp_path, env)
    assert done.returncode == 1
    assert "installed outside its source tree" in done.stderr
    assert "--lib" in done.stderr and "MSTC_SIL_LIB" in done.stderr
    # Named, the library works; the replay reaches it through the installed
    # package, and python-can finds the installed "mstc-sil" interface.
    lib = float_lib.resolve()
    log = ROOT / "tests" / "data" / "paper-line.log"
    with_lib = {**env, "MSTC_SIL_LIB": str(lib)}
    replayed = checked(run([target / "bin" / "mstc", "replay", "-q", log], tmp_path, with_lib))
    assert "bit-exact" in replayed.stdout
    probe = "import can; print(can.Bus(interface='mstc-sil').channel_info)"
    bus = checked(run([target / "bin" / "python", "-c", probe], tmp_path, with_lib))
    assert str(lib) in bus.stdout
