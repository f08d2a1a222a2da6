# SPDX-License-Identifier: MIT
"""The plant: the robot moved by its wheels (:mod:`~mstc.plant.plant`), the
paper's reference robot (:mod:`~mstc.plant.reference`), the range sensor
(:mod:`~mstc.plant.sensor`), scenario files (:mod:`~mstc.plant.scenario`) and
the world a scenario makes of them (:mod:`~mstc.plant.world`). It knows
neither the firmware nor the wire: the loops (:mod:`mstc.loop`) drive it."""
