# SPDX-License-Identifier: MIT
"""The firmware's wheel loop against DC motors, in this process: the bindings
of ``mstc_sil_wheels_*`` (hal/sil/mstc_sil_wheel.h), the library's wheel loop
(firmware/wheel/whl.h) running two DC gearmotors (sim/dcmotor/dcm.h) on its own
clock; and :class:`DcWheels`, which makes of it the plant's "dc" actuator
(``[actuator] model = "dc"``, docs/wheel.md): two brushed DC gearmotors
(sim/dcmotor/dcm.h) whose speed loop is the firmware's own (firmware/wheel/whl.h):
the control step's wheel speeds are the loop's setpoints, the loop runs at
its rate (1 kHz) on the motors' encoders, and the plant's pose follows the
wheels as they turn, in substeps of at most 1 ms. So ``mstc sim`` and the
sweeps run the complete firmware, outer and inner loops, against motors.

:class:`Motor` holds a motor's constants and their closed forms (its speed
and drive in steady state, its time constant); :meth:`Motor.pololu_37d`
derives the default motor from its datasheet here, independently of the C
model's defaults, which the tests compare (docs/wheel.md, "The motor model").
"""

from __future__ import annotations

import ctypes
import errno
import math
from collections.abc import Callable, Sequence
from dataclasses import astuple, dataclass, fields, replace
from pathlib import Path

from mstc.can.library import AbiStruct, Library, check_layout, library_layout
from mstc.errors import FirmwareError
from mstc.limits import load_table
from mstc.plant.plant import UnicyclePlant, body_velocity, integrate
from mstc.plant.scenario import Scenario


class MotorStruct(AbiStruct):
    """``mstc_sil_motor_t``."""

    c_name = "mstc_sil_motor_t"
    _fields_ = [
        (n, ctypes.c_double)
        for n in (
            "r_ohm",
            "kt",
            "ke",
            "j",
            "b",
            "tau_c",
            "v_supply",
            "counts_per_rev",
            "hold_k",
            "hold_c",
        )
    ]


class WheelParamsStruct(AbiStruct):
    """``mstc_sil_wheel_params_t``."""

    c_name = "mstc_sil_wheel_params_t"
    _fields_ = [
        (n, ctypes.c_double)
        for n in (
            "kp",
            "ki",
            "free_speed",
            "motor_tau",
            "counts",
            "rate",
            "window",
            "stall_time",
            "accel",
        )
    ]


class WheelsInputStruct(AbiStruct):
    """``mstc_sil_wheels_input_t``."""

    c_name = "mstc_sil_wheels_input_t"
    _fields_ = [("setpoint", ctypes.c_double * 2), ("load", ctypes.c_double * 2)]


class WheelsOutputStruct(AbiStruct):
    """``mstc_sil_wheels_output_t``."""

    c_name = "mstc_sil_wheels_output_t"
    _fields_ = [
        ("speed", ctypes.c_double * 2),
        ("angle", ctypes.c_double * 2),
        ("measured", ctypes.c_double * 2),
        ("drive", ctypes.c_double * 2),
        ("faults", ctypes.c_uint32),
        ("periods", ctypes.c_uint32),
        ("age_us", ctypes.c_uint32),
    ]


WHEEL_STRUCTS: tuple[type[AbiStruct], ...] = (
    MotorStruct,
    WheelParamsStruct,
    WheelsInputStruct,
    WheelsOutputStruct,
)
"""The structs of hal/sil/mstc_sil_wheel.h, checked at load time."""


