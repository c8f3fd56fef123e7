"""Every output on every log of ``../shared/ardupilot_sitl_hexa`` and ``ardupilot_sitl_quad``
(ArduCopter SITL: stopped motors, a weak motor with ESC telemetry) (``tests/output_checks.py``):
each log diagnosed once through the library; the terminal with --windows, JSON, CSV, HTML, the --db
store and the fleet page's flight page drawn from that one result, all saying the same verdict, in
the words of its cause; and ``fdlog diagnose`` run as a user runs it on the weak-motor log and a
stopped motor, for its exit code; then `fdlog history` and the fleet pages over the stores the logs
filled. Skipped, saying so, where ../shared is absent."""
from __future__ import annotations

from output_checks import dataset_tests

DATASETS = ('ardupilot_sitl_hexa', 'ardupilot_sitl_quad')
#: Logs run through the installed CLI (a process each): a damaged verdict whose cause is the motor or ESC, and a stopped motor.
CLI_LOGS = (
    'ardupilot_sitl_quad/motor1_weak_esc.BIN',
    'ardupilot_sitl_hexa/hexa_cwx_m1.bin',
)


(test_every_output_of_the_log, test_history_and_the_fleet_pages_of_those_logs,
 test_the_cli_exit_code) = dataset_tests(DATASETS, CLI_LOGS)
