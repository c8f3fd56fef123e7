"""Every output on every log of ``../shared/crazypad_e9`` and ``crazypad_e9_load`` (real CrazyPAD
flights: no horizontal accelerometer, a 100 Hz gyro; every HTML report failed on them before)
(``tests/output_checks.py``): each log diagnosed once through the library; the terminal with
--windows, JSON, CSV, HTML, the --db store and the fleet page's flight page drawn from that one
result, all saying the same verdict, in the words of its cause; and ``fdlog diagnose`` run as a user
runs it on one log of each dataset, for its exit code; then `fdlog history` and the fleet pages over
the stores the logs filled. Skipped, saying so, where ../shared is absent."""
from __future__ import annotations

from output_checks import dataset_tests

DATASETS = ('crazypad_e9', 'crazypad_e9_load')
#: Logs run through the installed CLI (a process each): one log of each dataset.
CLI_LOGS = (
    'crazypad_e9/ulog/cut_m3_2mm_2mm__E9_log00.ulg',
    'crazypad_e9_load/ulog/add_weight_W1_near_M3__E9_log00.ulg',
)


(test_every_output_of_the_log, test_history_and_the_fleet_pages_of_those_logs,
 test_the_cli_exit_code) = dataset_tests(DATASETS, CLI_LOGS)