@dataclass(frozen=True)
class Motor:
    """A DC gearmotor's constants at its output shaft, SI units (sim/dcmotor/dcm.h)."""

    r_ohm: float
    """Armature resistance R [Ω]."""
    kt: float
    """Torque constant Kt [N·m/A]."""
    ke: float
    """Back-EMF constant Ke [V·s/rad]."""
    j: float
    """Inertia J, rotor reflected plus the robot's share [kg·m²]."""
    b: float
    """Viscous friction [N·m·s/rad]."""
    tau_c: float
    """Coulomb friction [N·m]."""
    v_supply: float
    """Supply [V]: the voltage at full drive."""
    counts_per_rev: float
    """Encoder counts per output revolution (×4 quadrature)."""
    hold_k: float
    """Stiffness of a hold [N·m/rad]."""
    hold_c: float
    """Damping of a hold [N·m·s/rad]."""

    @classmethod
    def pololu_37d(cls, robot_kg: float = 1.0, wheel_radius: float = 0.05) -> Motor:
        """The Pololu 37D 12 V 30:1 gearmotor with its 64 CPR encoder,
        @p robot_kg of robot on a wheel of @p wheel_radius [m], from the
        datasheet (docs/wheel.md derives each line)."""
        volts, rpm, i_free, i_stall = 12.0, 330.0, 0.2, 5.5
        stall_torque = 140.0 * 9.80665e-3  # 140 kg·mm
        ratio, motor_cpr = 30.0, 64.0
        coulomb_share, rotor = 0.5, 1.0e-6  # not in the datasheet (docs/wheel.md)
        w_free = rpm * 2.0 * math.pi / 60.0
        r = volts / i_stall
        ke = (volts - r * i_free) / w_free
        kt = stall_torque / (i_stall - coulomb_share * i_free)
        friction = kt * i_free
        j = robot_kg * wheel_radius**2 + rotor * ratio**2
        hold_k = stall_torque / math.radians(1.0)
        return cls(
            r_ohm=r,
            kt=kt,
            ke=ke,
            j=j,
            b=(1.0 - coulomb_share) * friction / w_free,
            tau_c=coulomb_share * friction,
            v_supply=volts,
            counts_per_rev=motor_cpr * ratio,
            hold_k=hold_k,
            hold_c=2.0 * 0.7 * math.sqrt(hold_k * j),
        )

    @property
    def damping(self) -> float:
        """b + Kt·Ke/R [N·m·s/rad]."""
        return self.b + self.kt * self.ke / self.r_ohm

    @property
    def tau(self) -> float:
        """Mechanical time constant J / (b + Kt·Ke/R) [s]."""
        return self.j / self.damping

    def speed_steady(self, drive: float, load: float = 0.0) -> float:
        """Steady speed forward under @p drive and @p load [rad/s]."""
        return (self.kt * drive * self.v_supply / self.r_ohm - self.tau_c - load) / self.damping

    def drive_steady(self, omega: float, load: float = 0.0) -> float:
        """The drive that holds @p omega > 0 against @p load."""
        return (
            self.r_ohm / (self.kt * self.v_supply) * (self.b * omega + self.tau_c + load)
            + self.ke * omega / self.v_supply
        )


@dataclass(frozen=True)
class WheelParams:
    """The wheel loop's parameters (firmware/ctrl/ctl_params.toml's wheel_* rows),
    its setpoint ramp among them: wheel_accel, what the wheels can do."""

    kp: float
    ki: float
    free_speed: float
    motor_tau: float
    counts: float
    rate: float
    window: float
    stall_time: float
    accel: float
    """The setpoint ramp [rad/s²]: the firmware's wheel_accel."""

    @classmethod
    def defaults(cls) -> WheelParams:
        """The limits table's defaults."""
        table = load_table()
        return cls(**{f.name: table.by_name(f"wheel_{f.name}").default for f in fields(cls)})


@dataclass(frozen=True)
class WheelsState:
    """Where the wheels are after an advance (mstc_sil_wheels_output_t)."""

    speed: tuple[float, float]
    """True speeds [rad/s], left and right."""
    angle: tuple[float, float]
    """Angles [rad], running."""
    measured: tuple[float, float]
    """The wheel loop's estimate of its last period [rad/s]: what a board's
    WHEEL_SPEED says."""
    drive: tuple[float, float]
    """Drives in force, [−1, 1]."""
    faults: int
    """The loop's fault bits (WHL_FAULT_*, WHEEL_SPEED_faults)."""
    periods: int
    age_us: int
    """The estimate's age now [µs]: half its window plus the time since the
    loop's last period (0 before the first)."""


