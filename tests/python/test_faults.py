# SPDX-License-Identifier: MIT
"""Closed loop through a faulty link: the plant and the firmware in lock-step
over the in-process bus ("mstc-sil"), with the plant's frames cut, corrupted,
delayed and duplicated (docs/safety.md, "Tests").

- **Cut** (100 seeded trials): at a random step and a random phase within
  that step's input frames, the odometry, the reference or both stop for
  good; STEP frames keep coming, since in lock-step they are the firmware's
  clock (a cut of STEP itself stops the firmware's time: no step runs, so it
  can command nothing; docs/safety.md says why that is the simulator's side).
  The last valid frame is the last frame sent of the input cut first. The
  firmware must report the halt (STATUS_halt odometry or reference) at a
  step at most 3 control periods after the step of that frame, and with
  max_wheel_decel high enough to stop in one step, command exactly zero wheel
  speed there; with the default deceleration, ramp down at exactly that rate
  and never speed up.
- **Noise**: every input frame is corrupted, duplicated or delayed at a set
  rate, over the paper's first scenario; an operator re-arms after each halt.
  The robot never touches an obstacle, and at every step the firmware runs,
  the tracking errors it reports are those of the true poses (within what one
  held frame can move), so it never moved on a corrupted frame: those carry
  a pose 3 m off.

The bus is built by `open_bus`: the in-process library by default; with
MSTC_FAULTS_BUS=vcan, SocketCAN's vcan0 with mstc-fw (MSTC_FW) as its own
process, started afresh for each trial like a board. The last test runs a few
trials of each kind that way, inside the vcan VM (tools/vm/with-vcan: one
boot for all of them), so the closed loop is proved over a real CAN socket
too, not only in process.
"""

from __future__ import annotations

import math
import os
import random
import re
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import can
import pytest

from mstc.can.protocol import Frame, Protocol, wire_limits
from mstc.errors import FrameDropped
from mstc.firmware.process import start_firmware, stop_firmware
from mstc.loop.lockstep import ARM_INDEX, CanController
from mstc.model import wrap_angle
from mstc.plant.plant import UnicyclePlant
from mstc.plant.reference import ReferenceRobot
from mstc.plant.scenario import Scenario, load_scenario
from mstc.plant.sensor import RangeSensor

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "sim" / "scenarios" / "paper-line.toml"
DECEL_INDEX = 13
"""PARAM index of max_wheel_decel (mstc.dbc)."""
DEFAULT_DECEL = 125.0
"""APP_DEFAULT_MAX_WHEEL_DECEL [rad/s²]."""
WHEEL_LSB = 2.0**-10
"""WHEEL_CMD resolution [rad/s]."""
INPUTS = ("ODOM_XY", "ODOM_THETA", "REF_XY", "REF_MOTION")
HALT_ODOMETRY, HALT_REFERENCE = 2, 3
BUS = os.environ.get("MSTC_FAULTS_BUS", "sil")
"""Where the trials run: "sil" (in process) or "vcan" (mstc-fw on vcan0)."""
VCAN = BUS == "vcan"
ANSWER_S = 2.0
"""Longest wait for an answer the firmware owes [s] (wall time, vcan)."""
# In process, many trials; over vcan (in the VM, under software emulation,
# where a step takes milliseconds), a few of each kind, cut early, and the
# noisy run over the first 250 steps of the scenario (O1 detected, not yet
# activated).
CUT_SEEDS = range(3) if VCAN else range(100)
RAMP_SEEDS = range(100, 102) if VCAN else range(100, 120)
NOISE_SEEDS = range(1) if VCAN else range(3)
LATEST_CUT = 40 if VCAN else 400
"""Cuts happen at a random step in 5 .. LATEST_CUT - 1."""
NOISE_STEPS = 250 if VCAN else None
"""Steps of the noisy run (None: the whole scenario)."""


@dataclass
class Answer:
    """What the firmware answered to one STEP (None: it ran no step)."""

    left: float
    right: float
    halt: int
    e1: float
    e2: float


