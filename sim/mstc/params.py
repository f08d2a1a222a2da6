# SPDX-License-Identifier: MIT
"""Controller parameters: Table 1 of the paper, the wheel geometry and the
switching strategy.

The defaults are the limits table's (``firmware/ctrl/ctl_params.toml``,
:mod:`mstc.limits`), the same the firmware's ``ctl_params_default`` is
generated from.
"""

from collections.abc import Mapping
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import Any

from mstc.limits import load_table


class Strategy(StrEnum):
    """Which switching strategy the firmware runs (ctl_params_t.strategy). The
    values are the names of the DBC's global value table Strategy, which gives
    their numbers on the wire and the in-process ABI (:mod:`mstc.can.dbc`)."""

    PAPER = "paper"
    """The paper's switch strategy, exactly (section 4)."""
    MSTC = "mstc"
    """mstc's own strategy (docs/strategy.md; the firmware default)."""


def _default(name: str) -> float:
    return load_table().by_name(name).default


@dataclass(frozen=True)
class Params:
    """Every parameter the controller takes (ctl_params_t), SI units.

    The defaults are Table 1 of the paper, with wheel limits high enough that
    the paper's scenarios never saturate (they peak near 32 rad/s). The
    firmware's max_wheel_decel is not here: a scenario cannot set it (it
    keeps the firmware's default, docs/safety.md).
    """

    r_m: float = _default("R_m")
    """Robot radius R_m [m]."""
    r_ob: float = _default("R_ob")
    """Default obstacle radius R_ob [m]."""
    d_det: float = _default("D_det")
    """Sensor range D_det [m]."""
    d_act: float = _default("D_act")
    """Activation distance D_act [m]."""
    d_s: float = _default("D_s")
    """Safe distance D_s [m]."""
    tracking_gains: tuple[float, float, float] = (
        _default("trk_k1"),
        _default("trk_k2"),
        _default("trk_k3"),
    )
    """k1, k2, k3 of eq. (2)-(3)."""
    avoidance_gains: tuple[float, float] = (_default("avd_k1"), _default("avd_k2"))
    """k1, k2 of eq. (23)-(24)."""
    wheel_radius: float = _default("wheel_radius")
    """r [m]."""
    track_width: float = _default("track_width")
    """L, distance between the wheels [m]."""
    max_wheel_speed: float = _default("max_wheel_speed")
    """Largest |wheel angular speed| [rad/s]."""
    strategy: Strategy = Strategy.MSTC
    """Switching strategy; the paper's scenario files select ``paper``."""
    wheel_accel: float = _default("wheel_accel")
    """What the wheels can do [rad/s²] ("mstc" limits its commands to it)."""
    wheel_tau: float = _default("wheel_tau")
    """The wheels' lag to their command, delays included [s]."""

    def safe_distance(self, radius: float) -> float:
        """D_s for an obstacle of ``radius`` [m]: moved out by (radius − R_ob),
        so the clearance to its surface is the one Table 1 gives for R_ob
        (the firmware's supervisor does the same, sup.h)."""
        return self.d_s + radius - self.r_ob

    def activation_distance(self, radius: float) -> float:
        """D_act for an obstacle of ``radius`` [m], moved out like :meth:`safe_distance`."""
        return self.d_act + radius - self.r_ob


PARAM_NAMES: dict[str, tuple[str, int | None]] = {
    "R_m": ("r_m", None),
    "R_ob": ("r_ob", None),
    "D_det": ("d_det", None),
    "D_act": ("d_act", None),
    "D_s": ("d_s", None),
    "trk_k1": ("tracking_gains", 0),
    "trk_k2": ("tracking_gains", 1),
    "trk_k3": ("tracking_gains", 2),
    "avd_k1": ("avoidance_gains", 0),
    "avd_k2": ("avoidance_gains", 1),
    "wheel_radius": ("wheel_radius", None),
    "track_width": ("track_width", None),
    "max_wheel_speed": ("max_wheel_speed", None),
    "wheel_accel": ("wheel_accel", None),
    "wheel_tau": ("wheel_tau", None),
}
"""The parameters the Python side sets and reads, by their name in the DBC's
PARAM_SET_index value table: the :class:`Params` field of each, and the
element for a gain. Their index numbers are the DBC's (:mod:`mstc.can.dbc`);
scenario files use the same names for the scalar ones (docs/scenarios.md)."""


def param_values(p: Params) -> dict[str, float]:
    """Every parameter of @p p by its :data:`PARAM_NAMES` name."""
    values = {}
    for name, (field, element) in PARAM_NAMES.items():
        value = getattr(p, field)
        values[name] = float(value if element is None else value[element])
    return values


def with_param_values(p: Params, values: Mapping[str, float]) -> Params:
    """@p p with the parameters of @p values (by :data:`PARAM_NAMES` name) set;
    names not there are ignored."""
    changes: dict[str, Any] = {}
    for name, value in values.items():
        if name not in PARAM_NAMES:
            continue
        field, element = PARAM_NAMES[name]
        if element is None:
            changes[field] = value
        else:
            gains = list(changes.get(field, getattr(p, field)))
            gains[element] = value
            changes[field] = tuple(gains)
    return replace(p, **changes)
