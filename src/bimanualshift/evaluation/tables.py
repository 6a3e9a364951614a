"""Every table the project prints or writes: markdown tables of result files (README blocks, table.md files) and
the console tables of the commands."""

from __future__ import annotations

from typing import Any

from rich.console import Console
from rich.table import Table


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
    mean_label = "**mean, original nine**" if rows[0].get("mean_success_added_skills") is not None else "**mean**"
    lines.append(f"| {mean_label} | " + " | ".join(f"**{100 * r['mean_success']:.1f} %**" for r in rows) + " |")
    if rows[0].get("mean_success_added_skills") is not None:
        lines.append("| mean, added skills | " + " | ".join(
            f"{100 * r['mean_success_added_skills']:.1f} %" for r in rows) + " |")
    lines.append("| parameters | " + " | ".join(f"{r['parameters']:,}" for r in rows) + " |")
    lines.append("| ms per arm (2 threads) | " + " | ".join(f"{r['inference_ms_per_arm']}" for r in rows) + " |")
    lines.append("| training time | " + " | ".join(
        f"{r['training_time_s'] / 60:.0f} min" if r.get("training_time_s") else "–" for r in rows) + " |")
    episodes = rows[0]["tasks"][tasks[0]]["episodes"]
    split = next(iter(result.get("seeds") or {"test": []}))  # a candidate's choice ran on validation seeds
    return "\n".join([*lines, "", f"{episodes} {split} episodes per task. " + _footer(result)]) + "\n"


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
        # a field a row lacks stays blank; one it holds as null (not measured for it) reads as a dash
        cells = [_number(r[c]) if isinstance(r.get(c), float) else "–" if c in r and r[c] is None
                 else str(r.get(c, "")) for c in columns]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(f"Produced by `{result['command']}` at commit `{result['commit'][:12]}` on {result['created']} "
                 f"({result['machine']}); wall time {result['wall_time_s'] / 60:.1f} min. {result['notes']}.")
    return "\n".join(lines) + "\n"