def _declare(lib: Library) -> None:
    dll, c_int, c_void_p, pointer = lib.dll, ctypes.c_int, ctypes.c_void_p, ctypes.POINTER
    c_u32 = ctypes.c_uint32
    signatures: list[tuple[str, list[type], type | None]] = [
        ("mstc_sil_wheels_size", [], ctypes.c_size_t),
        ("mstc_sil_wheels_defaults", [pointer(WheelParamsStruct), pointer(MotorStruct)], None),
        (
            "mstc_sil_wheels_init",
            [c_void_p, pointer(WheelParamsStruct), pointer(MotorStruct)],
            c_int,
        ),
        (
            "mstc_sil_wheels_advance",
            [c_void_p, pointer(WheelsInputStruct), c_u32, pointer(WheelsOutputStruct)],
            c_int,
        ),
        ("mstc_sil_wheels_hold", [c_void_p, c_u32, c_u32], c_int),
        ("mstc_sil_wheels_kill_encoder", [c_void_p, c_u32], c_int),
        ("mstc_sil_wheels_clear_faults", [c_void_p], c_int),
    ]
    for name, argtypes, restype in signatures:
        fn = getattr(dll, name)
        fn.argtypes = argtypes
        fn.restype = restype


def _bound(lib: Library) -> Library:
    """@p lib with the wheel functions declared and their structs checked (once)."""
    if not getattr(lib, "_wheels_bound", False):
        try:
            layout = library_layout(lib.dll, "mstc_sil_wheels_layout")
            _declare(lib)
        except AttributeError as exc:
            raise FirmwareError(f"{lib.path} has no wheel loop (mstc_sil_wheels_*): {exc}") from exc
        check_layout(layout, str(lib.path), WHEEL_STRUCTS)
        lib._wheels_bound = True  # type: ignore[attr-defined]  # a mark on the loaded library
    return lib


def library_defaults(lib: Library) -> tuple[WheelParams, Motor]:
    """The library's own defaults (the C model's motor, the firmware's table)."""
    dll = _bound(lib).dll
    wp, mp = WheelParamsStruct(), MotorStruct()
    dll.mstc_sil_wheels_defaults(ctypes.byref(wp), ctypes.byref(mp))
    return (
        WheelParams(*(getattr(wp, f.name) for f in fields(WheelParams))),
        Motor(*(getattr(mp, f.name) for f in fields(Motor))),
    )