class Loop:
    """The scenario's plant, reference and sensor, stepped in lock-step with
    the firmware; `link` decides what becomes of each input frame."""

    def __init__(self, bus: can.BusABC, scenario: Scenario) -> None:
        self.bus = bus
        self.s = scenario
        p = scenario.params
        self.ctl = CanController(bus, p, sim_time_stamps=True)  # PARAM_SET of every parameter
        self.proto: Protocol = self.ctl.proto
        self.plant = UnicyclePlant(
            scenario.robot, p.wheel_radius, p.track_width, scenario.sim.integrator
        )
        r = scenario.reference
        self.ref = ReferenceRobot(r.pose, r.v, r.w, scenario.sim.integrator)
        self.obstacles = scenario.obstacles
        self.sensor = RangeSensor(self.obstacles, p.d_det)
        self.k = 0
        self.wheels = (0.0, 0.0)
        self.min_clearance = math.inf

    def t_us(self) -> int:
        return self.k * self.s.sim.dt_us

    def send(self, msg: can.Message, until: Callable[[Frame], bool] | None = None) -> list[Frame]:
        """Send @p msg; the frames that came back: those waiting, and with
        @p until, those up to the first that satisfies it (at most ANSWER_S
        later; the in-process firmware has answered before send returns)."""
        msg.timestamp = self.t_us() / 1e6
        self.bus.send(msg)
        out: list[Frame] = []
        deadline = time.monotonic() + ANSWER_S
        while True:
            wait = max(deadline - time.monotonic(), 0.0) if until is not None and VCAN else 0.0
            m = self.bus.recv(timeout=wait)
            if m is None:
                return out
            try:
                out.append(self.proto.decode(m))
            except FrameDropped:
                continue
            self.ctl.auth.sync(out[-1])  # the tool reads every frame, as CanController does
            if until is not None and until(out[-1]):
                return out

    def param(self, index: int, value: float) -> int | None:
        """An authenticated PARAM_SET (the controller's key, for the firmware's
        challenge); its result."""

        def answer(f: Frame) -> bool:
            return f.name == "PARAM_VALUE" and f.signals["index"] == index

        if not self.ctl.auth.can_sign():  # no challenge left unsigned: ask for the status
            self.send(
                self.proto.encode("PARAM_GET", index=index), lambda f: f.name == "AUTH_CHALLENGE"
            )
        pset, pauth = self.ctl.auth.param_set(self.proto, index, value)
        # The firmware answers once the PARAM_AUTH is in: wait after it only.
        frames = self.send(pset) + self.send(pauth, answer)
        return next((int(f.signals["result"]) for f in frames if answer(f)), None)

    def first_step(self) -> None:
        """Step 0 through CanController: it arms the firmware first."""
        robot, ref = self.plant.pose, self.ref.pose
        res = self.ctl.step(robot, ref, self.ref.v, self.ref.w, self.sensor.scan(robot), 0)
        self._advance((res.wheel_left, res.wheel_right))

    def inputs(self) -> list[can.Message]:
        robot, ref = self.plant.pose, self.ref.pose
        enc = self.proto.encode
        return [
            enc("ODOM_XY", x=robot.x, y=robot.y),
            enc("ODOM_THETA", theta=wrap_angle(robot.theta)),
            enc("REF_XY", x=ref.x, y=ref.y),
            enc("REF_MOTION", theta=wrap_angle(ref.theta), v=self.ref.v, w=self.ref.w),
        ]

    def step(self, frames: list[can.Message]) -> Answer | None:
        """Send @p frames, the obstacles and STEP; integrate with what comes back
        (the last command when no WHEEL_CMD does, as a motor driver holds it)."""
        for msg in frames:
            self.send(msg)
        for o in self.sensor.scan(self.plant.pose):
            self.send(self.proto.encode("OBSTACLE", id=o.id, x=o.x, y=o.y, radius=o.radius))
        step = self.k % 65536
        answers = self.send(
            self.proto.encode("STEP", step=step, time=self.t_us() % 2**32, raw=True),
            lambda f: f.name == "WHEEL_CMD" and f.signals["step"] == step,
        )
        status = next((f for f in answers if f.name == "STATUS"), None)
        trk = next((f for f in answers if f.name == "STATUS_TRK"), None)
        cmd = next(
            (f for f in answers if f.name == "WHEEL_CMD" and f.signals["step"] == step), None
        )
        if cmd is None or status is None or trk is None:
            self._advance(self.wheels)
            return None
        a = Answer(
            float(cmd.signals["left"]),
            float(cmd.signals["right"]),
            int(status.signals["halt"]),
            float(trk.signals["e1"]),
            float(trk.signals["e2"]),
        )
        self._advance((a.left, a.right))
        return a

    def true_errors(self) -> tuple[float, float]:
        """e1, e2 of eq. (1) from the true poses of this step."""
        r, q = self.plant.pose, self.ref.pose
        dx, dy = q.x - r.x, q.y - r.y
        return math.cos(r.theta) * dx + math.sin(r.theta) * dy, -math.sin(r.theta) * dx + math.cos(
            r.theta
        ) * dy

    def _advance(self, wheels: tuple[float, float]) -> None:
        self.wheels = wheels
        self.plant.step(*wheels, self.s.sim.dt)
        self.ref.step(self.s.sim.dt)
        self.k += 1
        for o in self.obstacles:
            self.min_clearance = min(self.min_clearance, o.distance(self.plant.pose) - o.radius)


