"""Every plot of a benchmark or study folder: success per task and method, success per stage."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from bimanualshift.evaluation.tables import row_label


def series_label(row: dict[str, Any]) -> str:
    """What a plot colours by: the row's label without its perturbation (perturbations are placed, not coloured)."""
    return row_label({k: v for k, v in row.items() if k != "perturbation"})


def group_label(row: dict[str, Any], tasks: int) -> str:
    """Where a row sits on a plot's axis: its task, with the perturbation it was tested under where there is one."""
    task = row["task"].replace("_", " ")
    if "perturbation" not in row:
        return task
    return row["perturbation"].replace("_", " ") + (f" ({task})" if tasks > 1 else "")


def label_colours(rows: list[dict[str, Any]]) -> dict[str, tuple[float, ...]]:
    """One distinct colour per series (method, with its study run where it has one), ordered by the method's place
    in the registry, so a method keeps its colour across plots of the same methods, and the full method always
    comes first (blue)."""
    import matplotlib

    from bimanualshift.registry import METHODS

    order = {name: i for i, name in enumerate(METHODS)}
    labels = sorted(dict.fromkeys(series_label(r) for r in rows),
                    key=lambda label: (order.get(next(r["method"] for r in rows if series_label(r) == label), 99),
                                       _natural(label)))
    # ten series or fewer: tab10's distinct hues; more: tab20's paired shades; beyond that, evenly spaced hues
    palette = matplotlib.colormaps["tab10" if len(labels) <= 10 else "tab20"].colors
    if len(labels) > len(palette):  # more labels than tab20 holds: fall back to evenly spaced hues
        palette = [matplotlib.colormaps["hsv"](i / len(labels)) for i in range(len(labels))]
    return {label: tuple(palette[i]) for i, label in enumerate(labels)}


def _natural(label: str) -> list[Any]:
    """A sort key that orders "[5 demos]" before "[15 demos]"."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", label)]


def legend_entries(axes: list[Any]) -> tuple[list[Any], list[str]]:
    """Every series drawn on any of ``axes``, once each in the order first drawn: a method missing from the first
    panel of a stage plot still gets its entry."""
    entries: dict[str, Any] = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    return list(entries.values()), list(entries)


def _legend_below(fig: Any, axes: list[Any]) -> None:
    """The figure's legend in a band under the plot, so it never covers a bar, a line or the title."""
    handles, labels = legend_entries(axes)
    columns = min(len(labels), 4)
    rows = (len(labels) + columns - 1) // columns
    fig.legend(handles, labels, fontsize=7, ncols=columns, loc="lower center", frameon=False)
    fig.tight_layout(rect=(0, 0.02 + 0.055 * rows * 3.8 / fig.get_figheight(), 1, 1))


