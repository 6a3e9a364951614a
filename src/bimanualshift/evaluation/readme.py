"""README blocks regenerated from result files: tables spliced in between marker comments.

`bimanualshift report` rewrites every block ``<!-- results:NAME -->`` ... ``<!-- /results:NAME -->`` with
the table built from ``results/NAME/summary.json`` (or ``results/NAME.json``), so no number is typed. A name may
end in a view, ``NAME#headline``: a study's success table and targets without its stage-wise tables, for pages
that show the headline and link to the rest.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from bimanualshift.evaluation.tables import table_for
from bimanualshift.utils.io import atomic_write_text
from bimanualshift.utils.jsonl import read_records

BLOCK = re.compile(r"(<!-- results:(?P<name>[\w/.-]+(?:#[\w-]+)?) -->\n)(?P<body>.*?)(<!-- /results:(?P=name) -->)",
                   re.S)


def result_file(results_dir: Path, name: str) -> Path:
    for candidate in (results_dir / name / "summary.json", results_dir / f"{name}.json"):
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(f"no result file for block {name!r} under {results_dir}")


def results_documents(root: str | Path = ".") -> list[str]:
    """README.md, every docs/*.md and results/HISTORY.md under ``root`` holding a results block, the files ``report``
    regenerates (a superseded table stays generated from its result file, which is kept)."""
    root = Path(root)
    candidates = [root / "README.md", *sorted((root / "docs").glob("*.md")), root / "results" / "HISTORY.md"]
    return [str(p) for p in candidates if p.is_file() and BLOCK.search(p.read_text())]


def render_readme(readme: str | Path, results_dir: str | Path = "results") -> list[str]:
    """Regenerate every results block of ``readme``; returns the names of the blocks it rewrote."""
    readme, results_dir = Path(readme), Path(results_dir)
    text = readme.read_text()
    names: list[str] = []

    def replace(match: re.Match[str]) -> str:
        name, _, view = match.group("name").partition("#")
        names.append(match.group("name"))
        table = table_for(json.loads(result_file(results_dir, name).read_text()), view=view)
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


def _recorded_pairs(log: Path, cache: dict[Path, set[tuple[str, str]]]) -> set[tuple[str, str]]:
    """The (task, method) pairs of one episode log, read once per index: a study's summary and each of its
    runs' summaries look at the same logs."""
    if log not in cache:
        cache[log] = {(e["task"], e["method"]) for e in read_records(log) if "task" in e and "method" in e}
    return cache[log]


def unsummarised_pairs(summary: Path, result: dict,
                       cache: dict[Path, set[tuple[str, str]]] | None = None) -> list[tuple[str, str]]:
    """(task, method) pairs with episodes recorded beside ``summary`` (its folder's ``episodes.jsonl`` and, for a
    study, its runs' folders) but no row in it: the summary of a run that covered part of what its folder holds
    (a study run one task or one group of methods at a time); a study's ``--recorded-only`` rewrites it whole."""
    folder, cache = summary.parent, {} if cache is None else cache
    logs = [folder / "episodes.jsonl"] + [child / "episodes.jsonl" for child in sorted(folder.iterdir())
                                         if child.is_dir() and (child / "summary.json").is_file()]
    recorded = set().union(*(_recorded_pairs(log, cache) for log in logs))
    rows = {(r.get("task"), r.get("method")) for r in result.get("rows", []) if isinstance(r, dict)}
    return sorted(recorded - rows)


def render_index(results_dir: str | Path = "results") -> Path:
    """``results/README.md``: every result file's table with the command, seeds, commit and wall time that
    produced it, regenerated from the files (each table is a results block, so `report` keeps it current). A
    summary that leaves out episodes recorded beside it (``unsummarised_pairs``) is marked partial above its table:
    a half-built table read as a finished one would mislead."""
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise FileNotFoundError(f"no results folder {results_dir}: give the folder the result files are in "
                                "(--results, default results)")
    parts = ["# Results", "",
             "Every table below is generated from the result file it names by `bimanualshift report --index`;",
             "each file records the command, seeds, commit, machine and wall time that produced it.", ""]
    logs: dict[Path, set[tuple[str, str]]] = {}
    for name in result_names(results_dir):
        path = result_file(results_dir, name)
        try:
            result = json.loads(path.read_text())
            table = table_for(result)
        except (KeyError, ValueError, IndexError, TypeError) as exc:
            result, table = {}, f"(not a results-envelope file: {exc!r})\n"
        missing = unsummarised_pairs(path, result, logs) if path.name == "summary.json" else []
        parts += [f"## {name}", "", f"`{path.relative_to(results_dir)}`", ""]
        if missing:
            shown = ", ".join(f"{t}/{m}" for t, m in missing[:4]) + (", ..." if len(missing) > 4 else "")
            parts += [f"**Partial**: {len(missing)} task/method pairs recorded here are not in this summary "
                      f"({shown}). A study's `--recorded-only` (or a bench over every method recorded here) "
                      "summarises them all.", ""]
        parts += [f"<!-- results:{name} -->", table.rstrip("\n"), f"<!-- /results:{name} -->", ""]
    index = results_dir / "README.md"
    atomic_write_text(index, "\n".join(parts))
    return index
