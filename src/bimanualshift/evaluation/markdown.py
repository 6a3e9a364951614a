"""Markdown tables generated from result files, spliced into README files between marker comments.

`bimanualshift report` rewrites every block ``<!-- results:NAME -->`` ... ``<!-- /results:NAME -->`` with
the table built from ``results/NAME/summary.json`` (or ``results/NAME.json``), so no number is typed.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from bimanualshift.utils.io import atomic_write_text

BLOCK = re.compile(r"(<!-- results:(?P<name>[\w/.-]+) -->\n)(?P<body>.*?)(<!-- /results:(?P=name) -->)", re.S)


def success_table(result: dict[str, Any]) -> str:
    lines = ["| task | method | demos | success | 95 % CI | episodes |", "|---|---|---|---|---|---|"]
    for r in result["rows"]:
        lo, hi = r["ci95"]
        lines.append(f"| {r['task']} | {r['method']} | {r.get('demos', '')} | {100 * r['success']:.1f} % | "
                     f"{100 * lo:.1f}–{100 * hi:.1f} % | {r['episodes']} |")
    lines.append("")
    lines.append(f"Produced by `{result['command']}` at commit `{result['commit'][:12]}` on {result['created']} "
                 f"({result['machine']}); wall time {result['wall_time_s'] / 60:.1f} min. "
                 f"Test seeds {result['seeds']['test'][0]}–{result['seeds']['test'][-1]}.")
    return "\n".join(lines) + "\n"


def experts_table(result: dict[str, Any]) -> str:
    lines = ["| task | arms | expert success | 95 % CI | episodes | s / episode | keyframes |",
             "|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        lo, hi = r["ci95"]
        lines.append(f"| {r['task']} | {'two' if r['bimanual'] else 'one'} | {100 * r['success']:.1f} % | "
                     f"{100 * lo:.1f}–{100 * hi:.1f} % | {r['episodes']} | {r['mean_wall_time_s']:.1f} | "
                     f"{r['mean_keyframes']:.1f} |")
    lines.append("")
    lines.append(f"Produced by `{result['command']}` at commit `{result['commit'][:12]}` on {result['created']} "
                 f"({result['machine']}); wall time {result['wall_time_s'] / 60:.1f} min. {result['notes']}.")
    return "\n".join(lines) + "\n"


def generic_table(result: dict[str, Any]) -> str:
    """Any other result file: one column per scalar field of its rows (timings, projection quality, ...)."""
    rows = result["rows"]
    columns = [k for k, v in rows[0].items() if isinstance(v, (str, int, float, bool))] if rows else []
    lines = ["| " + " | ".join(c.replace("_", " ") for c in columns) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        cells = [f"{r[c]:.3f}" if isinstance(r.get(c), float) else str(r.get(c, "")) for c in columns]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(f"Produced by `{result['command']}` at commit `{result['commit'][:12]}` on {result['created']} "
                 f"({result['machine']}); wall time {result['wall_time_s'] / 60:.1f} min. {result['notes']}.")
    return "\n".join(lines) + "\n"


def table_for(result: dict[str, Any]) -> str:
    """Expert measurements, success rates of methods, or a generic table of whatever the rows hold."""
    first = result["rows"][0] if result["rows"] else {}
    if "bimanual" in first:
        return experts_table(result)
    if "method" in first and "success" in first:
        return success_table(result)
    return generic_table(result)


def result_file(results_dir: Path, name: str) -> Path:
    for candidate in (results_dir / name / "summary.json", results_dir / f"{name}.json"):
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(f"no result file for block {name!r} under {results_dir}")


def render_readme(readme: str | Path, results_dir: str | Path = "results") -> list[str]:
    """Regenerate every results block of ``readme``; returns the names of the blocks it rewrote."""
    readme, results_dir = Path(readme), Path(results_dir)
    text = readme.read_text()
    names: list[str] = []

    def replace(match: re.Match[str]) -> str:
        name = match.group("name")
        names.append(name)
        table = table_for(json.loads(result_file(results_dir, name).read_text()))
        return match.group(1) + table + match.group(4)

    new = BLOCK.sub(replace, text)
    if new != text:
        atomic_write_text(readme, new)
    return names
