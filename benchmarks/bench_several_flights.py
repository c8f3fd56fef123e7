"""Several flights in one log: each flight's own verdict against the whole log's (issue 23).

    python benchmarks/bench_several_flights.py [--profile P.json ...] [--logs DIR ...]

Finds every log in ``../shared`` (or ``--logs``) holding several take-offs to landings
(:func:`flightlog_fd.flights.split_flights`) and prints, without a profile and with each
``--profile`` that fits the log (another airframe's profile is skipped), the whole log's verdict
(judged as one), each flight's verdict (:func:`flightlog_fd.diagnose._per_flight`) and the log's
verdict that follows; then counts damaged flights on logs whose truth is healthy and logs whose
verdict changed.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
if not SHARED.exists():
    SHARED = Path("/work/shared")
sys.path.insert(0, str(ROOT))

from flightlog_fd import diagnose as dg, load_flight  # noqa: E402
from flightlog_fd.errors import FlightLogError  # noqa: E402
from flightlog_fd.flights import split_flights  # noqa: E402

SUFFIXES = (".ulg", ".bin", ".log")


def _short(v) -> str:
    return v.status + (f" m{v.motor}" if v.motor else "")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--profile", action="append", default=[], type=Path)
    ap.add_argument("--logs", action="append", type=Path)
    ap.add_argument("--list", type=Path, help="cache of the multi-flight log paths (one a line)")
    args = ap.parse_args()
    from flightlog_fd.model import FaultModel, default_model_path
    from flightlog_fd.profile import Profile

    if args.list and args.list.exists():
        multi = [Path(x) for x in args.list.read_text().split()]
    else:
        roots = args.logs or [SHARED]
        paths = sorted(p for r in roots for p in r.rglob("*") if p.suffix.lower() in SUFFIXES)
        multi = []
        for p in paths:
            try:
                if len(split_flights(load_flight(p))) > 1:
                    multi.append(p)
            except FlightLogError:
                pass
        if args.list:
            args.list.write_text("\n".join(map(str, multi)) + "\n")
    print(f"{len(multi)} logs with several flights", flush=True)
    shipped = FaultModel(default_model_path())
    profiles = [None] + [Profile.load(p) for p in args.profile]
    whole_of = {}
    orig = dg._per_flight

    def spy(whole, *a, **k):
        whole_of["v"] = whole.verdict
        return orig(whole, *a, **k)

    dg._per_flight = spy
    healthy_damaged = changed = n_capped = 0
    for prof in profiles:
        name = Path(prof.path).stem if prof is not None else "no profile"
        for p in multi:
            fl = load_flight(p)
            if prof is not None:
                try:
                    prof.check_compatible(fl)
                except FlightLogError:
                    continue
            whole_of.clear()
            t0 = time.perf_counter()
            model = dg.resolve_model(None, prof, fl.frame.rotor_count if fl.frame else 4)
            d = dg.diagnose_flight(fl, model, prof, keep_flight=False)
            whole = whole_of.get("v")
            rel = str(p.relative_to(SHARED)) if p.is_relative_to(SHARED) else str(p)
            truth_healthy = any(s in rel for s in ("real_healthy", "normal", "good")) or \
                ("air_octo_14" in rel)
            flights = " | ".join(f"{_short(s.verdict)}"
                                 + (f" ({s.verdict.reason[:60]})" if s.verdict.status == "not_diagnosable" else "")
                                 for s in d.flights)
            ch = whole is not None and _short(whole) != _short(d.verdict)
            changed += ch
            capped = [s for s in d.flights if s.verdict.reason.startswith("judged alone")]
            n_capped += len(capped)
            bad = sum(s.verdict.status == "damaged" for s in d.flights) if "real_healthy" in rel else 0
            healthy_damaged += bad
            print(f"{name:22s} {rel:60s} whole {_short(whole) if whole else '-':14s} log {_short(d.verdict):14s}"
                  f"{' CHANGED' if ch else ''} flights: {flights} ({time.perf_counter() - t0:.1f} s)", flush=True)
            for s in capped:
                print(f"    capped {s.part}: {s.verdict.reason[:160]}")
    print(f"damaged flights on real healthy logs: {healthy_damaged}; log verdicts changed: {changed}; "
          f"flights capped by their log: {n_capped}")


if __name__ == "__main__":
    main()
