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


def _footer(result: dict[str, Any]) -> str:
    return (f"Produced by `{result['command']}` at commit `{result['commit'][:12]}` on {result['created']} "
            f"({result['machine']}); wall time {result['wall_time_s'] / 60:.1f} min. {result['notes']}.")


def projection_quality_table(result: dict[str, Any]) -> str:
    """Kept / removed voxel fractions, one line per task and segmenter, both arms side by side."""
    lines = ["| task | segmenter | left kept | left removed | right kept | right removed | episodes | keyframes |",
             "|---|---|---|---|---|---|---|---|"]
    cells: dict[tuple[str, str], dict[str, Any]] = {}
    for r in result["rows"]:
        cells.setdefault((r["task"], r["segmenter"]), {"episodes": r["episodes"], "keyframes": r["keyframes"]})
        cells[(r["task"], r["segmenter"])][r["arm"]] = r
    for (task, segmenter), c in cells.items():
        arms = [f"{c[a]['kept']:.3f} | {c[a]['removed']:.3f}" if a in c else "– | –" for a in ("left", "right")]
        lines.append(f"| {task} | {segmenter} | {arms[0]} | {arms[1]} | {c['episodes']} | {c['keyframes']} |")
    return "\n".join([*lines, "", _footer(result)]) + "\n"


def priors_table(result: dict[str, Any]) -> str:
    """Single-arm success per task (with 95 % intervals) for each prior, then size and speed."""
    rows = result["rows"]
    tasks = list(rows[0]["tasks"])
    lines = ["| task | " + " | ".join(r["prior"] for r in rows) + " |", "|---|" + "---|" * len(rows)]
    for task in tasks:
        cells = []
        for r in rows:
            t = r["tasks"][task]
            cells.append(f"{100 * t['success']:.0f} % ({100 * t['ci95'][0]:.0f}–{100 * t['ci95'][1]:.0f})")
        lines.append(f"| {task} | " + " | ".join(cells) + " |")
    lines.append("| **mean** | " + " | ".join(f"**{100 * r['mean_success']:.1f} %**" for r in rows) + " |")
    lines.append("| parameters | " + " | ".join(f"{r['parameters']:,}" for r in rows) + " |")
    lines.append("| ms per arm (2 threads) | " + " | ".join(f"{r['inference_ms_per_arm']}" for r in rows) + " |")
    lines.append("| training time | " + " | ".join(
        f"{r['training_time_s'] / 60:.0f} min" if r.get("training_time_s") else "–" for r in rows) + " |")
    episodes = rows[0]["tasks"][tasks[0]]["episodes"]
    return "\n".join([*lines, "", f"{episodes} test episodes per task. " + _footer(result)]) + "\n"


def _number(x: float) -> str:
    """At most three decimals, without trailing zeros: 714.6, 0.41, 1.046."""
    return f"{x:.3f}".rstrip("0").rstrip(".")