def coverage_table(result: dict[str, Any]) -> str:
    """Arm-frame coverage: each bimanual goal object's x / y / yaw range in each arm's frame against its
    single-arm task's, and the share of bimanual poses inside."""

    def span(r: list[list[float]] | None, i: int, scale: float = 100.0) -> str:
        return "–" if r is None else f"{scale * r[i][0]:.0f}…{scale * r[i][1]:.0f}"

    lines = ["| bimanual task | object | arm | x (cm) | y (cm) | yaw (°) | single-arm task | x (cm) | y (cm) | yaw (°) "
             "| covered | worst gap (cm) |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    deg = 180 / 3.141592653589793
    for r in result["rows"]:
        b, s = r["bimanual_range"], r["single_arm_range"]
        inside = "no single-arm skill" if r["inside"] is None else f"{100 * r['inside']:.0f} %"
        lines.append(f"| {r['task']} | {r['obj']} | {r['arm']} | {span(b, 0)} | {span(b, 1)} | {span(b, 2, deg)} | "
                     f"{r['single_arm_task'] or '–'} | {span(s, 0)} | {span(s, 1)} | {span(s, 2, deg)} | {inside} | "
                     f"{r.get('farthest_cm', '–')} |")
    return "\n".join([*lines, "", _footer(result)]) + "\n"


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


VIEWS = ("", "headline")


def table_for(result: dict[str, Any], view: str = "") -> str:
    """Expert measurements, success rates of methods, or a generic table of whatever the rows hold. ``view``
    "headline" leaves a study's stage-wise tables out (the README shows the success table and its targets)."""
    if view not in VIEWS:
        raise ValueError(f"unknown results-block view {view!r}: use one of {', '.join(v for v in VIEWS if v)} "
                         "(results:NAME#VIEW), or none")
    first = result["rows"][0] if result["rows"] else {}
    if result.get("bench"):
        from bimanualshift.evaluation.targets import study_targets

        # derived from the rows (and the stored paired counts), never stored alone
        targets = study_targets(result.get("study", ""), result["rows"], result.get("paired"))
        stages = "" if view == "headline" else stage_table(result["rows"])
        parts = [study_table(result.get("study", ""), result["rows"]), stages, targets_table(targets)]
        return "\n".join([*(p for p in parts if p), _footer(result)]) + "\n"
    if "prior" in first and "tasks" in first:
        return priors_table(result)
    if "segmenter" in first and "kept" in first:
        return projection_quality_table(result)
    if "bimanual" in first:
        return experts_table(result)
    if "single_arm_task" in first:
        return coverage_table(result)
    if "control_step_ms" in first:
        return sim_profile_table(result)
    if "method" in first and "success" in first:
        return success_table(result)
    return generic_table(result)


def stage_table(rows: list[dict[str, Any]]) -> str:
    """Stage-wise success (Table III / Fig. 11b layout): one row per method and task, one column per stage."""
    staged = [r for r in rows if r.get("stages")]
    if not staged:
        return ""
    lines = []
    for task in dict.fromkeys(r["task"] for r in staged):
        mine = [r for r in staged if r["task"] == task]
        names = [s["stage"] for s in mine[0]["stages"]]
        lines += [f"**{task.replace('_', ' ')}: stage-wise success (%)**", "",
                  "| method | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
        for r in mine:
            extra = f" ({degradation_text(r['degradation'])})" if "degradation" in r else ""
            lines.append(f"| {row_label(r)}{extra} | " + " | ".join(f"{100 * s['success']:.0f}" for s in r["stages"])
                         + " |")
        lines.append("")
    return "\n".join(lines)


def degradation_text(degradation: float) -> str:
    """A perturbation's relative drop from the unperturbed success; a gain is said as one, not as a negative drop."""
    if round(100 * degradation) < 0:
        return f"{-100 * degradation:.0f} % above unperturbed"
    return f"{100 * degradation:.0f} % degradation"


def row_label(row: dict[str, Any]) -> str:
    """The method, the study run it belongs to and the perturbation it was tested under, where there are some."""
    return (row["method"] + (f" [{row['run']}]" if "run" in row else "")
            + (f" ({row['perturbation']})" if "perturbation" in row else ""))


TIER_ORDER = ("Coordination", "Collaboration", "Precision")


def study_table(study: str, rows: list[dict[str, Any]]) -> str:
    """A study's success table: Table II's tiered layout for the real-world study, Table III's stage averages for
    its generalisation study, Table I's for the others."""
    layouts = {"realworld": tiered_table, "realworld_generalisation": stage_average_table}
    return layouts.get(study, bench_table)(rows)


def rate_cell(row: dict[str, Any] | None) -> str:
    """A success rate and its 95 % interval in percent, "45 (36–55)"; "–" where nothing was measured."""
    if row is None:
        return "–"
    return f"{100 * row['success']:.0f} ({100 * row['ci95'][0]:.0f}–{100 * row['ci95'][1]:.0f})"


def stage_average(row: dict[str, Any]) -> float:
    """The mean of a row's stage-wise success rates (Table III's "average"), or its success without stages."""
    stages = row.get("stages") or []
    return sum(s["success"] for s in stages) / len(stages) if stages else row["success"]


def degradation_rates(rows: list[dict[str, Any]]) -> dict[tuple[str, str], float]:
    """(method, perturbation) -> the relative drop of its stage average from its own unperturbed one (Table III's
    RDR); a method with a zero unperturbed average has none."""
    base = {r["method"]: stage_average(r) for r in rows if r.get("perturbation", "none") == "none"}
    return {(r["method"], r["perturbation"]): (base[r["method"]] - stage_average(r)) / base[r["method"]]
            for r in rows if r.get("perturbation", "none") != "none" and base.get(r["method"])}


def stage_average_table(rows: list[dict[str, Any]]) -> str:
    """Table III's layout: a row per condition; per method the stage average, the last stage's success and the
    relative degradation from its own unperturbed average."""
    methods = list(dict.fromkeys(r["method"] for r in rows))
    cell = {(r["method"], r.get("perturbation", "none")): r for r in rows}
    rdr = degradation_rates(rows)
    head = ["condition"] + [f"{m} {what}" for m in methods for what in ("average", "last stage", "RDR")]
    lines = ["| " + " | ".join(head) + " |", "|---|" + "---|" * (len(head) - 1)]
    for condition in dict.fromkeys(r.get("perturbation", "none") for r in rows):
        cells = []
        for m in methods:
            r = cell.get((m, condition))
            if r is None:
                cells += ["–"] * 3
                continue
            rate = rdr.get((m, condition))
            cells += [f"{100 * stage_average(r):.1f}", f"{100 * r['success']:.0f}",
                      "–" if rate is None else f"{100 * rate:.0f} %"]
        lines.append(f"| {condition.replace('_', ' ')} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def task_tier(task: str) -> tuple[str, int]:
    """Where the paper tabulates ``task``: its tier and keyframe count (``Task.tier``, ``Task.paper_keyframes``);
    a task this process does not know (or the paper does not tabulate) has neither."""
    from bimanualshift.sim.task_registry import task_class

    try:
        cls = task_class(task)
    except KeyError:
        return "", 0
    return cls.tier, cls.paper_keyframes


def tiered_table(rows: list[dict[str, Any]]) -> str:
    """Table II's layout: a row per task (tier, task, the paper's keyframe count), a column per method and run,
    then the average over the tasks."""
    labels = list(dict.fromkeys(row_label(r) for r in rows))
    cell = {(row_label(r), r["task"]): r for r in rows}
    tasks = [t for t in dict.fromkeys(r["task"] for r in rows) if t != "average"]
    tiers = {t: task_tier(t) for t in tasks}
    order = {tier: i for i, tier in enumerate(TIER_ORDER)}
    tasks.sort(key=lambda t: order.get(tiers[t][0], len(order)))  # stable: the study's order within a tier

    lines = ["| tier | task | keyframes | " + " | ".join(labels) + " |", "|---|---|---|" + "---|" * len(labels)]
    for task in tasks:
        tier, keyframes = tiers[task]
        lines.append(f"| {tier or '–'} | {task.replace('_', ' ')} | {keyframes or '–'} | "
                     + " | ".join(rate_cell(cell.get((label, task))) for label in labels) + " |")
    if any(r["task"] == "average" for r in rows):
        lines.append("| – | average | – | " + " | ".join(rate_cell(cell.get((label, "average"))) for label in labels)
                     + " |")
    return "\n".join(lines) + "\n"


def bench_table(rows: list[dict[str, Any]]) -> str:
    """Table I's layout: one row per method (and perturbation), one column per task, then the average."""
    tasks = list(dict.fromkeys(r["task"] for r in rows))
    methods = list(dict.fromkeys(row_label(r) for r in rows))
    cell = {(row_label(r), r["task"]): r for r in rows}
    lines = ["| method | " + " | ".join(t.replace("_", " ") for t in tasks) + " |", "|---|" + "---|" * len(tasks)]
    for method in methods:
        lines.append(f"| {method} | " + " | ".join(rate_cell(cell.get((method, task))) for task in tasks) + " |")
    return "\n".join(lines) + "\n"


def targets_table(targets: list[dict[str, Any]]) -> str:
    if not targets:
        return ""
    verdict = {True: "met", False: "**missed**", None: "not measured"}
    lines = ["| target | measured | |", "|---|---|---|"]
    lines += [f"| {t['target']} | {t['measured']} | {verdict[t['met']]} |" for t in targets]
    return "\n".join(lines) + "\n"


def print_success_table(rows: list[dict[str, Any]], title: str) -> None:
    table = Table(title=title)
    for col in ("task", "method", "success", "95% CI", "episodes"):
        table.add_column(col, justify="right" if col not in ("task", "method") else "left")
    for r in rows:
        table.add_row(r["task"], r["method"], f"{100 * r['success']:.1f} %",
                      f"[{100 * r['ci95'][0]:.1f}, {100 * r['ci95'][1]:.1f}]", str(r["episodes"]))
    Console().print(table)


def print_study_status(rows: list[dict[str, Any]], name: str) -> None:
    """One table per run folder: a row per method, a column per task, each cell recorded/planned rollouts."""
    for out in dict.fromkeys(r["out"] for r in rows):
        mine = [r for r in rows if r["out"] == out]
        tasks = list(dict.fromkeys(r["task"] for r in mine))
        table = Table(title=f"study {name}: {out} (recorded / planned rollouts)")
        table.add_column("method")
        for task in tasks:
            table.add_column(task, justify="right")
        for method in dict.fromkeys(r["method"] for r in mine):
            cells = {r["task"]: r for r in mine if r["method"] == method}
            table.add_row(method, *(_status_cell(cells[t]) for t in tasks))
        Console().print(table)
    done, planned = sum(r["recorded"] for r in rows), sum(r["planned"] for r in rows)
    print(f"{done} of {planned} rollouts recorded")


def _status_cell(row: dict[str, Any]) -> str:
    text = f"{row['recorded']}/{row['planned']}"
    return f"[green]{text}[/green]" if row["recorded"] == row["planned"] else text


def print_projection_quality(rows: list[dict[str, Any]]) -> None:
    table = Table(title="arm-conditioned projection: voxels kept (own arm + goal) / removed (other arm)")
    for col in ("task", "segmenter", "arm", "kept", "removed", "keyframes"):
        table.add_column(col)
    for r in rows:
        table.add_row(r["task"], r["segmenter"], r["arm"], f"{r['kept']:.3f}", f"{r['removed']:.3f}",
                      str(r["keyframes"]))
    Console().print(table)


def print_prior_report(rows: list[dict[str, Any]], tasks: list[str], episodes: int) -> None:
    table = Table(title=f"single-arm priors ({episodes} test seeds per task)")
    table.add_column("task")
    for row in rows:
        table.add_column(row["prior"], justify="right")
    for task in tasks:
        table.add_row(task, *[f"{100 * r['tasks'][task]['success']:.0f} % "
                              f"[{100 * r['tasks'][task]['ci95'][0]:.0f}, {100 * r['tasks'][task]['ci95'][1]:.0f}]"
                              for r in rows])
    table.add_row("mean", *[f"{100 * r['mean_success']:.1f} %" for r in rows])
    table.add_row("parameters", *[f"{r['parameters']:,}" for r in rows])
    table.add_row("ms per arm", *[f"{r['inference_ms_per_arm']}" for r in rows])
    Console().print(table)
