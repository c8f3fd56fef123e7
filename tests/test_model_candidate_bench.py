"""benchmarks/model_candidate.py scores verdicts as the results page reads them: a damaged verdict
is right only when it names a damaged motor, an uncertain one is counted apart, the model alone
by its window majority."""
from __future__ import annotations

import sys

from conftest import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))
import model_candidate as mc  # noqa: E402


def _rec(status, motors, truth, model_alone, log="x.ulg", set_name="px4_sih_dev_load"):
    return {"set": set_name, "profile": "none", "log": log, "status": status, "motor": motors[0] if motors else None,
            "motors": motors, "inspect": [], "truth": truth, "model_alone": model_alone}


def test_summary_counts_right_motors_and_false_alarms():
    recs = [_rec("damaged", [2], (2,), 2), _rec("damaged", [3], (2,), 0), _rec("uncertain", [2], (2,), 1),
            _rec("healthy", [], (2,), 0), _rec("damaged", [1], None, 1), _rec("healthy", [], None, 0)]
    s = mc.summary(recs)
    dmg, hea = s[("px4_sih_dev_load", "none", "damaged")], s[("px4_sih_dev_load", "none", "healthy")]
    assert (dmg["n"], dmg["damaged"], dmg["uncertain"], dmg["healthy"]) == (4, 2, 1, 1)
    assert (dmg["d right"], dmg["u right"], dmg["model"]) == (1, 1, 1)  # the wrong motor and the miss are not right
    assert (hea["n"], hea["damaged"], hea["healthy"], hea["model"]) == (2, 1, 1, 1)  # a false alarm, by both


def test_profile_kinds_and_groups():
    assert mc._kind("none") == "none"
    assert mc._kind("rrc_g1 no-adapt") == "no-adapt" and mc._kind("rrc_g1 adapted") == "adapted"
    assert mc.group_of("rrc_straight", "25_mm_cut_straight_line_1.BIN") == "25 mm"
    assert mc.group_of("rrc_straight", "good_prop_straight_line_2.BIN") == "good"
