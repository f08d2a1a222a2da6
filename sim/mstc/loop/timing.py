# SPDX-License-Identifier: MIT
"""Timing of a real-time run, measured from what crossed the bus (timing.json).

The real-time loop (:mod:`mstc.loop.realtime`) records every ODOM_XY frame it
sent (:class:`OdomSent`) and every control step the firmware reported
(:class:`FirmwareStep`: its WHEEL_CMD, with the STATUS and STATUS_TRK that
came before it), each stamped with the plant's clock. :func:`analyse` turns
them into :class:`Timing`:

- **period**: the interval between consecutive WHEEL_CMD arrivals;
- **latency**: from sending an ODOM_XY frame to the arrival of the first
  WHEEL_CMD computed from it. The firmware echoes the alive counter of the
  ODOM_XY frame each step used in STATUS_TRK_odom_counter, so the pairing is
  exact, whatever the phase between the two clocks;
- **missed periods**: an interval of about n periods (n ≥ 2, rounded) where
  the WHEEL_CMD step counter advanced by fewer than n: n − advance periods
  without a step (an interval of n periods with a counter advance of n means
  lost frames, counted as such); **doubled periods**: two steps less than half
  a period apart;
- **stale steps**: steps that reused odometry an earlier step had used (no
  new frame reached the firmware in that period); **unused odometry**: frames
  no step used (two reached the firmware in one period);
- the plant's own missed periods (its loop was late by a whole period and
  skipped a sample) and the frames each side dropped.

Times are in seconds from the run's start (sample 0) unless named ``_ms``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mstc.model import Event, Status

STEP_MODULO = 1 << 16
"""The WHEEL_CMD step counter wraps here."""
MISSED_FACTOR = 1.5
"""An interval longer than this many periods holds a missed period."""
DOUBLED_FACTOR = 0.5
"""An interval shorter than this many periods is a doubled period."""


@dataclass(frozen=True)
class OdomSent:
    """An ODOM_XY frame the plant sent."""

    t: float
    """When it was sent [s]."""
    counter: int
    """Its alive counter."""
    sample: int | None
    """The plant sample it belongs to; None for the frames sent while arming,
    which carry the initial pose (the pose of sample 0)."""


@dataclass(frozen=True)
class FirmwareStep:
    """One control step of the firmware, as the plant saw it."""

    t: float
    """Arrival of its WHEEL_CMD, the step's last frame [s]."""
    step: int
    """WHEEL_CMD_step."""
    left: float
    """Wheel speed commands [rad/s]."""
    right: float
    status: Status | None
    """From its STATUS and STATUS_TRK; None when either was lost."""
    halt: int | None
    """STATUS_halt (0 running); None when the STATUS was lost."""
    odom: int | None
    """Index in the run's :class:`OdomSent` list of the ODOM_XY frame the step
    used (the latest frame sent with the echoed counter); None when its
    STATUS_TRK was lost or no such frame was sent."""
    events: tuple[Event, ...] = ()
    """Its events, stamped with the firmware's own time."""


@dataclass(frozen=True)
class Stats:
    """Summary of a series [ms]."""

    n: int
    mean: float
    p50: float
    p99: float
    max: float
    min: float

    @classmethod
    def of(cls, values_ms: Sequence[float]) -> Stats:
        """Mean, median, 99th percentile (linear interpolation), extremes;
        NaN for an empty series."""
        if not values_ms:
            nan = math.nan
            return cls(0, nan, nan, nan, nan, nan)
        a = np.asarray(values_ms, dtype=float)
        p50, p99 = np.percentile(a, [50, 99])
        return cls(len(a), float(a.mean()), float(p50), float(p99), float(a.max()), float(a.min()))

    def to_json(self) -> dict[str, float | int | None]:
        """Rounded to the µs; NaN as null."""
        return {
            k: (None if isinstance(v, float) and math.isnan(v) else round(v, 3))
            for k, v in vars(self).items()
        }


@dataclass(frozen=True)
class CommLoss:
    """What happened after the plant stopped sending odometry."""

    stopped_at: float
    """Time of the first sample sent without odometry [s]."""
    last_odometry: float | None
    """When the last ODOM_XY frame was sent [s]."""
    last_step: int | None
    """WHEEL_CMD_step of the first step that used it: the last on live odometry."""
    last_step_t: float | None
    halt_step: int | None
    """The first step after it that reported a halt."""
    halt_t: float | None
    halt_reason: int | None
    """Its STATUS_halt (2: odometry)."""
    ramp: tuple[tuple[float, float, float], ...]
    """(t [s], left, right [rad/s]) of every wheel command from the last step
    on live odometry to the first at zero, both included."""

    @property
    def halt_after_steps(self) -> int | None:
        """Control steps from the last step on live odometry to the halt."""
        if self.halt_step is None or self.last_step is None:
            return None
        return (self.halt_step - self.last_step) % STEP_MODULO

    @property
    def halt_after(self) -> float | None:
        """Wall time from the last step on live odometry to the halt [s]."""
        if self.halt_t is None or self.last_step_t is None:
            return None
        return self.halt_t - self.last_step_t

    def to_json(self) -> dict[str, object]:
        """The record in timing.json."""

        def r(x: float | None) -> float | None:
            return None if x is None else round(x, 6)

        after = self.halt_after
        return {
            "stopped_at_s": r(self.stopped_at),
            "last_odometry_s": r(self.last_odometry),
            "last_step": self.last_step,
            "last_step_s": r(self.last_step_t),
            "halt_step": self.halt_step,
            "halt_s": r(self.halt_t),
            "halt_reason": self.halt_reason,
            "halt_after_steps": self.halt_after_steps,
            "halt_after_ms": None if after is None else round(after * 1e3, 3),
            "ramp": [[round(t, 6), left, right] for t, left, right in self.ramp],
        }