class WheelLoop:
    """Both motors and the firmware's wheel loop, in the library.

    :param lib: the firmware library.
    :param params: the loop's parameters (default: the table's).
    :param motor: both motors' constants (default: :meth:`Motor.pololu_37d`).
    :raises FirmwareError: the library refuses them (out of the table's
        ranges or relations, a constant not positive).
    """

    def __init__(
        self, lib: Library, params: WheelParams | None = None, motor: Motor | None = None
    ) -> None:
        self.lib = _bound(lib)
        self.params = params if params is not None else WheelParams.defaults()
        self.motor = motor if motor is not None else Motor.pololu_37d()
        dll = self.lib.dll
        size = int(dll.mstc_sil_wheels_size())
        self._raw = ctypes.create_string_buffer(size + 16)
        self._mem = ctypes.c_void_p((ctypes.addressof(self._raw) + 15) & ~15)
        rc = dll.mstc_sil_wheels_init(
            self._mem,
            ctypes.byref(WheelParamsStruct(*astuple(self.params))),
            ctypes.byref(MotorStruct(*astuple(self.motor))),
        )
        if rc != 0:
            raise FirmwareError(
                f"the wheel loop refuses {self.params} with {self.motor}: "
                f"{errno.errorcode.get(-rc, rc)}"
            )
        self._in = WheelsInputStruct()
        self._out = WheelsOutputStruct()
        self._advance: Callable[..., int] = dll.mstc_sil_wheels_advance

    def advance(
        self, left: float, right: float, dt_us: int, load: tuple[float, float] = (0.0, 0.0)
    ) -> WheelsState:
        """Setpoints @p left, @p right [rad/s] and @p load [N·m] for @p dt_us µs."""
        i, o = self._in, self._out
        i.setpoint[0], i.setpoint[1] = left, right
        i.load[0], i.load[1] = load
        self._advance(self._mem, ctypes.byref(i), dt_us, ctypes.byref(o))
        return WheelsState(
            speed=(o.speed[0], o.speed[1]),
            angle=(o.angle[0], o.angle[1]),
            measured=(o.measured[0], o.measured[1]),
            drive=(o.drive[0], o.drive[1]),
            faults=int(o.faults),
            periods=int(o.periods),
            age_us=int(o.age_us),
        )

    @property
    def address(self) -> int:
        """Where the loop and its motors are in memory: for
        ``mstc_sil_fw_wheels()``, which makes them a board's own
        (:meth:`mstc.can.silbus.SilBus.attach_wheels`)."""
        return int(self._mem.value or 0)

    def hold(self, wheel: int, held: bool) -> None:
        """Hold wheel @p wheel (0 left, 1 right), or let it go."""
        self.lib.dll.mstc_sil_wheels_hold(self._mem, wheel, 1 if held else 0)

    def kill_encoder(self, wheel: int) -> None:
        """Wheel @p wheel's encoder gives no more counts."""
        self.lib.dll.mstc_sil_wheels_kill_encoder(self._mem, wheel)

    def clear_faults(self) -> None:
        """Forget the loop's faults (as a re-arm does on a board)."""
        self.lib.dll.mstc_sil_wheels_clear_faults(self._mem)


SUBSTEP_US = 1000
"""Longest substep of the pose [µs]: the wheel loop's default period."""


