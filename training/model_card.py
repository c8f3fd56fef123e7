"""Write models/MODEL_CARD.md from the figures `build_default` measured (models/default.json).

    python -m flightlog_fd.training.model_card

The card's numbers are never typed by hand: they come from the JSON that the build wrote next to
the ONNX file (the same summary is inside the ONNX metadata, key "training").
"""
from __future__ import annotations

import json
from pathlib import Path

MODELS = Path(__file__).resolve().parents[1] / "models"
CLASS_NAMES = ["healthy", "motor 1", "motor 2", "motor 3", "motor 4"]


def _pct(x) -> str:
    return "n/a" if x is None else f"{100 * x:.1f} %"


def flight_verdicts() -> dict:
    """Flight verdicts of the shipped model, no profile, on the labelled ../shared sets (if present)."""
    from flightlog_fd.diagnose import diagnose_flight, resolve_model
    from flightlog_fd.errors import FlightLogError
    from flightlog_fd.training.targets import available, crazypad_logs, real_healthy_logs, sih_logs

    model = resolve_model()
    out = {}
    for key, loader in (("px4_sih_dev", sih_logs), ("crazypad_e9", crazypad_logs), ("real_healthy", real_healthy_logs)):
        if not available()[key]:
            continue
        rows = []
        for lg in loader():
            try:
                v = diagnose_flight(lg.load(), model, keep_flight=False).verdict
            except FlightLogError:
                continue
            if v.status == "not_diagnosable":
                continue
            rows.append((lg.truth["label"], v.status, v.motor))
        healthy = [r for r in rows if r[0] == 0]
        damaged = [r for r in rows if r[0] > 0]
        out[key] = {
            "healthy_flights": len(healthy),
            "healthy_right": sum(r[1] == "healthy" for r in healthy),
            "healthy_false_alarm": sum(r[1] == "damaged" for r in healthy),
            "damaged_flights": len(damaged),
            "damaged_right": sum(r[1] == "damaged" and r[2] == r[0] for r in damaged),
            "damaged_wrong_motor": sum(r[1] == "damaged" and r[2] != r[0] for r in damaged),
            "uncertain": sum(r[1] == "uncertain" for r in rows),
            "healthy_uncertain": sum(r[1] == "uncertain" for r in healthy),
        }
    return out


