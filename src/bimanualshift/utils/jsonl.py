"""Append-only JSON-lines logs that a killed run resumes from."""

from __future__ import annotations

import gzip
import json
import os
from pathlib import Path
from typing import Any


def read_records(path: str | Path) -> list[dict[str, Any]]:
    """Finished records of an earlier run; a line cut short by a kill is ignored (that record is redone). A
    ``.gz`` log (an archived folder's) is read the same way."""
    path = Path(path)
    if not path.is_file():
        return []
    records = []
    text = gzip.decompress(path.read_bytes()).decode() if path.suffix == ".gz" else path.read_text()
    for line in text.splitlines():
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return records


def append_record(path: str | Path, record: dict[str, Any]) -> None:
    """Append one record and sync it to disk; a half-written last line (a kill) is closed off first."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a+b") as f:
        f.seek(0, os.SEEK_END)
        if f.tell() > 0:
            f.seek(-1, os.SEEK_END)
            if f.read(1) != b"\n":
                f.write(b"\n")
        f.write((json.dumps(record) + "\n").encode())
        f.flush()
        os.fsync(f.fileno())
