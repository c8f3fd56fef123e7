"""What kind of log a file is, from its first bytes (the readers' shared first step)."""
from __future__ import annotations

from pathlib import Path
from typing import Iterable

from ..errors import NotALogError

ULOG_MAGIC = b"ULog\x01\x12\x35"
DATAFLASH_HEAD = b"\xa3\x95"
DATAFLASH_FMT_ID = 0x80


def read_head(path, n: int = 16) -> bytes:
    """The first ``n`` bytes of a log file; NotALogError (one line) for a missing path, a folder,
    an unreadable or an empty file. Every reader starts here."""
    p = Path(path)
    if not p.exists():
        raise NotALogError(path, "no such file")
    if p.is_dir():
        raise NotALogError(path, "is a folder, not a log file")
    try:
        with open(p, "rb") as f:
            head = f.read(n)
    except OSError as e:
        raise NotALogError(path, f"cannot read: {e.strerror or e}") from None
    if not head:
        raise NotALogError(path, "empty file (0 bytes)")
    return head


def sniff_format(path) -> str:
    """Return ``"ulog"`` or ``"dataflash"`` from the file's first bytes, else raise NotALogError."""
    head = read_head(path)
    if head.startswith(ULOG_MAGIC):
        return "ulog"
    if len(head) >= 3 and head[:2] == DATAFLASH_HEAD and head[2] == DATAFLASH_FMT_ID:
        return "dataflash"
    if head.startswith(b"ULog"):
        return "ulog"  # unknown ULog version: let the reader say what is wrong
    raise NotALogError(path, "not a PX4 ULog or ArduPilot DataFlash log (unrecognised header)")


def collect_logs(paths: Iterable[Path]) -> tuple[list[Path], list[str]]:
    """Expand folders into the log files they hold (by content, not extension).

    Returns (files, errors): a path that does not exist is an error; inside a folder, files that
    are not logs (READMEs, CSVs...) are skipped silently.
    """
    files: list[Path] = []
    errors: list[str] = []
    for p in map(Path, paths):
        if p.is_dir():
            for f in sorted(x for x in p.rglob("*") if x.is_file()):
                try:
                    sniff_format(f)
                except NotALogError:
                    continue
                files.append(f)
            continue
        if not p.exists():
            errors.append(f"{p}: no such file")
            continue
        files.append(p)
    return files, errors