def render(meta: dict, verdicts: dict | None = None) -> str:
    sim = meta["sim_test"]
    L = [
        "# Model card: the shipped default model (`models/default.onnx`)",
        "",
        "**What it is.** The paper's DCNN (4 × [Conv1d k=3, 64 filters, ReLU, max-pool 2], dense 128, "
        "dense 128, dropout 0.1, 5-way softmax) on NIF windows: 80 samples at 50 Hz of the angular "
        "accelerations ṗ, q̇, ṙ (each divided by the flight's robust scale) and the four squared commanded "
        "motor speeds (each divided by the window's mean over the four motors, i.e. thrust shares), then "
        "standardised with the per-channel statistics stored in the file's metadata. Classes: healthy, "
        "propeller 1..4 damaged (the autopilot's motor numbering).",
        "",
        f"**How it was trained.** {meta['data']}. Cross-entropy only (no domain adaptation: there is no "
        f"target airframe), Adam 5e-4, batch 128, {meta['epochs']} epochs (lowest training loss at epoch "
        f"{meta['best_epoch']}), seed {meta['seed']}. Class counts (windows): "
        + ", ".join(f"{n} {c}" for n, c in zip(meta["class_counts"], CLASS_NAMES)) + ".",
        "",
        f"Made by `{meta['command']}` in {meta['train_seconds'] / 60:.0f} min on a 2-core CPU; "
        "`models/default.pt` holds the same weights for `fdlog calibrate` to fine-tune.",
        "",
        "## Measured accuracy",
        "",
        "| data | windows | window accuracy | healthy windows called healthy | damaged windows with the right motor |",
        "|---|---|---|---|---|",
    ]
    conf = sim["confusion"]
    healthy = conf[0][0] / max(1, sum(conf[0]))
    dmg_right = sum(conf[k][k] for k in range(1, 5)) / max(1, sum(sum(conf[k]) for k in range(1, 5)))
    L.append(f"| simulated test flights ({sim['flights']} flights, other seeds, same distribution) | "
             f"{sim['windows']} | {_pct(sim['window_accuracy'])} | {_pct(healthy)} | {_pct(dmg_right)} |")
    names = {"px4_sih_dev": "PX4 SITL (SIH physics), 19 flights, no calibration",
             "crazypad_e9": "CrazyPAD E9 real Crazyflie flights, 42 flights, no calibration",
             "real_healthy": "Real healthy ArduCopter flights (../shared real_healthy + Erle real_logs)"}
    for key, t in meta.get("targets", {}).items():
        L.append(f"| {names.get(key, key)} | {t['n_windows']} | {_pct(t['window_accuracy'])} | "
                 f"{_pct(t['healthy_window_accuracy'])} | {_pct(t['damaged_window_accuracy'])} |")
    if verdicts:
        L += ["", "Flight verdicts without calibration (`fdlog diagnose`, shipped model, no profile):", "",
              "| set | healthy flights called healthy | false alarms on healthy flights | damaged flights, right motor | "
              "damaged, wrong motor | uncertain (any) |", "|---|---|---|---|---|---|"]
        for key, v in verdicts.items():
            L.append(f"| {names.get(key, key).split(',')[0]} | {v['healthy_right']}/{v['healthy_flights']} | "
                     f"{v['healthy_false_alarm']} | {v['damaged_right']}/{v['damaged_flights']} | "
                     f"{v['damaged_wrong_motor']} | {v['uncertain']} |")
        L += ["", "Real healthy flights: every verdict that is not `healthy` is a false alarm or an abstention "
              "(`uncertain`); a `damaged` one sends a pilot to replace a good propeller.",
              "", "Read the CrazyPAD row with its README in mind: this airframe runs motor 2 hardest when healthy "
              "and most of its damage is on motor 2, so a model that says \"motor 2\" whenever it sees that "
              "imbalance scores well on damaged flights while failing healthy ones. "
              + ("Without calibration the shipped model does exactly that on the healthy flights; "
                 if verdicts.get("crazypad_e9", {}).get("healthy_false_alarm") else
                 "This model does not fall into that trap (its healthy flights stay healthy), and its cuts of "
                 "0.5-3 mm barely move the motor commands, so without calibration it names none of them; ")
              + "`fdlog calibrate` on one healthy flight is the way to mild damage (see `results/crazypad_e9.md`)."]
    L += [
        "",
    ]
    cal = meta.get("confidence_calibration")
    if cal:
        L += [f"**Confidence calibration.** Temperature scaling fitted on the held-out simulated flights: "
              f"T = {cal['temperature']:.2f} (stored in the model's metadata and applied by `FaultModel`); "
              f"negative log-likelihood {cal['nll_before']:.3f} → {cal['nll_after']:.3f}, expected calibration "
              f"error (15 bins) {_pct(cal['ece_before'])} → {_pct(cal['ece_after'])}.", ""]
    L += [WHAT_LIMITS_IT, "", TIMELINE_LABELS, ""]
    L += [
        "Confusion on the simulated test flights (rows truth, columns predicted):",
        "",
        "| truth \\ predicted | " + " | ".join(CLASS_NAMES) + " |",
        "|---" * 6 + "|",
    ]
    for k, row in enumerate(conf):
        L.append(f"| {CLASS_NAMES[k]} | " + " | ".join(str(x) for x in row) + " |")
    L += [
        "",
        "## Limits (read before trusting a verdict)",
        "",
        "- Trained on simulation only. It has never seen a real airframe; real quads differ (motor and "
        "propeller differences, frame flex, vibration, estimator behaviour).",
        "- Every training airframe, healthy or damaged, is unbalanced the way real healthy quads are (centre of "
        "mass off the middle, motor tilt / yaw trim, thrust and torque coefficient spread: steady offsets up to "
        "~±0.10 of full scale, measured on real healthy logs), so one motor running high is not damage by "
        "itself. The verdict also asks the per-motor evidence (`flightlog_fd/analyzers/share_fit.py`): without a profile "
        "it confirms a one-motor excess from about η ≈ 0.83 down; milder damage needs `fdlog calibrate` on a "
        "healthy flight of the airframe.",
        "- Windows are 1.6 s; the flight verdict smooths over several seconds and abstains (`uncertain`) when "
        "the evidence is weak or split.",
        "- Quadrotors only (quad-X and quad-+); one damaged propeller at a time.",
        "- Real damaged-propeller data (CrazyPAD) is used only to measure, never to train.",
        "",
    ]
    return "\n".join(L)