@dataclass(frozen=True)
class Timing:
    """The timing of a real-time run (timing.json)."""

    rate_hz: float
    """The plant's sample rate; the firmware's control rate is the same."""
    period: Stats
    """Interval between WHEEL_CMD arrivals [ms]."""
    latency: Stats
    """ODOM_XY sent → first WHEEL_CMD computed from it arrived [ms]."""
    steps: int
    """Firmware steps in the run."""
    missed: int
    """Control periods without a step."""
    doubled: int
    """Steps less than half a period after the previous one."""
    wheel_cmd_lost: int
    """WHEEL_CMD frames missing from the step counter's sequence."""
    stale: int
    """Steps on odometry an earlier step had used."""
    samples: int
    """Plant samples sent."""
    plant_missed: int
    """Samples the plant skipped because its loop was a whole period late."""
    unused: int
    """ODOM_XY frames no step used."""
    send_failures: int
    """Frames the plant could not send (bus error, full queue)."""
    dropped_by_firmware: dict[str, int]
    """STATUS_COUNTERS at the end less at the start of the run, by reason."""
    dropped_by_plant: dict[str, int]
    """Frames the plant's E2E checks dropped, by reason."""
    period_series: tuple[tuple[float, float], ...] = ()
    """(arrival [s], interval [ms]) of each WHEEL_CMD after the first."""
    latency_series: tuple[tuple[float, float], ...] = ()
    """(sent [s], latency [ms]) of each ODOM_XY frame a step used."""
    comm_loss: CommLoss | None = None
    """Set when the plant stopped sending odometry (a comm-loss trial)."""
    phase: float | None = None
    """Where the plant put its samples within the firmware's period (a
    fraction after a WHEEL_CMD arrival); None when not aligned."""
    extra: dict[str, object] = field(default_factory=dict)
    """More of the run, as is: ``start_stamp``, the run's start in bus.log's
    time stamps [s]; ``plant_cpu_ms_per_sample``, the plant process's CPU
    time over the run per sample [ms]; ``bridge``, what crossed the vcan VM's
    bridge (:meth:`mstc.can.vmbridge.Bridge.tally`), when the run went
    through it."""

    @property
    def period_s(self) -> float:
        """The nominal control period [s]."""
        return 1.0 / self.rate_hz

    def to_json(self) -> dict[str, object]:
        """The document written as timing.json."""
        doc: dict[str, object] = {
            "rate_hz": self.rate_hz,
            "period_ms": round(1e3 / self.rate_hz, 6),
            "phase": self.phase,
            "wheel_cmd_period_ms": self.period.to_json(),
            "latency_ms": self.latency.to_json(),
            "firmware": {
                "steps": self.steps,
                "missed_periods": self.missed,
                "doubled_periods": self.doubled,
                "wheel_cmd_lost": self.wheel_cmd_lost,
                "stale_steps": self.stale,
            },
            "plant": {
                "samples": self.samples,
                "missed_periods": self.plant_missed,
                "odometry_unused": self.unused,
                "send_failures": self.send_failures,
            },
            "dropped": {"by_firmware": self.dropped_by_firmware, "by_plant": self.dropped_by_plant},
            **self.extra,
        }
        if self.comm_loss is not None:
            doc["comm_loss"] = self.comm_loss.to_json()
        doc["series"] = {
            "period": [[round(t, 6), round(ms, 3)] for t, ms in self.period_series],
            "latency": [[round(t, 6), round(ms, 3)] for t, ms in self.latency_series],
        }
        return doc

    def describe(self) -> str:
        """One line for the report."""
        p, lat = self.period, self.latency
        bridge = self.extra.get("bridge")
        crossed = bridge if isinstance(bridge, dict) else {}
        dropped = {
            **_prefixed("fw ", self.dropped_by_firmware),
            **_prefixed("plant ", self.dropped_by_plant),
            **_prefixed("bridge ", {k: v for k, v in crossed.items() if k.startswith("dropped")}),
        }
        return (
            f"WHEEL_CMD every {p.mean:.2f} ms (p50 {p.p50:.2f}, p99 {p.p99:.2f}, "
            f"max {p.max:.2f}); latency odometry→command {lat.p50:.2f} ms p50 "
            f"(p99 {lat.p99:.2f}, max {lat.max:.2f}); periods missed {self.missed}, "
            f"doubled {self.doubled}, plant missed {self.plant_missed}; stale steps "
            f"{self.stale}; frames dropped: {dropped or 'none'} (timing.json)"
        )


