"""Benchmarks: ``python -m benchmarks [name ...]`` runs every ``benchmarks/bench_<name>.py``.

Each module exposes ``run() -> list[Section]``. The tables are printed and recorded in
``docs/benchmarks.md``, one block per module, so that running one module keeps the others.
"""

from __future__ import annotations

import os
import platform
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime

import numpy as np


@dataclass(frozen=True)
class Section:
    """One result table: title, column headers, rows of cells, and notes (markdown text, or
    a list of lines shown as bullets)."""

    title: str
    headers: Sequence[str]
    rows: Sequence[Sequence] = field(default_factory=list)
    notes: str | Sequence[str] = ""

    def to_markdown(self) -> str:
        lines = [f"### {self.title}", "", "| " + " | ".join(map(str, self.headers)) + " |"]
        lines.append("|" + "---|" * len(self.headers))
        lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in self.rows]
        notes = self.notes
        if not isinstance(notes, str):
            notes = "\n".join(f"- {line}" for line in notes)
        if notes.strip():
            lines += ["", notes.strip()]
        return "\n".join(lines) + "\n"


def _cpu_name() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as info:
            for line in info:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> str:
    """One line saying where and when a benchmark ran."""
    date = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    return (
        f"{date}; {os.cpu_count()} CPUs ({_cpu_name()}); Python {platform.python_version()}; "
        f"numpy {np.__version__}; {sys.platform}"
    )
