# SPDX-License-Identifier: MIT
"""Both examples of the paper's section 5, end to end through the firmware.

The expected times and sides are the paper's (section 5; docs/equations.md),
written here rather than read from the scenario files, so that an edit of a
file cannot move the target.
"""

import re
from pathlib import Path

import pytest

from conftest import SCENARIOS
from mstc.can.protocol import wire_limits
from mstc.firmware.sil import SilController
from mstc.loop.lockstep import simulate
from mstc.loop.result import RunResult
from mstc.model import EventKind
from mstc.plant.scenario import Scenario, load_scenario

# (t [s], event, obstacle, side), paper section 5 (docs/equations.md).
PAPER = {
    "paper-line": [
        (0.82, "detect", 1, None),
        (3.10, "detect", 2, None),
        (6.82, "activate", 1, "right"),
        (8.76, "complete", 1, None),
        (9.36, "activate", 2, "left"),
        (11.10, "complete", 2, None),
    ],
    "paper-circle": [
        (0.00, "detect", 1, None),  # both obstacles are within D_det at t = 0
        (0.00, "detect", 2, None),
        (4.94, "activate", 1, "left"),
        (7.06, "complete", 1, None),
        (13.68, "activate", 2, "right"),
        (15.58, "complete", 2, None),
    ],
}
D_S = 0.35  # Table 1 [m]
NAMES = sorted(PAPER)


def run(scenario: Scenario, lib: Path) -> RunResult:
    return simulate(scenario, SilController(scenario.params, lib))


@pytest.fixture(scope="module", params=NAMES)
def euler_run(request: pytest.FixtureRequest, sil_lib: Path) -> tuple[str, RunResult]:
    """The scenario file as it is: Euler, dt = 0.02 s."""
    name = request.param
    return name, run(load_scenario(SCENARIOS / f"{name}.toml", wire_limits()), sil_lib)


@pytest.fixture(scope="module", params=NAMES)
def exact_run(
    request: pytest.FixtureRequest, sil_lib: Path, tmp_path_factory: pytest.TempPathFactory
) -> tuple[str, RunResult]:
    """The scenario with exact integration at 1 kHz, from a temporary file."""
    name = request.param
    text = (SCENARIOS / f"{name}.toml").read_text()
    text, n_dt = re.subn(r"(?m)^dt = .*$", "dt = 0.001", text)
    text, n_int = re.subn(r'(?m)^integrator = "euler"', 'integrator = "exact"', text)
    assert (n_dt, n_int) == (1, 1)
    path = tmp_path_factory.mktemp("exact") / f"{name}-exact.toml"
    path.write_text(text)
    return name, run(load_scenario(path, wire_limits()), sil_lib)


Row = tuple[int, str, int, str | None]


def by_time(rows: list[Row]) -> list[Row]:
    return sorted(rows, key=lambda r: r[:3])


def events(result: RunResult) -> list[Row]:
    """(t_us, event, obstacle, side) of each simulated event, in time order."""
    return by_time(
        [
            (e.t_us, str(e.kind), e.obstacle, None if e.side is None else str(e.side))
            for e in result.events
        ]
    )


@pytest.mark.parametrize("name", NAMES)
def test_scenario_files_hold_the_papers_setup_and_times(name: str) -> None:
    s = load_scenario(SCENARIOS / f"{name}.toml", wire_limits())
    assert (s.sim.dt, str(s.sim.integrator)) == (0.02, "euler")
    expected = [(e.t, str(e.event), e.obstacle, e.side and str(e.side)) for e in s.expected]
    assert expected == PAPER[name]


def test_euler_reproduces_every_event_of_the_paper_to_the_control_step(
    euler_run: tuple[str, RunResult],
) -> None:
    name, result = euler_run
    paper = by_time([(round(t * 1e6), kind, o, side) for t, kind, o, side in PAPER[name]])
    # Equal lists: same step, same side, and no event the paper does not report.
    assert events(result) == paper


def test_euler_keeps_the_safe_distance_to_every_obstacle(
    euler_run: tuple[str, RunResult],
) -> None:
    _, result = euler_run
    assert len(result.min_distance) == 2
    assert all(d >= D_S for d in result.min_distance)
    # docs/equations.md: about 0.362 m.
    assert result.min_distance == pytest.approx((0.362, 0.362), abs=0.002)
    assert result.faults == {}


def test_exact_integration_at_1_khz_is_within_30_ms_of_the_paper(
    exact_run: tuple[str, RunResult],
) -> None:
    name, result = exact_run
    # The same events (kind, obstacle, side), none missing and none extra.
    assert sorted(row[1:] for row in events(result)) == sorted(
        (kind, o, side) for _, kind, o, side in PAPER[name]
    )
    for t, kind, obstacle, _ in PAPER[name]:
        (match,) = [e for e in result.events if (str(e.kind), e.obstacle) == (kind, obstacle)]
        assert abs(match.t - t) <= 0.03, f"{kind} O{obstacle}: {match.t} s, paper {t} s"
    assert all(d >= D_S for d in result.min_distance)


def test_trace_agrees_with_the_events_and_distances(euler_run: tuple[str, RunResult]) -> None:
    _, result = euler_run
    trace = result.trace
    assert len(trace.mode) == round(result.scenario.sim.duration / 0.02) + 1
    assert trace["t"][0] == 0.0 and trace["t"][-1] == result.scenario.sim.duration
    assert tuple(trace.distance.min(axis=0)) == result.min_distance
    # Avoiding from each activation (inclusive) to its completion (exclusive).
    k = {(str(e.kind), e.obstacle): e.t_us // 20_000 for e in result.events}
    avoiding = trace.avoiding
    for o in (1, 2):
        start, end = k[("activate", o)], k[("complete", o)]
        assert avoiding[start:end].all()
        assert not avoiding[start - 1] and not avoiding[end]
    assert avoiding.sum() == sum(k[("complete", o)] - k[("activate", o)] for o in (1, 2))
    assert EventKind.DETECT in {e.kind for e in result.events}
