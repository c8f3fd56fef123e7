"""Terminal text for `fdlog info` (input: the dict from :func:`flightlog_fd.checks.describe_flight`)."""
from __future__ import annotations

from rich.console import Console
from rich.markup import escape
from rich.table import Table


def print_info(console: Console, d: dict) -> None:
    """Print one log's description; every string from the log is escaped for rich markup."""
    verdict = "[green]diagnosable[/green]" if d["diagnosable"] else (
        "[red]not diagnosable[/red]: " + escape("; ".join(d["reasons"])))
    console.print(f"[bold]{escape(str(d['log']))}[/bold]")
    frame = d.get("frame") or {}
    console.print(f"  autopilot  {escape(d['autopilot'])}  firmware {escape(d['firmware'] or '?')}")
    if d.get("reader"):
        console.print(f"  reader     {escape(d['reader'])}")
    console.print(f"  vehicle    {escape(str(d['vehicle_type']))}"
                  + (f"  id {escape(str(d['vehicle_id']))}" if d.get("vehicle_id") else ""))
    if frame:
        motors = ", ".join(f"{m['motor']} {m['position']} {m['spin']}" for m in frame.get("motors", []))
        console.print(f"  frame      {escape(frame['name'])} ({frame['rotor_count']} rotors; {escape(motors)})"
                      f"  [dim]from {escape(frame.get('source') or '?')}[/dim]")
        _print_geometry(console, frame)
    else:
        console.print("  frame      unknown")
    console.print(f"  duration   {d['duration_s']:.1f} s  (t={d['t_start']:.2f}..{d['t_end']:.2f} s on the log clock)")
    console.print(f"  airborne   {d['airborne_s']:.1f} s in {len(d['airborne'])} interval(s)"
                  f"  [dim]from {escape(d.get('airborne_source') or '?')}[/dim]")
    tc = d.get("thrust_curve")
    console.print(f"  motors are {escape(d['motor_kind'])} commands"
                  + (f", thrust curve {tc:g}" if tc is not None else ""))
    t = Table(show_header=True, header_style="bold", box=None, pad_edge=False)
    t.add_column("stream")
    t.add_column("source")
    t.add_column("rate", justify="right")
    t.add_column("samples", justify="right")
    for s in d["streams"]:
        t.add_row(escape(s["name"]), escape(s["source"]), f"{s['rate_hz']:.1f} Hz", str(s["samples"]))
    console.print(t)
    esc = d.get("esc")
    if esc:
        units = ", ".join(f"{q} {escape(u)}" for q, u in esc["units"].items() if q in esc["quantities"])
        console.print(f"  ESC        {escape(esc['source'])}")
        console.print(f"             [dim]{units}[/dim]")
        e = Table(show_header=True, header_style="bold", box=None, pad_edge=False)
        for col, just in (("motor", "right"), ("ESC", "right"), ("rate", "right"), ("samples", "right"),
                          ("offline", "right"), ("gaps", "left")):
            e.add_column(col, justify=just)
        for m in esc["motors"]:
            gaps = (f"{len(m['gaps'])} ({m['gap_s']:.1f} s, first at {m['gaps'][0][0]:.1f} s)" if m["gaps"] else "none")
            e.add_row(str(m["motor"]), str(m["esc_index"]), f"{m['rate_hz']:.1f} Hz", str(m["samples"]),
                      str(m["offline_samples"]), gaps)
        console.print(e)
    for w in d.get("warnings", []):
        console.print(f"  [yellow]warning[/yellow] {escape(w)}")
    for m in d.get("stopped_motors", []):
        console.print(f"  [red]stopped[/red]    motor {m['motor']} at t={m['t_start']:.2f} s for "
                      f"{m['t_end'] - m['t_start']:.1f} s: {escape(m['evidence'])}")
    console.print(f"  verdict    {verdict}")
    console.print()


def _print_geometry(console: Console, frame: dict) -> None:
    """The rotor table (position, x/y, spin, thrust axis when tilted, output channel), or why the
    rotors could not be placed."""
    if frame.get("unplaced"):
        console.print(f"  geometry   [red]cannot place the rotors[/red]: {escape(frame['unplaced'])}")
        return
    motors = frame.get("motors") or []
    if not motors:
        return
    if frame.get("layout"):
        console.print(f"  geometry   {escape(frame['layout'])}  [dim](x forward, y right; spin seen from above)[/dim]")
    t = Table(show_header=True, header_style="bold", box=None, pad_edge=False, padding=(0, 1))
    for col, just in (("  motor", "right"), ("position", "left"), ("x", "right"), ("y", "right"),
                      ("spin", "left"), ("thrust axis", "left"), ("output", "right")):
        t.add_column(col, justify=just)
    for m in motors:
        axis = m.get("axis") or [0.0, 0.0, -1.0]
        tilted = abs(axis[0]) > 1e-6 or abs(axis[1]) > 1e-6
        t.add_row(str(m["motor"]), escape(m["position"]), f"{m['x']:+.3f}", f"{m['y']:+.3f}", m["spin"],
                  ("(" + ", ".join(f"{a:+.2f}" for a in axis) + ")") if tilted else "up",
                  str(m["output"]) if m.get("output") is not None else "-")
    console.print(t)
