"""Pages of the documentation made from the code and the benchmark results at build time.

``_generated/performance.md``: the tables of ``benchmarks/results/*.json`` (one current
result file per benchmark), so no number on the performance page is typed by hand.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parents[1] / "benchmarks" / "results"


def write_generated(docs: Path) -> None:
    """Write every generated page under ``docs/_generated`` (only where it changed)."""
    out = docs / "_generated"
    out.mkdir(exist_ok=True)
    _write(out / "performance.md", performance_tables())


def _write(path: Path, text: str) -> None:
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _results() -> dict[str, Any]:
    found = {}
    for path in sorted(RESULTS.glob("*.json")):
        found[path.stem] = json.loads(path.read_text(encoding="utf-8"))
    return found


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3g}" if abs(value) < 1000 else f"{value:,.0f}"
    if isinstance(value, int):
        return f"{value:,}"
    return str(value)


def performance_tables() -> str:
    """Return one section per benchmark: its summary as its result file states it."""
    lines = [
        "# Benchmark results\n",
        "Read from `benchmarks/results/*.json` when the documentation is built (see",
        "{doc}`../performance`).\n",
    ]
    for name, result in _results().items():
        summary = result.get("summary") if isinstance(result, dict) else None
        lines.append(f"## {name}\n")
        what = result.get("what") if isinstance(result, dict) else None
        if what:
            lines.append(f"{what}\n")
        machine = result.get("machine") if isinstance(result, dict) else None
        if machine:
            lines.append(f"Measured on: {machine}.\n")
        if isinstance(summary, list) and summary and isinstance(summary[0], dict):
            keys = list(summary[0])
            lines.append("| " + " | ".join(keys) + " |")
            lines.append("|" + "---|" * len(keys))
            for row in summary:
                lines.append("| " + " | ".join(_cell(row.get(k, "")) for k in keys) + " |")
            lines.append("")
        elif isinstance(summary, dict):
            lines.append("| quantity | value |")
            lines.append("|---|---|")
            for key, value in summary.items():
                lines.append(f"| {key} | {_cell(value)} |")
            lines.append("")
        else:
            lines.append(f"(`benchmarks/results/{name}.json` holds no summary table)\n")
    return "\n".join(lines) + "\n"