def _prefixed(prefix: str, counts: dict[str, int]) -> dict[str, int]:
    return {f"{prefix}{k}": v for k, v in counts.items() if v}


def _comm_loss(
    stopped_at: float, odometry: Sequence[OdomSent], steps: Sequence[FirmwareStep]
) -> CommLoss:
    sent_before = [i for i, o in enumerate(odometry) if o.t < stopped_at]
    last = sent_before[-1] if sent_before else None
    first_use = next((s for s in steps if last is not None and s.odom == last), None)
    after = [s for s in steps if first_use is not None and s.t > first_use.t]
    halt = next((s for s in after if s.halt not in (0, None)), None)
    ramp: list[tuple[float, float, float]] = []
    if first_use is not None:
        for s in (first_use, *after):
            ramp.append((s.t, s.left, s.right))
            if s.left == 0.0 and s.right == 0.0:
                break
    return CommLoss(
        stopped_at=stopped_at,
        last_odometry=odometry[last].t if last is not None else None,
        last_step=first_use.step if first_use else None,
        last_step_t=first_use.t if first_use else None,
        halt_step=halt.step if halt else None,
        halt_t=halt.t if halt else None,
        halt_reason=halt.halt if halt else None,
        ramp=tuple(ramp),
    )


def analyse(
    rate_hz: float,
    odometry: Sequence[OdomSent],
    steps: Sequence[FirmwareStep],
    *,
    samples: int,
    plant_missed: int = 0,
    send_failures: int = 0,
    dropped_by_firmware: dict[str, int] | None = None,
    dropped_by_plant: dict[str, int] | None = None,
    odometry_stopped_at: float | None = None,
    phase: float | None = None,
) -> Timing:
    """The timing of a run from its records.

    :param rate_hz: the control rate.
    :param odometry: every ODOM_XY frame sent, in order.
    :param steps: every firmware step seen, in order of arrival. Those that
        arrived before the run's start (t < 0: arming) only serve to tell
        which odometry was used.
    :param samples: plant samples sent in the run.
    :param odometry_stopped_at: the time of the first sample sent without
        odometry, for a comm-loss trial.
    """
    period = 1.0 / rate_hz
    # The run's steps: from its start to the first that used the last
    # odometry sent (the loop listens a little longer, for that one; a
    # comm-loss trial keeps all: the firmware's steps after the cut are the
    # point).
    end = math.inf
    if odometry_stopped_at is None and odometry:
        last = len(odometry) - 1
        end = next((s.t for s in steps if s.odom == last), math.inf)
    run = [s for s in steps if 0.0 <= s.t <= end]
    intervals: list[tuple[float, float]] = []
    missed = doubled = lost = 0
    for prev, cur in zip(run, run[1:], strict=False):
        d = cur.t - prev.t
        advance = (cur.step - prev.step) % STEP_MODULO
        intervals.append((cur.t, d * 1e3))
        lost += max(advance - 1, 0)
        if d > MISSED_FACTOR * period:
            missed += max(round(d / period) - max(advance, 1), 0)
        elif d < DOUBLED_FACTOR * period:
            doubled += 1

    first_use: dict[int, FirmwareStep] = {}
    stale = 0
    live_until = end if odometry_stopped_at is None else odometry_stopped_at
    for s in steps:
        if s.odom is None:
            continue
        if s.odom in first_use:
            # Once odometry stops on purpose every step is stale: not counted.
            stale += 0.0 <= s.t <= live_until
        else:
            first_use[s.odom] = s
    latency: list[tuple[float, float]] = []
    unused = 0
    last_used = max(first_use, default=-1)
    for i, o in enumerate(odometry):
        if o.t < 0.0:
            continue  # arming, before the run's start: not part of its timing
        if i in first_use:
            latency.append((o.t, (first_use[i].t - o.t) * 1e3))
        elif i < last_used:
            unused += 1  # a later frame was used: this one was passed over

    return Timing(
        rate_hz=rate_hz,
        period=Stats.of([ms for _, ms in intervals]),
        latency=Stats.of([ms for _, ms in latency]),
        steps=len(run),
        missed=missed,
        doubled=doubled,
        wheel_cmd_lost=lost,
        stale=stale,
        samples=samples,
        plant_missed=plant_missed,
        unused=unused,
        send_failures=send_failures,
        dropped_by_firmware=dict(dropped_by_firmware or {}),
        dropped_by_plant=dict(dropped_by_plant or {}),
        period_series=tuple(intervals),
        latency_series=tuple(latency),
        comm_loss=(
            _comm_loss(odometry_stopped_at, odometry, steps)
            if odometry_stopped_at is not None
            else None
        ),
        phase=phase,
    )