@pytest.fixture
def open_bus() -> Iterator[can.BusABC]:
    """A fresh firmware behind a bus: the library in process, or mstc-fw on
    vcan0 (MSTC_FAULTS_BUS=vcan)."""
    if not VCAN:
        lib = os.environ.get("MSTC_SIL_LIB")
        if not lib or not Path(lib).is_file():
            pytest.fail(f"MSTC_SIL_LIB={lib!r}: `make lib` builds it", pytrace=False)
        with can.Bus(interface="mstc-sil", lib=lib) as bus:
            yield bus
        return
    fw = os.environ.get("MSTC_FW")
    if not fw or not Path(fw).is_file():
        pytest.fail(f"MSTC_FW={fw!r}: `make fw` builds build/host/mstc-fw", pytrace=False)
    bus = can.Bus(interface="socketcan", channel="vcan0")
    firmware = start_firmware(Path(fw), "vcan0")
    try:
        yield bus
    finally:
        bus.shutdown()
        stop_firmware(firmware)


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    return load_scenario(SCENARIO, wire_limits())


# ---------------------------------------------------------------------- cut

CUTS = {"odometry": {"ODOM_XY", "ODOM_THETA"}, "reference": {"REF_XY", "REF_MOTION"}}
CUTS["both"] = CUTS["odometry"] | CUTS["reference"]


