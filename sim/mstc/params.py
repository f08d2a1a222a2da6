# SPDX-License-Identifier: MIT
"""Controller parameters: Table 1 of the paper and the wheel geometry."""

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any


@dataclass(frozen=True)
class Params:
    """Every parameter the controller takes (ctl_params_t), SI units.

    The defaults are Table 1 of the paper, with wheel limits high enough that
    the paper's scenarios never saturate (they peak near 32 rad/s).
    """

    r_m: float = 0.2
    """Robot radius R_m [m]."""
    r_ob: float = 0.1
    """Default obstacle radius R_ob [m]."""
    d_det: float = 3.5
    """Sensor range D_det [m]."""
    d_act: float = 0.5
    """Activation distance D_act [m]."""
    d_s: float = 0.35
    """Safe distance D_s [m]."""
    tracking_gains: tuple[float, float, float] = (3.0, 12.0, 6.0)
    """k1, k2, k3 of eq. (2)-(3)."""
    avoidance_gains: tuple[float, float] = (3.0, 6.0)
    """k1, k2 of eq. (23)-(24)."""
    wheel_radius: float = 0.05
    """r [m]."""
    track_width: float = 0.3
    """L, distance between the wheels [m]."""
    max_wheel_speed: float = 100.0
    """Largest |wheel angular speed| [rad/s]."""

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
