# SPDX-License-Identifier: MIT
"""`make test-python PYTEST_ARGS=...` runs what PYTEST_ARGS names (issue 35:
with a test file named, the whole suite ran, VM tests included). Checked on
the command make would run (`make -n`), without running it."""

from __future__ import annotations

import shlex
import subprocess

import pytest

from conftest import ROOT


def pytest_command(pytest_args: str) -> list[str]:
    """The arguments of the pytest command `make test-python` would run."""
    done = subprocess.run(
        ["make", "-n", "-s", "test-python", f"PYTEST_ARGS={pytest_args}"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    lines = [line for line in done.stdout.splitlines() if " -m pytest " in line]
    assert len(lines) == 1, done.stdout
    words = shlex.split(lines[0])
    return words[words.index("pytest") + 1 :]


@pytest.mark.parametrize(
    ("pytest_args", "paths"),
    [
        ("tests/python/test_scenario.py", ["tests/python/test_scenario.py"]),
        ("tests/python/test_cli.py::test_help -x", ["tests/python/test_cli.py::test_help"]),
        ("-k hil", ["tests/python"]),
        ("", ["tests/python"]),
    ],
)
def test_named_tests_alone_else_the_whole_suite(pytest_args: str, paths: list[str]) -> None:
    args = pytest_command(pytest_args)
    assert [a for a in args if a.startswith("tests/")] == paths, args