#: Measured on the shipped quad model by benchmarks/model_why.py (results/model_why.md); re-measure
#: after retraining.
WHAT_LIMITS_IT = "**What limits it (measured, `results/model_why.md`).** On 320 held-out simulated flights of every logging profile it is right on 64.0 % of windows. Mild damage (eta >= 0.9) is 30 % of the errors (13 % right), eta 0.85-0.9 another large share (36 % right); healthy windows called a motor name the motor running the highest thrust share 76 % of the time, and healthy windows are called healthy 87 % on airframes with little CoG offset but 48 % on the third with the most: without the airframe's own healthy level (a profile) a trim and a damaged propeller look alike in 1.6 s. A classifier on the window's four mean motor shares alone reaches 62.3 %, so the network adds little beyond the steady shares. It memorises its training airframes (83.1 % right on its own training flights), and a moved load makes it call healthy airframes damaged (simulated healthy flights with random loads: healthy windows called healthy 72 % -> 46 %). More airframes, not more epochs or capacity, is what helps (results/model_why.md section 4): a build on 4800 flights x 10 epochs (`python -m flightlog_fd.training.build_default --flights 4800 --test-flights 240 --epochs 10 --duration 50.0 --seed 0`, 13 min) reaches 67.3 % on the same held-out flights, 83.2 % of healthy windows, px4_sih_dev 90.0 % and crazypad_e9 51.6 % without calibration, but is not shipped: with the decision's tables measured for this model it turns 2 of 15 real healthy flights damaged."
#: How the timeline reads this model's probabilities (flightlog_fd/timeline.py LABEL_BARS).
TIMELINE_LABELS = "**Timeline labels.** The temperature T (fitted on one logging profile's held-out flights, pulled up by confidently wrong windows) leaves the window probabilities under-confident in the middle: a smoothed window whose top class has probability 0.3-0.5 is right 57-69 % of the time. The timeline therefore labels a window with its top class from the bar where such windows are right more often than not (`timeline.LABEL_BARS`: healthy 0.25, a motor 0.40 for this model) and shows `?` below it; the decision's inputs (window probabilities, the damage run at 0.5) are unchanged."


#: The card's n-rotor section starts at this line; `--nrotor` rewrites only what follows it.
NROTOR_MARKER = "<!-- n-rotor models: written by python -m flightlog_fd.training.model_card --nrotor -->"
NROTOR_FILES = {6: "default_hexa", 8: "default_octo"}


