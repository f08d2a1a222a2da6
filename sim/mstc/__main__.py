# SPDX-License-Identifier: MIT
"""``python -m mstc``: the same as the ``mstc`` command (:mod:`mstc.cli`)."""

from mstc.cli import main

raise SystemExit(main())
