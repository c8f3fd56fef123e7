"""Write models/MODEL_CARD.md from the figures `build_default` measured (models/default.json).

    python -m training.model_card

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


def render(meta: dict) -> str:
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
             "crazypad_e9": "CrazyPAD E9 real Crazyflie flights, 42 flights, no calibration"}
    for key, t in meta.get("targets", {}).items():
        L.append(f"| {names.get(key, key)} | {t['n_windows']} | {_pct(t['window_accuracy'])} | "
                 f"{_pct(t['healthy_window_accuracy'])} | {_pct(t['damaged_window_accuracy'])} |")
    L += [
        "",
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
        "- Healthy training flights carry up to ~5 % per-motor speed imbalance, because real healthy quads do "
        "(CrazyPAD E9: motor 2 at +5 %; an Erle-Copter: motor 3 at +9.5 %). So without calibration it flags "
        "only damage that clearly exceeds that (thrust loss of roughly 15 % or more). A weaker propeller on "
        "an unbalanced airframe looks the same as that airframe's own imbalance: calibrate on a healthy "
        "flight (`fdlog calibrate`) for mild damage.",
        "- Windows are 1.6 s; the flight verdict smooths over several seconds and abstains (`uncertain`) when "
        "the evidence is weak or split.",
        "- Quadrotors only (quad-X and quad-+); one damaged propeller at a time.",
        "- Real damaged-propeller data (CrazyPAD) is used only to measure, never to train.",
        "",
    ]
    return "\n".join(L)


def main() -> None:
    meta = json.loads((MODELS / "default.json").read_text())
    (MODELS / "MODEL_CARD.md").write_text(render(meta))
    print(f"wrote {MODELS / 'MODEL_CARD.md'}")


if __name__ == "__main__":
    main()
