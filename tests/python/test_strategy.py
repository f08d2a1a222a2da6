# SPDX-License-Identifier: MIT
"""The "mstc" strategy end to end on seeded scenes of every family of the
standard suite (issue 12), in both numeric modes.

The first SCENES scenes of each family of sim/suites/standard.toml (the same
files `mstc sweep` writes) run in closed loop with the float and the Q16.16
firmware library. On every float run the acceptance of issue 12 is checked:
no contact, the centre distance never below D_s, back on the reference
(tracking error under 0.05 m within 10 s after an obstacle, judged as
sim/mstc/sweep/metrics.py says) in every run that is not blocked, no
obstacle activated more than twice. The float and fixed runs give the same
events, in the same order, on the same obstacles and sides. The full suite
(500 scenes a family) is the benchmark of docs/strategy-results.md; these are its
first scenes, so a change that breaks the strategy fails here.

Under real wheels (issue 19, the suite's actuator profile "sluggish": lag
0.1 s, 10 rad/s², two periods of delay) the first SLUGGISH_SCENES scenes of
every family run too, in both modes, and what the strategy guarantees there
is asserted on both (docs/strategy-wheels.md: the braking guard
keeps every static obstacle beyond D_s): no contact and D_s kept in every
scene without moving obstacles, at most two activations. What it does not
guarantee is reported, not asserted (docs/strategy-wheels-results.md gives the rates and
says why): rejoin, scenes with moving obstacles, and whether the two modes
switch alike (under real wheels their paths part at the guard's decisions).

Expected values come from the issue's acceptance, not from the code's output;
the one tolerance (EVENT_SLACK) is argued where it is defined.
"""

from pathlib import Path

import pytest

from mstc.can.protocol import wire_limits
from mstc.loop.lockstep import simulate
from mstc.loop.result import RunResult
from mstc.model import EventKind
from mstc.plant.scenario import load_scenario
from mstc.sweep.engine import controller_for
from mstc.sweep.metrics import Metrics, evaluate
from mstc.sweep.suite import ActuatorProfile, Family, load_suite, scene_text

ROOT = Path(__file__).resolve().parents[2]
SUITE = load_suite(ROOT / "sim" / "suites" / "standard.toml")
SCENES = 60
"""Scenes per family: the issue's 60 for float vs fixed, also the end-to-end set."""
EVENT_SLACK_US = 100_000
"""Float and Q16.16 positions differ by well under 1 mm (test_numeric_modes),
but a threshold crossed at ~0.5 m/s by a path 1 mm apart may be crossed one
period (0.02 s) earlier or later, and a release a period apart moves the next
activation as much again. The events must be the same ones in the same order;
their times may differ by at most 5 periods (on the first 100 scenes of every
family the largest difference measured was 2 periods, in 15 of 1000 scenes)."""
SLUGGISH_SCENES = 6
"""Scenes per family under the "sluggish" actuator: seconds, not minutes."""
SLUGGISH = next(a for a in SUITE.actuators if a.name == "sluggish")
_RUNS: dict[tuple[str, str], list[tuple[str, RunResult, RunResult, Metrics]]] = {}
REPORT: list[str] = []
"""Lines for the terminal summary (conftest.py prints them)."""


def _family(name: str) -> Family:
    return next(f for f in SUITE.families if f.name == name)


def _runs(
    name: str, libs: dict[str, Path], tmp: Path, actuator: ActuatorProfile | None = None
) -> list[tuple[str, RunResult, RunResult, Metrics]]:
    """Every scene of family @p name (the first SCENES, or SLUGGISH_SCENES
    under @p actuator) run with "mstc" by both libraries, and the float run's
    metrics; run once per session."""
    key = (name, actuator.name if actuator else "ideal")
    if key not in _RUNS:
        family = _family(name)
        out = []
        count = SCENES if actuator is None else SLUGGISH_SCENES
        for i in range(count):
            stem = family.scene_name(i) if actuator is None else f"{name}-{actuator.name}-{i:04d}"
            path = tmp / f"{stem}.toml"
            path.write_text(scene_text(SUITE, family, i, actuator=actuator))
            scenario = load_scenario(path, wire_limits())
            results = []
            for mode in ("float", "fixed"):
                run, controller = controller_for(scenario, "mstc", str(libs[mode]))
                results.append(simulate(run, controller))
            out.append((stem, results[0], results[1], evaluate(results[0])))
        _RUNS[key] = out
    return _RUNS[key]


FAMILIES = [f.name for f in SUITE.families]


@pytest.fixture(scope="module")
def scenes_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("strategy")


def test_the_suite_has_every_family_of_the_issue() -> None:
    # The nine families of issue 12, and noisy clusters; each with at least
    # SCENES scenes.
    kinds = {f.kind for f in SUITE.families}
    assert kinds == {
        "isolated",
        "cluster",
        "head_on",
        "circle",
        "moving",
        "dense",
        "narrow",
        "through",
        "start_active",
    }
    assert all(f.count >= SCENES for f in SUITE.families)


