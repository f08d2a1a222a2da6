# SPDX-License-Identifier: MIT
"""Controller parameters: Table 1 of the paper and the wheel geometry."""

from dataclasses import dataclass


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
