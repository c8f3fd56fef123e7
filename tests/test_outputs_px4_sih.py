"""Every output on every log of ``../shared/px4_sih_dev`` and ``px4_sih_dev_load`` (PX4 SIH simulated
flights) (``tests/output_checks.py``): each log diagnosed once through the library; the terminal
with --windows, JSON, CSV, HTML, the --db store and the fleet page's flight page drawn from that one
result, all saying the same verdict, in the words of its cause; and ``fdlog diagnose`` run as a user
runs it on one log of each dataset (a healthy and an uncertain one), for its exit code. Skipped,
saying so, where ../shared is absent."""
from __future__ import annotations

import pytest
from output_checks import SHARED, cli_exit_problems, shared_log_params

DATASETS = ('px4_sih_dev', 'px4_sih_dev_load')
#: Logs run through the installed CLI (a process each): exit 0 and 1.
CLI_LOGS = (
    'px4_sih_dev/logs/sih_004.ulg',
    'px4_sih_dev_load/A_default_com_m1.ulg',
)


@pytest.mark.parametrize("path", shared_log_params(*DATASETS))
def test_every_output_of_the_log(path, every_output):
    assert every_output(path) == []


@pytest.mark.parametrize("rel", CLI_LOGS)
def test_the_cli_exit_code(rel, tmp_path):
    path = SHARED / rel
    if not path.is_file():
        pytest.skip(f"../shared/{rel} not available")
    assert cli_exit_problems(path, tmp_path) == []