class DcWheels:
    """The plant's "dc" actuator: a :class:`~mstc.plant.plant.WheelDrive`.

    Each control period is cut into substeps of at most 1 ms; over each, the
    motors and their loop advance in the library, and the plant's pose moves
    with the body velocity of the wheels' mean speeds over the substep (their
    angle turned, divided by its length), by the scenario's integrator.

    :param lib: the firmware library (its numeric mode is the loop's).
    :param params: see :class:`WheelLoop`.
    :param motor: see :class:`WheelLoop`.
    """

    def __init__(
        self, lib: Library, params: WheelParams | None = None, motor: Motor | None = None
    ) -> None:
        self.loop = WheelLoop(lib, params, motor)
        self.state = self.loop.advance(0.0, 0.0, 0)
        self.load = (0.0, 0.0)
        """Torque against each wheel's forward motion [N·m]."""
        self.record = 0
        """Substeps still to record in :attr:`speeds` (0: none)."""
        self.speeds: list[tuple[float, float]] = []
        """The true wheel speeds at the end of each recorded substep [rad/s]."""
        self.commands: list[tuple[float, float]] = []
        """The setpoints of each recorded period (one per :meth:`drive`)."""

    @property
    def measured(self) -> tuple[float, float]:
        """The wheel loop's measured speeds at the end of the last period."""
        return self.state.measured

    @property
    def address(self) -> int:
        """Where their wheel loop is (:attr:`WheelLoop.address`): for a
        firmware instance that measures them as its own."""
        return self.loop.address

    def drive(self, plant: UnicyclePlant, left: float, right: float, dt: float) -> None:
        """See :meth:`mstc.plant.plant.WheelDrive.drive`."""
        dt_us = round(dt * 1e6)
        n = max(1, -(-dt_us // SUBSTEP_US))
        r, track, integrator = plant.wheel_radius, plant.track_width, plant.integrator
        pose = plant.pose
        state = self.state
        done = 0
        if self.record > 0:
            self.commands.append((left, right))
        for k in range(1, n + 1):
            h_us = dt_us * k // n - done
            done += h_us
            before = state.angle
            state = self.loop.advance(left, right, h_us, self.load)
            if self.record > 0:
                self.speeds.append(state.speed)
                self.record -= 1
            h = h_us * 1e-6
            mean_l = (state.angle[0] - before[0]) / h
            mean_r = (state.angle[1] - before[1]) / h
            v, w = body_velocity(mean_l, mean_r, r, track)
            pose = integrate(pose, v, w, h, integrator)
        plant.pose = pose
        self.state = state


@dataclass(frozen=True)
class LoopFigures:
    """How a wheel loop followed its commands at the start of a run
    (:func:`loop_figures`), each wheel's figure (left, right)."""

    rise_63_ms: tuple[float, float]
    """When the wheel first reached 63 % of the command in force [ms], from
    the first control step, interpolated between periods."""
    rise_90_ms: tuple[float, float]
    """... 90 % of it [ms]."""
    track_max: tuple[float, float]
    """The largest |ω − r| [rad/s], r the commands ramped at wheel_accel as
    the loop ramps its setpoint."""
    track_rms: tuple[float, float]
    """The RMS of ω − r [rad/s]."""

    def as_dict(self) -> dict[str, list[float]]:
        """Each figure as [left, right], rounded for a report."""
        return {f.name: [round(v, 4) for v in getattr(self, f.name)] for f in fields(self)}


def loop_figures(
    speeds: Sequence[tuple[float, float]],
    commands: Sequence[tuple[float, float]],
    per_step: int,
    accel: float,
    period_s: float = SUBSTEP_US * 1e-6,
) -> LoopFigures:
    """The step response and ramp tracking of a wheel loop from its wheels'
    true speeds @p speeds (after each loop period of @p period_s, from the
    first control step on) and the control step's commands @p commands, each
    in force for @p per_step periods: the same figures from a board's motors
    under QEMU and from the simulation's (docs/hil.md).

    The reference r is each command ramped at @p accel [rad/s²], a step of
    accel·period a period from 0, as ``whl_step`` ramps its setpoint
    (firmware/wheel/whl.c); a rise is timed against the command in force at
    each period, in the command's direction.

    :raises ValueError: fewer commands than the speeds need, or no speeds.
    """
    if not speeds or len(commands) * per_step < len(speeds):
        raise ValueError(f"{len(speeds)} periods of speeds, {len(commands)} commands")
    step = accel * period_s
    figures: dict[str, list[float]] = {"r63": [], "r90": [], "max": [], "rms": []}
    for wheel in (0, 1):
        r = 0.0
        rise = {0.63: math.nan, 0.9: math.nan}
        worst, sq = 0.0, 0.0
        before = 0.0  # the share of the command reached at the last period
        for i, pair in enumerate(speeds):
            w = pair[wheel]
            c = commands[i // per_step][wheel]
            r += min(max(c - r, -step), step)
            e = w - r
            worst, sq = max(worst, abs(e)), sq + e * e
            reached = w / c if c != 0.0 else 0.0
            for share in rise:
                if math.isnan(rise[share]) and reached >= share:
                    # Interpolated between this period and the last: the
                    # figures are finer than a period.
                    frac = (share - before) / (reached - before) if reached > before else 1.0
                    rise[share] = (i + frac) * period_s * 1e3
            before = reached
        figures["r63"].append(rise[0.63])
        figures["r90"].append(rise[0.9])
        figures["max"].append(worst)
        figures["rms"].append(math.sqrt(sq / len(speeds)))
    pair2 = {k: (v[0], v[1]) for k, v in figures.items()}
    return LoopFigures(pair2["r63"], pair2["r90"], pair2["max"], pair2["rms"])


def wheels_for(scenario: Scenario, lib: str | Path | None) -> DcWheels | None:
    """The wheels @p scenario's ``[actuator]`` asks for: :class:`DcWheels` on
    the firmware library @p lib for "dc", their loop ramping at the
    scenario's wheel_accel (what the firmware is told they can do), None for
    the ideal ones."""
    if scenario.actuator.model != "dc":
        return None
    params = replace(WheelParams.defaults(), accel=scenario.params.wheel_accel)
    return DcWheels(Library.open(lib), params)
