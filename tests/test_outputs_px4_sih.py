"""Every output on every log of ``../shared/px4_sih_dev`` and ``px4_sih_dev_load`` (PX4 SIH simulated
flights) (``tests/output_checks.py``): each log diagnosed once through the library; the terminal
with --windows, JSON, CSV, HTML, the --db store and the fleet page's flight page drawn from that one
result, all saying the same verdict, in the words of its cause; and ``fdlog diagnose`` run as a user
runs it on one log of each dataset (a healthy and an uncertain one), for its exit code; then `fdlog
history` and the fleet pages over the stores the logs filled. Skipped, saying so, where ../shared is
absent."""
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
    assert every_output.check(path) == []


def test_history_and_the_fleet_pages_of_those_logs(every_output):
    """After the logs above (same file, same store): `fdlog history` lists each, the fleet and
    airframe pages draw."""
    logs = [p.values[0] for p in shared_log_params(*DATASETS) if p.values[0] is not None]
    if not logs:
        pytest.skip("../shared not available")
    assert every_output.history_problems(logs) == []


@pytest.mark.parametrize("rel", CLI_LOGS)
def test_the_cli_exit_code(rel, tmp_path):
    path = SHARED / rel
    if not path.is_file():
        pytest.skip(f"../shared/{rel} not available")
    assert cli_exit_problems(path, tmp_path) == []
