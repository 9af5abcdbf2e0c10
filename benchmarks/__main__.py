"""Run benchmarks, print their tables and record them in docs/benchmarks.md.

Usage, from the repository root: ``python -m benchmarks`` (every ``bench_*.py`` module) or
``python -m benchmarks keyimages ...`` (only those).
"""

from __future__ import annotations

import importlib
import pkgutil
import re
import sys
import traceback
from pathlib import Path

import benchmarks
from benchmarks import machine

REPORT = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"
HEADER = (
    "# Benchmarks\n\nWritten by `python -m benchmarks` (run from the repository root); "
    "each block records the machine and date of its own run.\n"
)


def _block(name: str, body: str) -> str:
    return f"<!-- bench:{name} -->\n## {name}\n\n_{machine()}_\n\n{body}<!-- /bench:{name} -->\n"


def _record(blocks: dict[str, str]) -> None:
    """Replace or add each module's block in the report, keeping the other modules'."""
    old = REPORT.read_text(encoding="utf-8") if REPORT.exists() else ""
    pattern = r"<!-- bench:(\w+) -->\n.*?<!-- /bench:\1 -->\n"
    kept = {match[1]: match[0] for match in re.finditer(pattern, old, flags=re.S)}
    kept.update(blocks)
    REPORT.parent.mkdir(parents=True, exist_ok=True)
    REPORT.write_text(HEADER + "".join("\n" + kept[k] for k in sorted(kept)), encoding="utf-8")


def main(argv: list[str]) -> int:
    names = sorted(
        m.name.removeprefix("bench_")
        for m in pkgutil.iter_modules(benchmarks.__path__)
        if m.name.startswith("bench_")
    )
    unknown = [a for a in argv if a not in names]
    if unknown:
        print(f"unknown benchmark {unknown[0]!r}; choose from: {', '.join(names)}", file=sys.stderr)
        return 2
    blocks, failed = {}, []
    for name in argv or names:
        try:
            sections = importlib.import_module(f"benchmarks.bench_{name}").run()
        except Exception:  # report it, run the others, and exit non-zero
            traceback.print_exc()
            failed.append(name)
            continue
        blocks[name] = _block(name, "\n".join(s.to_markdown() for s in sections))
        print(blocks[name], flush=True)
    _record(blocks)
    print(f"recorded {', '.join(blocks) or 'nothing'} in {REPORT}")
    if failed:
        print(f"benchmarks that failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