def generic_table(result: dict[str, Any]) -> str:
    """Any other result file: one column per scalar field of its rows (timings, projection quality, ...)."""
    rows = result["rows"]
    # Rows may differ in their fields (a training row and a throughput row): every scalar field gets a column.
    columns = list(dict.fromkeys(k for r in rows for k, v in r.items() if isinstance(v, (str, int, float, bool))))
    lines = ["| " + " | ".join(c.replace("_", " ") for c in columns) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        cells = [_number(r[c]) if isinstance(r.get(c), float) else str(r.get(c, "")) for c in columns]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(f"Produced by `{result['command']}` at commit `{result['commit'][:12]}` on {result['created']} "
                 f"({result['machine']}); wall time {result['wall_time_s'] / 60:.1f} min. {result['notes']}.")
    return "\n".join(lines) + "\n"


def sim_profile_table(result: dict[str, Any]) -> str:
    """Per task, where a step's and a keyframe's time goes, before and after a change side by side."""
    by_task: dict[str, dict[str, dict[str, Any]]] = {}
    for r in result["rows"]:
        by_task.setdefault(r["task"], {})[r["label"]] = r
    labels = list(dict.fromkeys(r["label"] for r in result["rows"]))
    lines = ["| task | " + " | ".join(f"control ms ({lb}) | physics ms ({lb}) | ratio ({lb}) | observation ms ({lb})"
                                        f" | expert episodes / min ({lb})" for lb in labels) + " |",
             "|---|" + "---|---|---|---|---|" * len(labels)]
    for task, rows in by_task.items():
        cells = []
        for lb in labels:
            r = rows.get(lb)
            cells += ([f"{r['control_step_ms']:.1f}", f"{r['physics_ms']:.1f}", f"{r['control_over_physics']:.2f}",
                       f"{r['observation_ms']:.0f}", f"{r['expert_episodes_per_min']:.1f}"] if r else ["–"] * 5)
        lines.append(f"| {task} | " + " | ".join(cells) + " |")
    lines.append("")
    commands = "; ".join(f"{lb}: `{c}` at commit `{next(r['commit'] for r in result['rows'] if r['label'] == lb)[:12]}`"
                         for lb, c in result.get("commands", {}).items())
    lines.append(f"Produced by {commands} ({result['machine']}). {result['notes']}.")
    for lb, note in result.get("notes_by_label", {}).items():
        lines.append(f"*{lb}*: {note}.")
    return "\n".join(lines) + "\n"


def table_for(result: dict[str, Any]) -> str:
    """Expert measurements, success rates of methods, or a generic table of whatever the rows hold."""
    first = result["rows"][0] if result["rows"] else {}
    if result.get("bench"):
        from bimanualshift.evaluation.bench import bench_table, stage_table
        from bimanualshift.evaluation.targets import study_targets, targets_table

        targets = study_targets(result.get("study", ""), result["rows"])  # derived from the rows, never stored alone
        parts = [bench_table(result["rows"]), stage_table(result["rows"]), targets_table(targets)]
        return "\n".join([*(p for p in parts if p), _footer(result)]) + "\n"
    if "prior" in first and "tasks" in first:
        return priors_table(result)
    if "segmenter" in first and "kept" in first:
        return projection_quality_table(result)
    if "bimanual" in first:
        return experts_table(result)
    if "control_step_ms" in first:
        return sim_profile_table(result)
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


def result_names(results_dir: str | Path) -> list[str]:
    """Every result file under ``results_dir`` as a block name: ``NAME.json`` and ``NAME/summary.json`` (nested
    study runs included, e.g. ``few_shot/demos_5``)."""
    results_dir = Path(results_dir)
    names = [p.stem for p in results_dir.glob("*.json")]
    names += [str(p.parent.relative_to(results_dir)) for p in results_dir.rglob("summary.json")]
    return sorted(set(names))


def render_index(results_dir: str | Path = "results") -> Path:
    """``results/README.md``: every result file's table with the command, seeds, commit and wall time that
    produced it, regenerated from the files (each table is a results block, so `report` keeps it current)."""
    results_dir = Path(results_dir)
    parts = ["# Results", "",
             "Every table below is generated from the result file it names by `bimanualshift report --index`;",
             "each file records the command, seeds, commit, machine and wall time that produced it.", ""]
    for name in result_names(results_dir):
        path = result_file(results_dir, name)
        try:
            result = json.loads(path.read_text())
            table = table_for(result)
        except (KeyError, ValueError, IndexError, TypeError) as exc:
            table = f"(not a results-envelope file: {exc!r})\n"
        parts += [f"## {name}", "", f"`{path.relative_to(results_dir)}`", "",
                  f"<!-- results:{name} -->", table.rstrip("\n"), f"<!-- /results:{name} -->", ""]
    index = results_dir / "README.md"
    atomic_write_text(index, "\n".join(parts))
    return index