def render_nrotor(metas: dict, bench: str | None = None) -> str:
    """The card's section on the hexa and octo models from their build summaries (models/*.json)
    and, if given, the text `benchmarks/bench_nrotor.py` printed."""
    L = [NROTOR_MARKER, "", "# The hexa and octo models (`models/default_hexa.onnx`, `models/default_octo.onnx`)", "",
         "**What they are.** The same DCNN on NIF windows with n motor channels: ṗ, q̇, ṙ and w1²..wn² "
         "(n + 3 channels), n + 1 classes (healthy, propeller 1..n damaged, ArduPilot's motor numbering of "
         "the trained tables). The ONNX metadata carries `rotor_count`, `frames`, `classes` and the feature "
         "spec. `fdlog diagnose` picks the model whose rotor count matches the log's frame "
         "(`flightlog_fd.model.model_for_flight`); a hexa or octo frame numbered otherwise (HEXA/H, DJI_X, "
         "CW_X, Y6...) is refused with the reason (`checks.trained_layout`).", "",
         "**How they were trained.** Same recipe as the quad model (`build_default.py --rotors n`: random "
         "airframes 30 g-5 kg with realistic imbalance, real-log noise, strong and mild damage, five logging "
         "profiles, cross-entropy, temperature scaling), with FEWER flights and epochs to fit a budget of "
         "about 15 minutes of torch training per model on one thread of a shared 2-core CPU: training "
         "stopped on the time limit, with the loss still falling, so both models are under-trained against "
         "the quad's.", "",
         "| model | training data | epochs | final training loss | command |", "|---|---|---|---|---|"]
    import re

    for n, meta in sorted(metas.items()):
        cmd = meta["command"]
        prior = re.search(r"--prior-epochs (\d+)", cmd)
        how = f"`{cmd}`"
        if prior:
            first = re.sub(r" --prior-epochs \d+", "", re.sub(r"--max-train-seconds [0-9.]+", "--max-train-seconds 540", cmd))
            how = (f"`{first}` (stopped on its time limit after {prior.group(1)} epochs), then `{cmd} --init` "
                   f"with that run's .pt")
        L.append(f"| {n} rotors | {meta['data']} | {meta['epochs']} | {meta['best_loss']:.3f} | {how} |")
    L += ["", "Held-out simulated flights (200 per model, other seeds, same distribution as training: η 0.55-0.9 "
          "plus 25 % mild 0.9-0.97, 35 % healthy):", "",
          "| model | windows | window accuracy | healthy windows called healthy | damaged windows, right motor | "
          "damaged flights, window majority right | healthy flights whose window majority is a motor |",
          "|---|---|---|---|---|---|---|"]
    for n, meta in sorted(metas.items()):
        sim = meta["sim_test"]
        conf = sim["confusion"]
        healthy = conf[0][0] / max(1, sum(conf[0]))
        dmg = sum(conf[k][k] for k in range(1, n + 1)) / max(1, sum(sum(conf[k]) for k in range(1, n + 1)))
        L.append(f"| {n} rotors | {sim['windows']} | {_pct(sim['window_accuracy'])} | {_pct(healthy)} | {_pct(dmg)} | "
                 f"{sim['damaged_flights_majority_right']}/{sim['damaged_flights']} | "
                 f"{sim['healthy_flights_majority_motor']}/{sim['healthy_flights']} |")
    if bench:
        L += ["", "`python benchmarks/bench_nrotor.py` (η ≤ 0.8, random airframes with realistic imbalance, PX4 "
              "default and ArduPilot logging): the model alone (window majority), then the flight verdict of "
              "`fdlog diagnose` without a profile and with one calibrated (`--no-adapt`) on a healthy twin "
              "flight of the same airframe (the verdict layer is the decision model's, not this model's alone):",
              "", "```", bench.strip(), "```"]
    from flightlog_fd.analyzers.model_votes import NROTOR_VOTE_STATS

    h, o = NROTOR_VOTE_STATS[6], NROTOR_VOTE_STATS[8]
    L += ["", "**How the decision weighs them.** Their votes (flight mean of the windows' log(q_k/q_0)) are "
          "priced with their own statistics, not the quad model's (`model_votes.NROTOR_VOTE_STATS`, "
          "measured by `python benchmarks/nrotor_vote_stats.py` on simulated flights with seeds neither "
          f"training nor the benchmark uses): a damaged motor's mean sits at {h.damaged_mean:+.2f} ± "
          f"{h.damaged_sigma:.2f} (hexa) and {o.damaged_mean:+.2f} ± {o.damaged_sigma:.2f} (octo) against healthy "
          f"{h.healthy_mean:+.2f} / {o.healthy_mean:+.2f}, and against the airframe's own healthy level (a "
          f"profile) it moves {h.damage_shift:+.2f} ± {h.shift_sigma:.2f} / {o.damage_shift:+.2f} ± "
          f"{o.shift_sigma:.2f}. Re-measure them after retraining.",
          "", "**Limits.** Simulation only, like the quad model, and weaker: the model alone raises a motor "
          "on a fair share of healthy simulated flights and misses many damaged ones, so it is one vote for "
          "the decision layer, not a verdict (the command pattern against a profile names the motor). No "
          "real hexa or octo damage data exists to measure it on. "
          "`fdlog calibrate` measures an n-rotor profile (`--no-adapt`) but does not adapt these models yet.", ""]
    return "\n".join(L)


def main(argv=None) -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nrotor", action="store_true", help="rewrite only the hexa/octo section")
    ap.add_argument("--bench", type=Path, default=None, help="bench_nrotor.py output to quote in that section")
    args = ap.parse_args(argv)
    card = MODELS / "MODEL_CARD.md"
    if args.nrotor:
        metas = {n: json.loads((MODELS / f"{stem}.json").read_text()) for n, stem in NROTOR_FILES.items()
                 if (MODELS / f"{stem}.json").is_file()}
        text = card.read_text()
        head = text.split(NROTOR_MARKER)[0].rstrip("\n")
        bench = args.bench.read_text() if args.bench is not None else None
        card.write_text(head + "\n\n" + render_nrotor(metas, bench))
    else:
        meta = json.loads((MODELS / "default.json").read_text())
        rest = card.read_text().split(NROTOR_MARKER, 1) if card.is_file() else [""]
        tail = NROTOR_MARKER + rest[1] if len(rest) > 1 else ""
        card.write_text(render(meta, flight_verdicts()) + ("\n" + tail if tail else ""))
    print(f"wrote {card}")


if __name__ == "__main__":
    main()
