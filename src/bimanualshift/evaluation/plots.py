"""Every plot of a benchmark or study folder: success per task and method, success per stage."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from bimanualshift.evaluation.tables import row_label


def label_colours(rows: list[dict[str, Any]]) -> dict[str, tuple[float, ...]]:
    """One distinct colour per row label (method, with its demos or perturbation where they vary): labels ordered
    by their method's place in the registry, so a method keeps its colour across plots of the same methods, and
    the full method always comes first (tab20's strongest blue)."""
    import matplotlib

    from bimanualshift.registry import METHODS

    order = {name: i for i, name in enumerate(METHODS)}
    labels = sorted(dict.fromkeys(row_label(r) for r in rows),
                    key=lambda label: (order.get(next(r["method"] for r in rows if row_label(r) == label), 99), label))
    palette = matplotlib.colormaps["tab20"].colors
    if len(labels) > len(palette):  # more labels than tab20 holds: fall back to evenly spaced hues
        palette = [matplotlib.colormaps["hsv"](i / len(labels)) for i in range(len(labels))]
    return {label: tuple(palette[i]) for i, label in enumerate(labels)}


def bar_plot(path: Path, rows: list[dict[str, Any]], title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bimanualshift.utils.io import atomic_writer

    tasks = list(dict.fromkeys(r["task"] for r in rows))
    methods = list(dict.fromkeys(row_label(r) for r in rows))
    cell = {(row_label(r), r["task"]): r for r in rows}
    width = 0.8 / len(methods)
    colours = label_colours(rows)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(tasks)), 3.8))
    for i, method in enumerate(methods):
        xs, ys, err = [], [], [[], []]
        for j, task in enumerate(tasks):
            r = cell.get((method, task))
            if r is None:
                continue
            xs.append(j + (i - (len(methods) - 1) / 2) * width)
            ys.append(100 * r["success"])
            err[0].append(100 * (r["success"] - r["ci95"][0]))
            err[1].append(100 * (r["ci95"][1] - r["success"]))
        ax.bar(xs, ys, width, yerr=err, capsize=2, label=method, color=colours[method])
    ax.set_xticks(range(len(tasks)), [t.replace("_", "\n") for t in tasks], fontsize=8)
    ax.set_ylabel("success (%)")
    ax.set_ylim(0, 100)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7, ncols=min(len(methods), 3))
    fig.tight_layout()
    with atomic_writer(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def stage_plot(path: Path, rows: list[dict[str, Any]], title: str) -> Path | None:
    """Stage-wise success (Fig. 11b's layout): per multi-stage task, one line per method over its stages with
    Wilson 95 % bands; None (nothing written) when no row has stages."""
    staged = [r for r in rows if r.get("stages")]
    if not staged:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bimanualshift.utils.io import atomic_writer

    tasks = list(dict.fromkeys(r["task"] for r in staged))
    colours = label_colours(staged)
    fig, axes = plt.subplots(1, len(tasks), figsize=(5.5 * len(tasks), 3.8), squeeze=False)
    for ax, task in zip(axes[0], tasks):
        mine = [r for r in staged if r["task"] == task]
        names = [s["stage"] for s in mine[0]["stages"]]
        xs = list(range(len(names)))
        for r in mine:
            ys = [100 * s["success"] for s in r["stages"]]
            low = [100 * s["ci95"][0] for s in r["stages"]]
            high = [100 * s["ci95"][1] for s in r["stages"]]
            colour = colours[row_label(r)]
            ax.plot(xs, ys, marker="o", label=row_label(r), color=colour)
            ax.fill_between(xs, low, high, alpha=0.12, color=colour)
        ax.set_xticks(xs, [n.replace(" ", "\n") for n in names], fontsize=8)
        ax.set_ylim(0, 100)
        ax.set_ylabel("episodes reaching the stage (%)")
        ax.set_title(f"{title}: {task.replace('_', ' ')}", fontsize=10)
        ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_writer(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def draw_plots(out: Path, rows: list[dict[str, Any]], title: str) -> None:
    """A result folder's plots: success bars and, for multi-stage tasks, the stage-wise lines."""
    bar_plot(out / "success.png", rows, title)
    stage_plot(out / "stages.png", rows, title)


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
    first = result["rows"][0]
    title = (f"study {result['study']}" if result.get("study") else f"{first.get('demos', '?')} demos, "
             f"{first.get('episodes', '?')} test episodes per task (95 % Wilson intervals)")
    draw_plots(folder, result["rows"], title)
    return [p for p in (folder / "success.png", folder / "stages.png") if p.is_file()]