def _cut_trial(bus: can.BusABC, scenario: Scenario, seed: int, instant: bool) -> None:
    rng = random.Random(seed)
    loop = Loop(bus, scenario)
    if instant:  # 10000 rad/s² × 20 ms = 200 rad/s a step: more than any wheel speed
        assert loop.param(DECEL_INDEX, 10000.0) == 0
    loop.first_step()
    cut_step = rng.randrange(5, LATEST_CUT)
    phase = rng.randrange(len(INPUTS) + 1)  # input frames of cut_step sent before the cut
    what = rng.choice(sorted(CUTS))
    last_sent = dict.fromkeys(INPUTS, 0)
    history: list[Answer] = []
    while loop.k < cut_step + 8:
        frames = loop.inputs()
        if loop.k >= cut_step:
            frames = [
                m
                for i, m in enumerate(frames)
                if not (INPUTS[i] in CUTS[what] and (loop.k > cut_step or i >= phase))
            ]
        for m in frames:
            last_sent[loop.proto.message(m.arbitration_id).name] = loop.k
        a = loop.step(frames)
        assert a is not None, "every STEP arrives intact here"
        history.append(a)
    k_last = min(last_sent[n] for n in CUTS[what])
    first = 1  # history[i] answers step i + 1
    halted = [k for k, a in enumerate(history, start=first) if a.halt != 0]
    assert halted, f"seed {seed}: no halt after cutting {what} at step {cut_step}"
    k_halt = halted[0]
    assert k_last < k_halt <= k_last + 3, f"seed {seed}: halt at {k_halt}, last frame {k_last}"
    # Both cut: the input whose last frame came first; odometry when they
    # time out together (docs/safety.md: the reasons' order).
    odom = min(last_sent[n] for n in CUTS["odometry"])
    ref = min(last_sent[n] for n in CUTS["reference"])
    want = {
        "odometry": HALT_ODOMETRY,
        "reference": HALT_REFERENCE,
        "both": HALT_REFERENCE if ref < odom else HALT_ODOMETRY,
    }[what]
    assert history[k_halt - first].halt == want
    assert all(a.halt == want for a in history[k_halt - first :]), "the halt latches"
    before = history[k_halt - first - 1]
    if instant:
        assert all(a.left == 0.0 and a.right == 0.0 for a in history[k_halt - first :])
        return
    # Ramp: the larger wheel loses max_wheel_decel·dt a step until zero.
    dv = DEFAULT_DECEL * scenario.sim.dt
    prev = max(abs(before.left), abs(before.right))
    for a in history[k_halt - first :]:
        now = max(abs(a.left), abs(a.right))
        assert now <= prev + WHEEL_LSB, "never speeds up"
        assert now == pytest.approx(max(prev - dv, 0.0), abs=3 * WHEEL_LSB)
        prev = now


@pytest.mark.parametrize("seed", CUT_SEEDS)
def test_a_cut_link_gives_zero_speed_within_3_periods(
    open_bus: can.BusABC, scenario: Scenario, seed: int
) -> None:
    _cut_trial(open_bus, scenario, seed, instant=True)


@pytest.mark.parametrize("seed", RAMP_SEEDS)
def test_a_cut_link_ramps_down_at_the_configured_deceleration(
    open_bus: can.BusABC, scenario: Scenario, seed: int
) -> None:
    _cut_trial(open_bus, scenario, seed, instant=False)


# -------------------------------------------------------------------- noise

RATE = 0.02
"""Probability of each fault for each input frame."""


def _corrupt(loop: Loop, name: str, rng: random.Random) -> can.Message:
    """A frame of @p name that claims a pose or reference 3 m off, with one
    flipped bit: it must never be used."""
    robot, ref = loop.plant.pose, loop.ref.pose
    enc = loop.proto.encode
    hostile = {
        "ODOM_XY": lambda: enc("ODOM_XY", x=robot.x + 3.0, y=robot.y - 3.0),
        "ODOM_THETA": lambda: enc("ODOM_THETA", theta=wrap_angle(robot.theta + 2.0)),
        "REF_XY": lambda: enc("REF_XY", x=ref.x - 3.0, y=ref.y + 3.0),
        "REF_MOTION": lambda: enc("REF_MOTION", theta=wrap_angle(ref.theta + 2.0), v=5.0, w=3.0),
    }[name]()
    data = bytearray(hostile.data)
    data[rng.randrange(8)] ^= 1 << rng.randrange(8)
    hostile.data = data
    return hostile