def bar_plot(path: Path, rows: list[dict[str, Any]], title: str) -> Path:
    """Success with Wilson 95 % intervals: one group per task (per perturbation in a generalisation study), one
    colour per method."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bimanualshift.utils.io import atomic_writer

    tasks = len(dict.fromkeys(r["task"] for r in rows))
    groups = list(dict.fromkeys(group_label(r, tasks) for r in rows))
    series = list(dict.fromkeys(series_label(r) for r in rows))
    cell = {(series_label(r), group_label(r, tasks)): r for r in rows}
    width = 0.8 / len(series)
    colours = label_colours(rows)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(groups) + 1.0), 4.2))
    for i, name in enumerate(series):
        xs, ys, err = [], [], [[], []]
        for j, group in enumerate(groups):
            r = cell.get((name, group))
            if r is None:
                continue
            xs.append(j + (i - (len(series) - 1) / 2) * width)
            ys.append(100 * r["success"])
            err[0].append(100 * (r["success"] - r["ci95"][0]))
            err[1].append(100 * (r["ci95"][1] - r["success"]))
        ax.bar(xs, ys, width, yerr=err, capsize=2, label=name, color=colours[name])
    ax.set_xticks(range(len(groups)), [g.replace(" ", "\n") for g in groups], fontsize=8)
    ax.set_ylabel("success (%)")
    ax.set_ylim(0, 100)
    ax.set_title(title, fontsize=10)
    _legend_below(fig, [ax])
    with atomic_writer(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def stage_plot(path: Path, rows: list[dict[str, Any]], title: str) -> Path | None:
    """Stage-wise success (Fig. 11b's layout): one panel per multi-stage task (and perturbation), one line per
    method over its stages with Wilson 95 % bands; None (nothing written) when no row has stages."""
    staged = [r for r in rows if r.get("stages")]
    if not staged:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bimanualshift.utils.io import atomic_writer

    panels = list(dict.fromkeys((r["task"], r.get("perturbation")) for r in staged))
    colours = label_colours(staged)
    columns = min(len(panels), 4)
    lines = (len(panels) + columns - 1) // columns
    fig, axes = plt.subplots(lines, columns, figsize=(4.2 * columns if len(panels) > 1 else 5.5, 3.6 * lines + 0.6),
                             squeeze=False, sharey=True)
    for ax, (task, perturbation) in zip(axes.flat, panels):
        mine = [r for r in staged if r["task"] == task and r.get("perturbation") == perturbation]
        names = [s["stage"] for s in mine[0]["stages"]]
        xs = list(range(len(names)))
        for r in mine:
            ys = [100 * s["success"] for s in r["stages"]]
            low = [100 * s["ci95"][0] for s in r["stages"]]
            high = [100 * s["ci95"][1] for s in r["stages"]]
            colour = colours[series_label(r)]
            ax.plot(xs, ys, marker="o", label=series_label(r), color=colour)
            ax.fill_between(xs, low, high, alpha=0.12, color=colour)
        ax.set_xticks(xs, [n.replace(" ", "\n") for n in names], fontsize=8)
        ax.set_ylim(0, 100)
        ax.set_title(task.replace("_", " ") + (f" ({perturbation.replace('_', ' ')})" if perturbation else ""),
                     fontsize=9)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("episodes reaching the stage (%)", fontsize=8)
    fig.suptitle(title, fontsize=10)
    _legend_below(fig, list(axes.flat))
    with atomic_writer(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def draw_plots(out: Path, rows: list[dict[str, Any]], title: str) -> None:
    """A result folder's plots: success bars and, for multi-stage tasks, the stage-wise lines."""
    bar_plot(out / "success.png", rows, title)
    stage_plot(out / "stages.png", rows, title)


def bench_title(demos: object, episodes: object, split: str) -> str:
    """A bench's plot title: demos, episodes per task and the split they come from."""
    return f"{demos} demos, {episodes} {split} episodes per task (95 % Wilson intervals)"


def plot_title(result: dict[str, Any]) -> str:
    """A bench or study result's plot title: the study, or the demos and the episodes per task and their split
    (bench records validation rollouts' seeds as ``validation_rollouts``)."""
    if result.get("study"):
        return f"study {result['study']}"
    first = result["rows"][0]
    split = "validation" if "validation_rollouts" in (result.get("seeds") or {}) else "test"
    return bench_title(first.get("demos", "?"), first.get("episodes", "?"), split)


def redraw_plots(folder: str | Path) -> list[Path]:
    """Redraw the plots of a bench or study result folder from its ``summary.json``."""
    folder = Path(folder)
    summary = folder / "summary.json"
    if not summary.is_file():
        raise FileNotFoundError(f"no summary.json in {folder}: give a folder written by `bimanualshift bench` or "
                                "`bimanualshift study`")
    result = json.loads(summary.read_text())
    if not result.get("rows") or "task" not in result["rows"][0]:
        raise ValueError(f"{summary} holds no benchmark rows (task, method, success); it is not a bench result")
    draw_plots(folder, result["rows"], plot_title(result))
    return [p for p in (folder / "success.png", folder / "stages.png") if p.is_file()]
