"""Every output on every log of ``../shared/real_damaged``, ``real_healthy``, ``real_logs`` (truncated,
disarmed, VTOL and old-format logs among them) and ``real_vibration`` (``tests/output_checks.py``):
each log diagnosed once through the library; the terminal with --windows, JSON, CSV, HTML, the --db
store and the fleet page's flight page drawn from that one result, all saying the same verdict, in
the words of its cause; and ``fdlog diagnose`` run as a user runs it on a healthy, two uncertain and
a truncated log, for its exit code; then `fdlog history` and the fleet pages over the stores the
logs filled. Skipped, saying so, where ../shared is absent."""
from __future__ import annotations

from output_checks import dataset_tests

DATASETS = ('real_damaged', 'real_healthy', 'real_logs', 'real_vibration')
#: Logs run through the installed CLI (a process each): exit 0, 1, 1 and 2 (a truncated file: bad input).
CLI_LOGS = (
    'real_healthy/logs/erle_pxf_copter_09-10-2014_25.BIN',
    'real_damaged/rrc_straight/25_mm_cut_straight_line_1.BIN',
    'real_vibration/quad_udesa/udesa_f450_prop13.ulg',
    'real_logs/ardupilot/arducopter46_truncated_80k.bin',
)


(test_every_output_of_the_log, test_history_and_the_fleet_pages_of_those_logs,
 test_the_cli_exit_code) = dataset_tests(DATASETS, CLI_LOGS)
