# SPDX-License-Identifier: MIT
"""The text report of a run: its events beside the expected ones."""

from dataclasses import dataclass
from pathlib import Path

from mstc.can.dbc import tables
from mstc.loop.result import RunResult
from mstc.model import Event, EventKind, Fault, Params
from mstc.plant.scenario import ExpectedEvent

_NONE = "—"
_FAULT_NAMES = {
    Fault.INPUT_NONFINITE: "non-finite input",
    Fault.OBSTACLE_DROPPED: "obstacle report dropped",
    Fault.SATURATED: "wheel speeds saturated",
    Fault.FILTER: "safety filter acted",
    Fault.TELEMETRY_CLIPPED: "telemetry value clipped to its frame field",
}


@dataclass(frozen=True)
class Match:
    """A simulated event and the expected one it corresponds to; either may be
    missing."""

    kind: EventKind
    obstacle: int
    simulated: Event | None
    expected: ExpectedEvent | None

    @property
    def t(self) -> float:
        """When it happened, or was expected to [s]."""
        if self.simulated is not None:
            return self.simulated.t
        assert self.expected is not None
        return self.expected.t


def match_events(simulated: tuple[Event, ...], expected: tuple[ExpectedEvent, ...]) -> list[Match]:
    """Pair the n-th simulated event of each (kind, obstacle) with the n-th
    expected one; the result is in time order."""
    pending: dict[tuple[EventKind, int], list[ExpectedEvent]] = {}
    for exp in sorted(expected, key=lambda x: x.t):
        pending.setdefault((exp.event, exp.obstacle), []).append(exp)
    matches = []
    for event in simulated:
        queue = pending.get((event.kind, event.obstacle))
        matches.append(Match(event.kind, event.obstacle, event, queue.pop(0) if queue else None))
    matches += [
        Match(exp.event, exp.obstacle, None, exp) for queue in pending.values() for exp in queue
    ]
    return sorted(matches, key=lambda m: m.t)


def _steps(match: Match, dt_us: int) -> str:
    """Simulated minus expected time, in control steps."""
    if match.simulated is None or match.expected is None:
        return _NONE
    steps = (match.simulated.t_us - match.expected.t_us) / dt_us
    if steps == round(steps):
        return f"{round(steps):+d}" if steps else "0"
    return f"{steps:+.1f}"


def missed(result: RunResult, slack: float = 0.0, stop_at: float | None = None) -> list[str]:
    """What @p result missed of its scenario's expectations, one phrase each:
    an ``[[expected]]`` event not reproduced, further from its time than its
    tolerance plus @p slack [s], or on the other side; a contact with an
    obstacle (closer than R_m + its radius); a firmware that ended the run
    halted. Empty when it met them all.

    :param stop_at: a comm-loss trial's time [s]: the odometry stopped then,
        so the halt was asked for and the events expected from then on are
        not judged.
    """
    scenario = result.scenario
    problems = []
    for m in match_events(result.events, scenario.expected):
        exp, sim = m.expected, m.simulated
        if exp is None or (stop_at is not None and exp.t >= stop_at):
            continue
        what = f"{exp.event} O{exp.obstacle} expected at {exp.t:g} s"
        allowed = exp.tolerance + slack
        if sim is None:
            problems.append(f"{what}: not reproduced")
        elif abs(sim.t_us - exp.t_us) > round(allowed * 1e6):
            steps = _steps(m, scenario.sim.dt_us)
            problems.append(f"{what}: at {sim.t:g} s, Δ {steps} steps (tolerance {allowed:g} s)")
        elif exp.side != sim.side:
            problems.append(f"{what}: on the {sim.side}, expected on the {exp.side}")
    p = scenario.params
    for i, (o, d) in enumerate(zip(scenario.obstacles, result.min_distance, strict=True)):
        if d < p.r_m + o.radius:  # the bodies overlapped: a collision, whatever was expected
            problems.append(f"contact with O{i + 1}: {d:.4f} m, closer than R_m + radius")
    if result.halt and stop_at is None:
        reason = tables().halt.name_of(result.halt) or "?"
        problems.append(f"the firmware ended the run halted (STATUS_halt {result.halt}, {reason})")
    return problems


