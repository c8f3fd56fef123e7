"""Analyzers: one module per evidence source over one flight, each returning typed per-motor findings.

So far: :mod:`flightlog_fd.analyzers.esc` (ESC telemetry: rpm per command, current per rpm²).
The registry and the decision model that weighs the findings come with issue 15/17's lead work.
"""
