# SPDX-License-Identifier: MIT
"""``python -m mstc_sim``: see :mod:`mstc_sim.cli`."""

from mstc_sim.cli import main

raise SystemExit(main())