def _note(match: Match, any_expected: bool) -> str:
    if match.simulated is None:
        return "not reproduced"
    if match.expected is None:
        return "not expected" if any_expected else ""
    if match.expected.side != match.simulated.side:
        return f"side differs: expected {match.expected.side}"
    return ""


def _verdict(p: Params, radius: float, d: float) -> str:
    """How the closest approach @p d to an obstacle of @p radius compares with
    its D_s. Never "ok" for a distance that means nothing: the robot's body
    (R_m) overlapped the obstacle's, or D_s itself lies within R_m + radius
    (a parameter set the loader refuses: D_s >= R_m + R_ob)."""
    touch = p.r_m + radius
    if d < touch:
        return f"COLLISION: closer than R_m + radius = {touch:g} m"
    if p.safe_distance(radius) < touch:
        return f"D_s meaningless: below R_m + radius = {touch:g} m"
    return "ok" if d >= p.safe_distance(radius) else "BELOW D_s"


def _decimals(t_us: int) -> int:
    """Decimals that show a time in µs exactly in seconds."""
    digits = 6
    while digits and t_us % 10 == 0:
        t_us //= 10
        digits -= 1
    return digits


def format_report(result: RunResult, folder: Path) -> str:
    """The table printed after a run: events (simulated, expected, difference
    in control steps), minimum distance to each obstacle against its D_s,
    faults, and where the outputs are."""
    scenario = result.scenario
    sim = scenario.sim
    places = max([_decimals(sim.dt_us)] + [_decimals(e.t_us) for e in scenario.expected])
    row = "  {:<9} {:<9} {:<6} {:>9}  {:>14}  {:>9}  {}"
    lines = [
        f"{scenario.name}: {scenario.path} ({sim.integrator}, dt {sim.dt:g} s, "
        f"{sim.duration:g} s, {len(scenario.obstacles)} obstacles)",
        row.format("event", "obstacle", "side", "t sim [s]", "t expected [s]", "Δ [steps]", "note"),
    ]
    for m in match_events(result.events, scenario.expected):
        side = m.simulated.side if m.simulated else (m.expected.side if m.expected else None)
        t_sim = f"{m.simulated.t:.{places}f}" if m.simulated else _NONE
        t_exp = f"{m.expected.t:.{places}f}" if m.expected else _NONE
        note = _note(m, bool(scenario.expected))
        cells = (m.kind, f"O{m.obstacle}", side or "", t_sim, t_exp, _steps(m, sim.dt_us), note)
        lines.append(row.format(*cells).rstrip())
    if not result.events and not scenario.expected:
        lines.append("  (no events)")
    p = scenario.params
    listed = len(scenario.obstacles) - scenario.world
    pairs = list(zip(scenario.obstacles, result.min_distance, strict=True))
    for i, (o, d) in enumerate(pairs[:listed]):
        d_s = p.safe_distance(o.radius)
        label = "min distance" if i == 0 else ""
        verdict = _verdict(p, o.radius, d)
        lines.append(f"  {label:<13} O{i + 1} {d:.4f} m  (D_s {d_s:g} m: {verdict})")
    if scenario.world:
        # A world's hundreds of obstacles: how many, from where, the nearest.
        world = pairs[listed:]
        k = min(range(len(world)), key=lambda j: world[j][1])
        o, d = world[k]
        below = sum(1 for w, dw in world if dw < p.safe_distance(w.radius))
        lines.append(
            f"  {'world':<13} {scenario.world} obstacles ({scenario.world_source}): nearest "
            f"O{listed + k + 1} {d:.4f} m  (D_s {p.safe_distance(o.radius):g} m: "
            f"{_verdict(p, o.radius, d)}); {below} came within D_s"
        )
    for fault, count in result.faults.items():
        lines.append(f"  {'fault':<13} {_FAULT_NAMES.get(fault, str(fault))} in {count} steps")
    if result.timing is not None:
        lines.append(f"  {'timing':<13} {result.timing.describe()}")
    lines.append(f"  {'output':<13} {folder}/")
    return "\n".join(lines)
