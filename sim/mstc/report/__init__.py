# SPDX-License-Identifier: MIT
"""What a run leaves behind: outputs on disk (:mod:`~mstc.report.outputs`),
the report table (:mod:`~mstc.report.table`), figures
(:mod:`~mstc.report.plots`), what ``mstc plot`` makes of a bus log
(:mod:`~mstc.report.logplot`), and progress bars
(:mod:`~mstc.report.progress`)."""
