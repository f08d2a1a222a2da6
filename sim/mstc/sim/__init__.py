# SPDX-License-Identifier: MIT
"""The kinematic plant, the reference robot, the range sensor, scenario files
and the closed loop."""