@pytest.mark.parametrize("name", FAMILIES)
def test_mstc_is_safe_rejoins_and_activates_at_most_twice(
    name: str, libs: dict[str, Path], scenes_dir: Path
) -> None:
    runs = _runs(name, libs, scenes_dir)
    for scene, result, _, m in runs:
        assert result.scenario.params.strategy.value == "mstc", scene
        assert not m.contact, f"{scene}: contact, clearance {m.min_clearance:.4f} m"
        # The issue allows 0.5 % of moving-obstacle runs below D_s: none of 60.
        assert m.ds_kept, f"{scene}: centre distance below D_s"
        assert m.max_activations <= 2, f"{scene}: an obstacle activated {m.max_activations} times"
        if not m.blocked:
            assert m.rejoined is not False, f"{scene}: not back on the reference within 10 s"
    # Rejoin can be "not judged" (a pass too short to tell, metrics.py); the
    # check above must not be empty: most runs of every family are judged.
    judged = sum(1 for *_, m in runs if not m.blocked and m.rejoined is not None)
    blocked = sum(1 for *_, m in runs if m.blocked)
    REPORT.append(
        f"{name}: {len(runs)} runs, rejoin judged in {judged}, blocked {blocked}, "
        f"smallest clearance {min(m.min_clearance for *_, m in runs):.3f} m"
    )
    assert judged >= SCENES // 2, f"{name}: only {judged} of {SCENES} runs judged on rejoin"


def _events(r: RunResult) -> list[tuple[EventKind, int, str | None]]:
    return [(e.kind, e.obstacle, e.side and str(e.side)) for e in r.events]


_FILTER_KINDS = (EventKind.FILTER, EventKind.INFEASIBLE)


def _switching(r: RunResult) -> list[tuple[EventKind, int, str | None]]:
    """The events of the switch (detect, activate, complete, blocked,
    resume): under real wheels the filter's episodes start and end where
    the braking guard's margin is crossed by a path micrometres away, and
    may split or merge between the numeric modes (docs/strategy.md)."""
    return [e for e in _events(r) if e[0] not in _FILTER_KINDS]


@pytest.mark.parametrize("name", FAMILIES)
def test_float_and_fixed_give_the_same_events(
    name: str, libs: dict[str, Path], scenes_dir: Path
) -> None:
    # With imperfections (noisy reports) the filter may act for a period in one
    # build and not in the other (docs/strategy-results.md, "Float and fixed
    # builds"): there the switch's events must agree, and the filter's are
    # reported when they do not; elsewhere every event.
    noisy = bool(_family(name).imperfections)
    for scene, flt, fix, _ in _runs(name, libs, scenes_dir):
        if noisy and _events(fix) != _events(flt):
            assert _switching(fix) == _switching(flt), scene
            REPORT.append(f"{scene}: the filter's events differ between float and fixed")
            flt_events = [e for e in flt.events if e.kind not in _FILTER_KINDS]
            fix_events = [e for e in fix.events if e.kind not in _FILTER_KINDS]
        else:
            assert _events(fix) == _events(flt), scene
            flt_events, fix_events = list(flt.events), list(fix.events)
        worst = max(
            (abs(a.t_us - b.t_us) for a, b in zip(flt_events, fix_events, strict=True)),
            default=0,
        )
        assert worst <= EVENT_SLACK_US, f"{scene}: an event {worst / 1e6:.2f} s apart"
        if worst:
            REPORT.append(f"{scene}: float and fixed events up to {worst / 1e6:.2f} s apart")


@pytest.mark.parametrize("name", FAMILIES)
def test_mstc_on_sluggish_wheels_is_safe_and_activates_at_most_twice(
    name: str, libs: dict[str, Path], scenes_dir: Path
) -> None:
    runs = _runs(name, libs, scenes_dir, SLUGGISH)
    alike = 0
    for scene, result, fixed, m in runs:
        assert result.scenario.actuator.model == "lag"
        assert result.scenario.params.wheel_accel == 10.0
        for mode, metrics in (("float", m), ("fixed", evaluate(fixed))):
            if not any(o.moving for o in result.scenario.obstacles):
                assert not metrics.contact, f"{scene} ({mode}): contact"
                assert metrics.ds_kept, f"{scene} ({mode}): centre distance below D_s"
            assert metrics.max_activations <= 2, f"{scene} ({mode}): activated 3 times"
        alike += _switching(fixed) == _switching(result)
    judged = [m for *_, m in runs if not m.blocked and m.rejoined is not None]
    REPORT.append(
        f"{name} (sluggish, float): {len(runs)} runs, rejoined "
        f"{sum(1 for m in judged if m.rejoined)} of {len(judged)} judged, contacts "
        f"{sum(1 for *_, m in runs if m.contact)}, smallest clearance "
        f"{min(m.min_clearance for *_, m in runs):.3f} m; float and fixed switch alike in "
        f"{alike} of {len(runs)}"
    )


def test_a_suite_scene_runs_mstc_by_default(tmp_path: Path) -> None:
    # The issue: "mstc" is the default of scenario files that do not say;
    # the suite's files do not, so `mstc sim` on one runs what is judged above.
    path = tmp_path / "s.toml"
    path.write_text(scene_text(SUITE, _family("isolated"), 0))
    assert "strategy" not in path.read_text()
    assert load_scenario(path, wire_limits()).params.strategy.value == "mstc"
