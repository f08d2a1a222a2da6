# SPDX-License-Identifier: MIT
"""Controller parameters: Table 1 of the paper and the wheel geometry.

The defaults are the limits table's (``firmware/ctrl/ctl_params.toml``,
:mod:`mstc.limits`), the same the firmware's ``ctl_params_default`` is
generated from.
"""

from dataclasses import dataclass

from mstc.limits import load_table


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

    def safe_distance(self, radius: float) -> float:
        """D_s for an obstacle of ``radius`` [m]: moved out by (radius − R_ob),
        so the clearance to its surface is the one Table 1 gives for R_ob
        (the firmware's supervisor does the same, sup.h)."""
        return self.d_s + radius - self.r_ob

    def activation_distance(self, radius: float) -> float:
        """D_act for an obstacle of ``radius`` [m], moved out like :meth:`safe_distance`."""
        return self.d_act + radius - self.r_ob
