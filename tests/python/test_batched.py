# SPDX-License-Identifier: MIT
"""The batched sweep engine against the per-scene one (issue 22).

The per-scene engine (mstc.loop.lockstep.simulate judged by
mstc.sweep.metrics.evaluate) is the reference: it is independent of the
batched code (its own plant objects, math's functions, one ctypes call per
step), so its rows and events.json are the expected values. The batched
engine is built to take the same operations in the same order and draw the
same random numbers, so the expected agreement is exact, bit for bit, with
ideal wheels and with "lag" wheels (mstc.plant.actuator.Actuator, whose
substeps the batched plant takes over arrays); the full-size check (2,000
scenes per family) is python -m mstc.bench.agreement.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import tomllib
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from mstc.can.library import (
    BATCH_INPUT_DTYPE,
    NUMPY_DTYPES,
    Library,
    check_layout,
    library_layout,
)
from mstc.can.protocol import wire_limits
from mstc.errors import FirmwareError
from mstc.firmware.sil import SilBatch, SilController
from mstc.loop.batched import BatchStep, simulate_batch
from mstc.loop.lockstep import simulate
from mstc.loop.result import RunResult
from mstc.model import EventKind, Obstacle, Pose, Strategy, wrap_angle
from mstc.plant.batch import BatchActuator, BatchWorld, wrap
from mstc.plant.scenario import Scenario, load_scenario, parse_scenario
from mstc.plant.world import make_world
from mstc.sweep import engine
from mstc.sweep.engine import MEASURED_COLUMNS, Job, Scene, run_batch
from mstc.sweep.suite import IDEAL, load_suite, scene_text

ROOT = Path(__file__).resolve().parents[2]
STANDARD = ROOT / "sim" / "suites" / "standard.toml"
PAPER = [
    ROOT / "sim" / "scenarios" / "paper-line.toml",
    ROOT / "sim" / "scenarios" / "paper-circle.toml",
]
PER_FAMILY = 3
"""Scenes of every family of the standard suite in the seeded subset."""
PER_PROFILE = 2
"""Scenes of every family and actuator profile of the standard suite in the
seeded subset with actuators."""


@pytest.fixture(params=["float", "fixed"])
def any_lib(request: pytest.FixtureRequest) -> str:
    var = f"MSTC_SIL_LIB_{request.param.upper()}"
    value = os.environ.get(var)
    if not value or not Path(value).is_file():
        pytest.fail(f"{var}={value!r}: `make test-python` builds both libraries and sets it")
    return str(Path(value).resolve())


def _suite_jobs(
    per_family: int, strategies: tuple[str, ...], profiles: tuple[str, ...] = (IDEAL,)
) -> list[Job]:
    """The first @p per_family scenes of every family of the standard suite
    under each actuator profile of @p profiles, named and written as
    ``mstc sweep`` writes them."""
    suite = load_suite(STANDARD)
    actuators = {a.name: a for a in suite.actuators}
    jobs = []
    for f in suite.families:
        for name in profiles:
            profile = actuators[name]
            for i in range(per_family):
                stem = suite.scene_name(f, i, profile)
                text = scene_text(suite, f, i, actuator=profile if profile.values else None)
                scene = Scene(stem, stem, text, f.name, actuator=name)
                jobs += [(scene, s) for s in strategies]
    return jobs


def _reproducible(row: dict[str, str]) -> dict[str, str]:
    return {k: v for k, v in row.items() if k not in MEASURED_COLUMNS}


def _differences(jobs: list[Job], lib: str) -> list[str]:
    """Jobs whose row or events.json differ between the engines."""
    batched = run_batch(jobs, lib, "batched")
    scene = run_batch(jobs, lib, "scene")
    return [
        f"{a.scene} {a.strategy}"
        for a, b in zip(batched, scene, strict=True)
        if _reproducible(a.row) != _reproducible(b.row) or a.events != b.events
    ]


def test_the_engines_give_the_same_rows_and_events_on_every_family(any_lib: str) -> None:
    jobs = _suite_jobs(PER_FAMILY, ("paper", "mstc"))
    assert _differences(jobs, any_lib) == []


def test_the_comparison_sees_a_plant_that_differs(
    sil_lib: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The check above can fail: the headings passed unwrapped (np.remainder,
    # a floor modulo, instead of the IEEE remainder) change rows.
    import mstc.loop.batched as batched

    monkeypatch.setattr(batched, "wrap", lambda a: np.remainder(a, math.tau))
    jobs = _suite_jobs(1, ("mstc",))
    assert len(_differences(jobs, str(sil_lib.resolve()))) > 0


def test_the_engines_agree_on_every_family_under_every_actuator_profile(
    any_lib: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The suite's three profiles (ideal, gearmotor: 20 substeps and encoders;
    # sluggish: a 2-period delay too) mixed in one batch, both strategies.
    suite = load_suite(STANDARD)
    profiles = tuple(a.name for a in suite.actuators)
    assert profiles == ("ideal", "gearmotor", "sluggish"), "the suite's profiles changed"
    jobs = _suite_jobs(PER_PROFILE, ("paper", "mstc"), profiles)
    # The batched engine batches them all: none goes through the per-scene run.
    alone: list[str] = []
    run_job = engine.run_job

    def counted(scene: Scene, strategy: str, lib: str) -> tuple[RunResult | None, dict[str, str]]:
        alone.append(scene.name)
        return run_job(scene, strategy, lib)

    monkeypatch.setattr(engine, "run_job", counted)
    batched = run_batch(jobs, any_lib, "batched")
    assert alone == []
    assert [o.row["error"] for o in batched] == [""] * len(jobs)
    monkeypatch.setattr(engine, "run_job", run_job)
    scene = run_batch(jobs, any_lib, "scene")
    assert {o.row["actuator"] for o in batched} == set(profiles)
    differ = [
        f"{a.scene} {a.strategy}"
        for a, b in zip(batched, scene, strict=True)
        if _reproducible(a.row) != _reproducible(b.row) or a.events != b.events
    ]
    assert differ == []
    # The wheels mattered: the same scene's runs differ between profiles.
    rows = {(o.row["scene"], o.strategy): _reproducible(o.row) for o in batched}
    changed = [
        name
        for (name, strategy), row in rows.items()
        if "-gearmotor-" in name
        and {**row, "scene": "", "actuator": ""}
        != {**rows[(name.replace("-gearmotor", ""), strategy)], "scene": "", "actuator": ""}
    ]
    assert len(changed) > len(jobs) // 6


def test_the_engines_count_activations_per_encounter_alike(any_lib: str) -> None:
    # Circular references under "sluggish" wheels: the robot meets each
    # obstacle again a lap later, so some obstacle is activated more than
    # twice in a run but at most twice an encounter (mstc.sweep.metrics,
    # most_activations). The batched engine counts the encounters step by
    # step, the per-scene one from the whole trace: the same rows. (Of the
    # first 60 scenes, 4 meet an obstacle in two encounters under the
    # strategy of BARN's round, which activates a static obstacle only when
    # the roll-out comes near it; 0 of the first 30 under "gearmotor".)
    suite = load_suite(STANDARD)
    family = next(f for f in suite.families if f.name == "circle")
    profile = next(a for a in suite.actuators if a.name == "sluggish")
    jobs: list[Job] = []
    for i in range(60):
        stem = suite.scene_name(family, i, profile)
        scene = Scene(stem, stem, scene_text(suite, family, i, actuator=profile), "circle")
        jobs.append((scene, "mstc"))
    assert _differences(jobs, any_lib) == []
    relapsed = 0
    for o in run_batch(jobs, any_lib, "batched"):
        assert o.events is not None
        per_run: dict[int, int] = {}
        for e in json.loads(o.events)["events"]:
            if e["event"] == EventKind.ACTIVATE.value:
                per_run[e["obstacle"]] = per_run.get(e["obstacle"], 0) + 1
        assert int(o.row["max_activations"]) <= 2
        relapsed += max(per_run.values(), default=0) > 2
    assert relapsed >= 2, "no run met an obstacle in two encounters"


@pytest.mark.parametrize("plant", ["max_accel 0.1 % higher", "encoders unquantised"])
def test_the_comparison_sees_wheels_that_differ(
    sil_lib: Path, monkeypatch: pytest.MonkeyPatch, plant: str
) -> None:
    # The check above can fail: batched wheels a little off change rows.
    init = BatchActuator.__init__

    def planted(
        self: BatchActuator,
        scenarios: Sequence[Scenario],
        rows: np.ndarray,
        euler: np.ndarray | None,
    ) -> None:
        if plant.startswith("max_accel"):  # the batched wheels' only
            scenarios = [
                dataclasses.replace(
                    s,
                    actuator=dataclasses.replace(
                        s.actuator, max_accel=s.actuator.max_accel * 1.001
                    ),
                )
                for s in scenarios
            ]
        init(self, scenarios, rows, euler)
        if plant.startswith("encoders"):
            self._any_quantised = False

    monkeypatch.setattr(BatchActuator, "__init__", planted)
    jobs = _suite_jobs(1, ("mstc",), ("gearmotor",))
    assert len(_differences(jobs, str(sil_lib.resolve()))) > 0


def _lag(**keys: float) -> str:
    """An ``[actuator]`` table of model "lag" with @p keys."""
    return '\n[actuator]\nmodel = "lag"\n' + "".join(f"{k} = {v}\n" for k, v in keys.items())


def _lag_variants() -> list[tuple[str, str]]:
    """paper-line with "lag" wheels of every kind the batched plant handles:
    other periods (10 and 13 substeps), the exact integrator, no encoder, no
    limit, no lag, delays of the actuator and of the imperfections, noise;
    and with ideal wheels."""
    text = PAPER[0].read_text()
    gear = _lag(time_constant=0.06, max_accel=20.0, encoder_counts=1920)
    variants = [
        ("gear", text + gear),
        ("fast", text.replace("dt = 0.02", "dt = 0.01") + gear),
        ("odd", text.replace("dt = 0.02", "dt = 0.0125") + gear),
        ("exact", text.replace('integrator = "euler"', 'integrator = "exact"') + gear),
        ("rough", text + _lag(time_constant=0.1, max_accel=10.0, delay=2)),
        ("ramp", text + _lag(max_accel=15.0, encoder_counts=512, delay=1)),
        ("lag", text + _lag(time_constant=0.06, encoder_counts=1920)),
        (
            "noisy",
            text + gear + "\n[imperfections]\ndelay = 1\nposition_noise = 0.005\nseed = 7\n",
        ),
        ("ideal", text),
    ]
    assert len({t for _, t in variants}) == len(variants), "the scenario file's keys changed"
    return variants


def test_lag_wheels_of_every_kind_move_as_the_per_scene_wheels_bit_for_bit() -> None:
    # Expected values: mstc.plant.actuator.Actuator (scalar Python floats,
    # an implementation of its own) driving each scene's own plant, with
    # the delays as the per-scene loop applies them.
    scenarios = [
        parse_scenario(tomllib.loads(t), name, wire_limits()) for name, t in _lag_variants()
    ]
    batch = BatchWorld(scenarios)
    assert batch.actuator is not None and batch.actuator.rows.tolist() == list(range(8))
    worlds = [make_world(s) for s in scenarios]
    pending = [[(0.0, 0.0)] * s.imperfections.delay for s in scenarios]
    rng = np.random.default_rng(11)
    for k in range(150):
        commands = rng.uniform(-12.0, 12.0, (len(scenarios), 2))
        batch.advance(k, commands[:, 0].copy(), commands[:, 1].copy())
        for i, (world, s) in enumerate(zip(worlds, scenarios, strict=True)):
            left, right = commands[i].tolist()
            if world.actuator is not None:
                measured = world.actuator.step(left, right)
                assert batch.actuator.measured[:, i].tolist() == list(measured), (s.name, k)
            else:
                if pending[i]:
                    pending[i].append((left, right))
                    left, right = pending[i].pop(0)
                world.plant.step(left, right, s.sim.dt)
            assert (batch.x[i], batch.y[i], batch.theta[i]) == tuple(world.plant.pose), (s.name, k)


def test_a_batch_without_lag_wheels_has_no_actuator_work() -> None:
    scenarios = [load_scenario(p, wire_limits()) for p in PAPER]
    assert BatchWorld(scenarios).actuator is None


def test_lag_scenes_of_different_periods_integrators_and_delays_agree(sil_lib: Path) -> None:
    lib = str(sil_lib.resolve())
    jobs: list[Job] = [
        (Scene(name, f"{name}.toml", t), s)
        for name, t in _lag_variants()
        for s in ("paper", "mstc")
    ]
    batched = run_batch(jobs, lib, "batched")
    assert [o.row["error"] for o in batched] == [""] * len(jobs)
    assert [o.row["steps"] for o in batched[::2]] == [
        "1001", "2001", "1601", "1001", "1001", "1001", "1001", "1001", "1001"
    ]  # fmt: skip
    assert _differences(jobs, lib) == []


def test_poses_are_the_per_scene_loops_bit_for_bit(any_lib: str) -> None:
    # The issue asks for 1e-9 m on the paper's scenarios; the engines share
    # every operation, so the poses are equal.
    for path in PAPER:
        scenario = load_scenario(path, wire_limits())
        for strategy in ("paper", "mstc"):
            params = dataclasses.replace(scenario.params, strategy=Strategy(strategy))
            s = dataclasses.replace(scenario, params=params)
            trace = simulate(s, SilController(params, any_lib)).trace
            xs: list[float] = []
            ys: list[float] = []

            def keep(step: BatchStep, xs: list[float] = xs, ys: list[float] = ys) -> None:
                xs.append(float(step.x[0]))
                ys.append(float(step.y[0]))

            runs = simulate_batch((s,), SilBatch([params], any_lib), keep)
            assert xs == trace["x"].tolist() and ys == trace["y"].tolist()
            assert runs[0].events == simulate(s, SilController(params, any_lib)).events


def test_scenes_of_different_lengths_and_periods_end_independently(sil_lib: Path) -> None:
    lib = str(sil_lib.resolve())
    text = PAPER[0].read_text()
    variants = [
        ("short", text.replace("duration = 20.0", "duration = 17.0")),
        ("fast", text.replace("dt = 0.02", "dt = 0.01")),
        ("exact", text.replace('integrator = "euler"', 'integrator = "exact"')),
        ("whole", text),
    ]
    assert all(t != text for _, t in variants[:3]), "the scenario file's keys changed"
    jobs: list[Job] = [(Scene(name, f"{name}.toml", t), "mstc") for name, t in variants]
    batched = run_batch(jobs, lib, "batched")
    assert [o.row["steps"] for o in batched] == ["851", "2001", "1001", "1001"]
    assert _differences(jobs, lib) == []


def test_wrap_is_the_ieee_remainder_of_wrap_angle() -> None:
    # Expected values: math.remainder (wrap_angle), independent of np.fmod.
    a = np.array(
        [0.0, math.pi, -math.pi, 3 * math.pi, -3 * math.pi, math.tau, 1e3, -1e3, 7.0, -7.0,
         math.nextafter(math.pi, 4.0), math.nextafter(-math.pi, -4.0), 123456.789]
    )  # fmt: skip
    assert wrap(a).tolist() == [wrap_angle(x) for x in a.tolist()]
    b = np.random.default_rng(1).uniform(-50.0, 50.0, 10_000)
    assert wrap(b).tolist() == [wrap_angle(x) for x in b.tolist()]


def _hypot_disagreement() -> tuple[float, float]:
    """dx, dy where numpy's hypot and math.hypot differ by an ulp (and so
    sqrt(dx·dx + dy·dy) may too): a distance no shortcut gets right."""
    rng = np.random.default_rng(3)
    dx, dy = rng.uniform(0.5, 3.0, 100_000), rng.uniform(0.5, 3.0, 100_000)
    exact = np.array(list(map(math.hypot, dx.tolist(), dy.tolist())))
    i = int(np.flatnonzero(np.hypot(dx, dy) != exact)[0])
    return float(dx[i]), float(dy[i])


def test_the_sensor_decides_a_range_at_the_threshold_as_math_hypot(sil_lib: Path) -> None:
    dx, dy = _hypot_disagreement()
    d = math.hypot(dx, dy)  # the per-scene sensor's distance: in range at exactly d
    scenario = load_scenario(PAPER[0], wire_limits())
    o = Obstacle(1, scenario.robot.x + dx, scenario.robot.y + dy, 0.1)
    for rng in (d, math.nextafter(d, 0.0)):  # seen at d, not just below it
        imp = dataclasses.replace(scenario.imperfections, sensor_range=rng)
        s = dataclasses.replace(scenario, obstacles=(o,), imperfections=imp)
        world = BatchWorld([s])
        ox, oy = world.obstacles_at(np.zeros(1))
        ddx, ddy = ox - world.x[:, None], oy - world.y[:, None]
        seen, _, _ = world.scan(0, ddx * ddx + ddy * ddy, ddx, ddy, ox, oy)
        want = math.hypot(o.x - s.robot.x, o.y - s.robot.y) <= rng
        assert bool(seen[0, 0]) == want == (rng == d)


def test_a_reported_entry_beyond_the_table_is_refused(sil_lib: Path) -> None:
    params = load_scenario(PAPER[0], wire_limits()).params
    batch = SilBatch([params, params], str(sil_lib))
    batch.inputs["in"]["n_obstacles"] = 2
    batch.inputs["reported"][0, :2] = 1
    batch.inputs["reported"][1, 2] = 1  # the second reports entry 3 of 2
    with pytest.raises(FirmwareError, match="mstc_sil_step_batch failed"):
        batch.step()


def test_one_batched_step_is_the_single_step(any_lib: str) -> None:
    # Expected: SilController on the same inputs (its own packing path).
    params = load_scenario(PAPER[0], wire_limits()).params
    single = SilController(params, any_lib)
    batch = SilBatch([params], any_lib)
    obstacles = [Obstacle(3, 1.0, 0.2, 0.15), Obstacle(5, 1.5, -0.3, 0.1, vx=0.2)]
    given = batch.inputs[0]
    given["in"]["robot"] = (0.1, 0.05, 0.2)
    given["in"]["ref"] = (0.2, 0.0, 0.0)
    given["in"]["v_r"], given["in"]["w_r"], given["in"]["t_us"] = 0.5, 0.0, 20000
    given["in"]["n_obstacles"] = 3
    table = batch.inputs["table"][0]
    for j, o in enumerate([Obstacle(1, 9.0, 9.0, 0.1), *obstacles]):
        table[j] = (o.id, o.x, o.y, o.radius, o.vx, o.vy)
    given["reported"][1:3] = 1  # the far one, entry 0, is not reported
    batch.step()
    want = single.step(Pose(0.1, 0.05, 0.2), Pose(0.2, 0.0, 0.0), 0.5, 0.0, obstacles, 20000)
    out = batch.outputs[0]
    assert (float(out["wheel_left"]), float(out["wheel_right"])) == (
        want.wheel_left,
        want.wheel_right,
    )
    assert batch.modes[int(out["mode"])] is want.status.mode
    assert batch.events([0]) == [want.events]


def test_the_batch_dtype_is_checked_against_the_library(sil_lib: Path) -> None:
    layout = library_layout(Library.open(sil_lib).dll)
    check_layout(layout, str(sil_lib), dtypes=NUMPY_DTYPES)  # the load did it too; it passes
    shifted = np.dtype(
        {
            "names": list(BATCH_INPUT_DTYPE.names or ()),
            "formats": [BATCH_INPUT_DTYPE.fields[n][0] for n in BATCH_INPUT_DTYPE.names or ()],  # type: ignore[index]
            "offsets": [
                0,
                BATCH_INPUT_DTYPE.fields["reported"][1] + 4,
                BATCH_INPUT_DTYPE.fields["table"][1],
            ],  # type: ignore[index]
            "itemsize": BATCH_INPUT_DTYPE.itemsize,
        }
    )
    with pytest.raises(
        FirmwareError, match=r"mstc_sil_batch_input_t\.reported: offset .* numpy dtype"
    ):
        check_layout(layout, str(sil_lib), dtypes={"mstc_sil_batch_input_t": shifted})