@pytest.mark.parametrize("seed", NOISE_SEEDS)
def test_corrupted_delayed_and_duplicated_frames_never_move_the_robot_wrongly(
    open_bus: can.BusABC, scenario: Scenario, seed: int
) -> None:
    rng = random.Random(seed)
    loop = Loop(open_bus, scenario)
    loop.first_step()
    held: list[can.Message] = []
    counts = dict.fromkeys(("corrupted", "duplicated", "delayed", "halts", "steps run"), 0)
    p = scenario.params
    steps = NOISE_STEPS or scenario.sim.steps
    while loop.k <= steps:
        out: list[can.Message] = held
        held = []
        for name, msg in zip(INPUTS, loop.inputs(), strict=True):
            r = rng.random()
            if r < RATE:
                out.append(_corrupt(loop, name, rng))
                counts["corrupted"] += 1
            elif r < 2 * RATE:
                out += [msg, msg]
                counts["duplicated"] += 1
            elif r < 3 * RATE:
                held.append(msg)  # comes after the next step's frames: stale
                counts["delayed"] += 1
            else:
                out.append(msg)
        e1, e2 = loop.true_errors()
        a = loop.step(out)
        assert a is not None
        if a.halt == 0:
            counts["steps run"] += 1
            # One held frame moves a pose by at most v·dt (< 0.05 m here);
            # a corrupted one would be 3 m off.
            assert abs(a.e1 - e1) < 0.1 and abs(a.e2 - e2) < 0.1, (loop.k, a, e1, e2)
            for w in (a.left, a.right):
                assert math.isfinite(w) and abs(w) <= p.max_wheel_speed
        else:
            counts["halts"] += 1
            loop.param(ARM_INDEX, 1.0)  # the operator re-arms; refused until ready
    # Each fault hits about RATE × 4 frames a step: at least a third of that.
    least = RATE * len(INPUTS) * steps / 3
    assert min(counts["corrupted"], counts["duplicated"], counts["delayed"]) > least, counts
    assert counts["steps run"] > 0.8 * steps, counts
    assert loop.min_clearance > p.r_m, f"collision: clearance {loop.min_clearance:.3f} m"
    print(f"seed {seed}: {counts}, min clearance {loop.min_clearance:.3f} m")


# ------------------------------------------------------------ over vcan, in the VM

ROOT_DIR = Path(__file__).resolve().parents[2]
VM_TRIALS = 3 + 2 + 1
"""What the VM runs: CUT_SEEDS, RAMP_SEEDS and NOISE_SEEDS over vcan."""


@pytest.mark.vm
def test_the_cut_and_noise_trials_pass_against_mstc_fw_over_vcan() -> None:
    """The trials above, a few of each kind, against mstc-fw over vcan0: in the
    vcan VM where the host kernel has no CAN (one boot for all of them), on
    the host's vcan0 where it has one. Never skipped: without a vcan, it
    fails with tools/vm/with-vcan's reason."""
    if VCAN:
        pytest.fail("run on the host: it starts the VM, which runs the other tests")
    fw = os.environ.get("MSTC_FW")
    if not fw or not Path(fw).is_file():
        pytest.fail(f"MSTC_FW={fw!r}: `make fw` builds build/host/mstc-fw", pytrace=False)
    env = dict(os.environ, MSTC_FAULTS_BUS="vcan", MSTC_FW=str(Path(fw).resolve()))
    cmd = [
        str(ROOT_DIR / "tools" / "vm" / "with-vcan"),
        "--verbose",
        "--timeout",
        "900",
        "--",
        sys.executable,
        "-m",
        "pytest",
        "-q",
        "-p",
        "no:cacheprovider",
        "--durations=0",
        "-k",
        "not over_vcan",
        str(Path(__file__).resolve()),
    ]
    start = time.monotonic()
    done = subprocess.run(
        cmd, cwd=ROOT_DIR, env=env, capture_output=True, text=True, timeout=1200, check=False
    )
    seconds = time.monotonic() - start
    report = f"with-vcan exit {done.returncode}\n{done.stdout}\n{done.stderr}"
    assert done.returncode == 0, report
    passed = re.search(r"(\d+) passed", done.stdout)
    assert passed and int(passed[1]) == VM_TRIALS, report
    assert "failed" not in done.stdout and "error" not in done.stdout.lower(), report
    boot = re.search(r"command started ([\d.]+) s after launch", done.stderr)
    where = "in the VM" if boot else "on the host's vcan0"
    print(
        f"{VM_TRIALS} trials against mstc-fw over vcan {where}: {seconds:.0f} s in all"
        + (f" ({boot[1]} s to boot)" if boot else "")
    )
    # The time of each trial in the VM, from its pytest's --durations.
    print("\n".join(line for line in done.stdout.splitlines() if re.match(r"[\d.]+s call", line)))
