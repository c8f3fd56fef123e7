"""Every output on every log of ``../shared/px4_sih_dev`` and ``px4_sih_dev_load`` (PX4 SIH simulated
flights) (``tests/output_checks.py``): each log diagnosed once through the library; the terminal
with --windows, JSON, CSV, HTML, the --db store and the fleet page's flight page drawn from that one
result, all saying the same verdict, in the words of its cause; and ``fdlog diagnose`` run as a user
runs it on one log of each dataset (a healthy and an uncertain one), for its exit code; then `fdlog
history` and the fleet pages over the stores the logs filled. Skipped, saying so, where ../shared is
absent."""
from __future__ import annotations

from output_checks import dataset_tests

DATASETS = ('px4_sih_dev', 'px4_sih_dev_load')
#: Logs run through the installed CLI (a process each): exit 0 and 1.
CLI_LOGS = (
    'px4_sih_dev/logs/sih_004.ulg',
    'px4_sih_dev_load/A_default_com_m1.ulg',
)


(test_every_output_of_the_log, test_history_and_the_fleet_pages_of_those_logs,
 test_the_cli_exit_code) = dataset_tests(DATASETS, CLI_LOGS)
