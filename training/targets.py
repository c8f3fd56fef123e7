"""Labelled real-format target sets from ``../shared`` (truth from their manifests).

- ``px4_sih_dev``: PX4 SITL (SIH physics) flights, healthy or with one weakened motor from
  take-off or from a mid-flight onset (``fault_onset_boot_us`` on the log clock);
- ``crazypad_e9``: real Crazyflie flights, healthy or with a cut / taped propeller (damage from
  take-off), with the damaged motor in PX4 numbering.

These are for adaptation (healthy flights only) and testing, never for training the shipped
model. Returns `Flight` objects plus truth dicts in the form `windows.window_labels` reads.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from flightlog_fd import load_flight
from flightlog_fd.flight import Flight

#: ../shared next to the project root (the layout CI uses).
SHARED = Path(__file__).resolve().parents[1].parent / "shared"


@dataclass
class LabelledLog:
    name: str
    path: Path
    truth: dict  # {"label", "motor", "eta", "onset_s"}
    detail: str = ""
    flight: Optional[Flight] = None

    @property
    def healthy(self) -> bool:
        return self.truth["label"] == 0

    def load(self) -> Flight:
        if self.flight is None:
            self.flight = load_flight(self.path)
        return self.flight


def sih_logs(shared: Path = SHARED) -> list[LabelledLog]:
    """The PX4 SITL/SIH development set with its manifest's truth."""
    root = shared / "px4_sih_dev"
    out = []
    with open(root / "manifest.csv", newline="") as fh:
        for r in csv.DictReader(fh):
            motor = int(r["faulty_motor"])
            onset = float(r["fault_onset_boot_us"]) / 1e6 if r.get("fault_onset_boot_us") else None
            out.append(LabelledLog(
                r["name"], root / "logs" / f"{r['name']}.ulg",
                {"label": motor, "motor": motor, "eta": float(r["eta"]), "onset_s": onset},
                f"sdlog {r['sdlog_profile']}, {r['fault_class']}" + (f", eta {r['eta']}" if motor else "")))
    return out


def crazypad_logs(shared: Path = SHARED) -> list[LabelledLog]:
    """The CrazyPAD E9 real flights with the damaged motor in PX4 numbering."""
    root = shared / "crazypad_e9"
    out = []
    with open(root / "manifest.csv", newline="") as fh:
        for r in csv.DictReader(fh):
            m = r["damaged_px4_motors"].strip()
            motor = int(m) if m else 0
            out.append(LabelledLog(
                Path(r["file"]).stem, root / "ulog" / r["file"],
                {"label": motor, "motor": motor, "eta": None, "onset_s": None},
                f"{r['damage_kind']}: {r['damage_detail']}" if motor else "healthy"))
    return out


def available(shared: Path = SHARED) -> dict[str, bool]:
    return {"px4_sih_dev": (shared / "px4_sih_dev" / "manifest.csv").exists(),
            "crazypad_e9": (shared / "crazypad_e9" / "manifest.csv").exists(),
            "real_healthy": (shared / "real_healthy" / "logs").is_dir()}


def real_healthy_logs(shared: Path = SHARED) -> list[LabelledLog]:
    """Real healthy ArduCopter flights (no labelled damage): ../shared/real_healthy and the Erle
    flights of ../shared/real_logs. For false-alarm measurements only."""
    paths = sorted((shared / "real_healthy" / "logs").glob("*"))
    paths += sorted((shared / "real_logs" / "ardupilot").glob("erle_copter*.BIN"))
    return [LabelledLog(p.stem, p, {"label": 0, "motor": 0, "eta": None, "onset_s": None}, "real, healthy")
            for p in paths]
