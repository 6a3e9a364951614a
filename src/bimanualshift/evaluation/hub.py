"""Sharing on the Hugging Face Hub (`bimanualshift push` / `pull`): a prior, a BimanualShift checkpoint (with its
memory bank, and its prior when that is neither shipped nor on the hub) or a dataset is staged as the files the
repository will hold, given a model card written from its config and result files, and uploaded with
huggingface_hub. Only safetensors, JSON, parquet, video and HDF5 files are staged: never pickle."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bimanualshift import __version__
from bimanualshift.data.episode import EPISODE_GLOB
from bimanualshift.methods.bimanualshift import BUNDLED_PRIOR, MEMORY_FILE
from bimanualshift.priors.base import PRIORS, resolve_prior_path
from bimanualshift.utils.config_files import read_json_file
from bimanualshift.utils.hub import HubRef, as_hub_ref, is_hub_ref, offline, snapshot
from bimanualshift.utils.io import atomic_write_json, atomic_write_text

# Files a pickle loader would run; staged folders refuse them by name (safetensors and JSON are what load here).
PICKLE_SUFFIXES = {".pkl", ".pickle", ".pt", ".pth", ".ckpt", ".bin", ".joblib", ".npz"}
MODEL_FILES = ("config.json", "model.safetensors")
CHECKPOINT_EXTRAS = (MEMORY_FILE, "train_config.json", "history.json", "summary.json")


@dataclass(frozen=True)
class Staged:
    folder: Path  # exactly what the repository will hold
    kind: str
    repo_type: str  # model | dataset
    files: list[str]


def detect_kind(folder: Path) -> str:
    """prior, checkpoint (a BimanualShift residual run's best/) or dataset (LeRobot v3.0, or task folders of
    episode files); a clear error for anything else."""
    if (folder / "meta" / "info.json").is_file() or any(folder.glob(f"*/{EPISODE_GLOB}")):
        return "dataset"
    if not (folder / "config.json").is_file():
        raise FileNotFoundError(f"{folder} holds no config.json, LeRobot meta/info.json or <task>/{EPISODE_GLOB}: "
                                "push a prior's folder, a BimanualShift run's best/ or a dataset folder")
    kind = read_json_file(folder / "config.json").get("type")
    if kind == "bimanualshift":
        return "checkpoint"
    if kind in PRIORS:
        return "prior"
    raise ValueError(f"{folder}/config.json has type {kind!r}: neither a prior ({sorted(PRIORS)}) nor a "
                     "BimanualShift checkpoint")


def _refuse_pickle(files: list[Path], root: Path) -> None:
    bad = [str(p.relative_to(root)) for p in files if p.suffix.lower() in PICKLE_SUFFIXES]
    if bad:
        raise ValueError(f"{root} holds files a pickle loader would read ({', '.join(bad[:5])}): only safetensors, "
                         "JSON and the dataset formats are shared; remove them or move them out of the folder")


def _copy(src: Path, dst: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, dst)


def stage(folder: str | Path, out: str | Path, results: str | Path | None = None, method: str = "",
          repo_id: str = "ORG/NAME") -> Staged:
    """Write into ``out`` (emptied first) the files ``folder`` is shared as, with a README.md model card that
    names ``repo_id``."""
    folder, out = Path(folder), Path(out)
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: no such folder to push")
    kind = detect_kind(folder)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    if kind == "dataset":
        files = [p for p in sorted(folder.rglob("*")) if p.is_file() and ".cache" not in p.parts]
        _refuse_pickle(files, folder)
        for p in files:
            _copy(p, out / p.relative_to(folder))
        card = dataset_card(folder, out, results, method, repo_id)
    else:
        missing = [f for f in MODEL_FILES if not (folder / f).is_file()]
        if missing:
            raise FileNotFoundError(f"{folder} lacks {missing}: push a whole checkpoint folder")
        for f in MODEL_FILES:
            _copy(folder / f, out / f)
        if kind == "prior":
            card = prior_card(folder, results, method, repo_id)
        else:
            extras = [f for f in CHECKPOINT_EXTRAS if (folder / f).is_file() or (folder.parent / f).is_file()]
            for f in extras:
                _copy(folder / f if (folder / f).is_file() else folder.parent / f, out / f)
            config = read_json_file(out / "config.json", "BimanualShift checkpoint")
            bundled = _bundle_prior(config, out)
            card = checkpoint_card(config, out, bundled, results, method, repo_id)
    atomic_write_text(out / "README.md", card)
    names = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())
    return Staged(out, kind, "dataset" if kind == "dataset" else "model", names)


def _bundle_prior(config: dict[str, Any], out: Path) -> str:
    """A checkpoint's prior named on the hub stays a reference; any other (a shipped name, a run's folder) is
    copied into ``prior/`` so the repository loads anywhere. Returns the prior's original name."""
    prior = str(config["prior"])
    config.setdefault("prior_source", prior)
    if is_hub_ref(prior):
        return prior
    source = resolve_prior_path(prior)
    for f in MODEL_FILES:
        _copy(source / f, out / BUNDLED_PRIOR / f)
    if (source / "README.md").is_file():
        _copy(source / "README.md", out / BUNDLED_PRIOR / "README.md")
    config["prior"] = BUNDLED_PRIOR
    atomic_write_json(out / "config.json", config)
    return prior


def _front_matter(tags: list[str]) -> str:
    lines = ["---", "library_name: bimanualshift", "license: apache-2.0", "pipeline_tag: robotics", "tags:"]
    lines += [f"- {t}" for t in ["robotics", "bimanualshift", *tags]]
    return "\n".join(lines + ["---", ""])


def results_section(results: str | Path | None, method: str, task: str = "") -> str:
    """The success rows a result file (a bench or study folder's summary.json, or a prior report) records for
    ``method`` (on ``task`` alone, if given), with their 95 % intervals and the command, commit and seeds behind
    them."""
    if not results:
        return ("## Measured success\n\nNo result file was given to `bimanualshift push --results`: this card "
                "reports no success figures.\n")
    path = Path(results)
    path = path / "summary.json" if path.is_dir() else path
    data = read_json_file(path, "result file")
    rows = [r for r in data.get("rows", []) if isinstance(r, dict)]
    lines = ["| task | success (95 % interval) | episodes |", "|---|---|---|"]
    for r in rows:
        if "prior" in r and "tasks" in r:  # a prior report: a row per prior, its tasks inside
            if method and r["prior"] != method:
                continue
            lines += [f"| {t} | {_pct(v['success'], v.get('ci95'))} | {v['episodes']} |" for t, v in r["tasks"].items()]
            lines.append(f"| **mean** | **{100 * r['mean_success']:.1f} %** | |")
        elif (not method or r.get("method") == method) and (not task or r.get("task") == task):
            lines.append(f"| {r.get('task')} | {_pct(r['success'], r.get('ci95'))} | {r.get('episodes', '')} |")
    if len(lines) == 2:
        raise ValueError(f"{path} records no rows for method {method!r}{f' on {task}' if task else ''}: pass "
                         "--method with a method (or prior) it holds")
    seeds = data.get("seeds", {}) if isinstance(data.get("seeds"), dict) else {}
    split, used = next(((k, v) for k, v in seeds.items() if k in ("test", "validation_rollouts") and v), ("", []))
    seed_text = f"; seeds {used[0]}–{used[-1]} ({split.replace('_', ' ')})" if isinstance(used, list) and used else ""
    return "\n".join(["## Measured success", "", *lines, "",
                      f"From `{path.as_posix()}`: produced by `{data.get('command', '?')}` at commit "
                      f"`{str(data.get('commit', '?'))[:12]}` on {data.get('created', '?')} "
                      f"({data.get('machine', '?')}; threads {data.get('threads', '?')}{seed_text}).", ""])


def _pct(success: float, ci: list[float] | None) -> str:
    interval = f" ({100 * ci[0]:.0f}–{100 * ci[1]:.0f})" if ci else ""
    return f"{100 * success:.0f} %{interval}"


def prior_card(folder: Path, results: str | Path | None, method: str, repo_id: str) -> str:
    existing = (folder / "README.md").read_text() if (folder / "README.md").is_file() else ""
    config = read_json_file(folder / "config.json")
    body = existing or (f"# Single-arm prior: {config.get('type')}\n\nA frozen unimanual prior for BimanualShift, "
                        f"trained on {config.get('pretrain_tasks', 'single-arm demonstrations')}.\n")
    # A shipped prior's card already carries its measured table (filled by `bimanualshift report`).
    extra = results_section(results, method) if not existing or (results and "<!-- results:" not in existing) else ""
    return (_front_matter(["prior", str(config.get("type"))]) + body.rstrip() + "\n\n" + extra
            + _usage("--prior", repo_id))


def checkpoint_card(config: dict[str, Any], out: Path, prior: str, results: str | Path | None, method: str,
                    repo_id: str) -> str:
    train = config.get("train_config") or {}  # the run's TrainConfig, saved with the checkpoint
    bank = "yes" if (out / MEMORY_FILE).is_file() else "no (trained without retrieval)"
    where = "bundled in `prior/`" if config.get("prior") == BUNDLED_PRIOR else "loaded from the hub"
    rows = [("task", config.get("task")), ("bimanual demos", config.get("demos")),
            ("frozen prior", f"`{prior}` ({where})"), ("residual steps", config.get("trained_steps")),
            ("validation loss", config.get("validation_loss")), ("memory bank", bank),
            ("segmenter", config.get("segmenter")), ("projection", config.get("use_projection"))]
    table = ["| | |", "|---|---|"] + [f"| {k} | {v} |" for k, v in rows if v is not None]
    reproduce = ("`bimanualshift train --config train_config.json` (the run's own config, in this repository) "
                 "reproduces the residual from the same demos." if (out / "train_config.json").is_file() else
                 "The run's train_config.json was not beside the checkpoint, so the card names no training command.")
    data = train.get("dataset") or {}
    if data.get("data"):
        reproduce += (f" It read {data.get('demos')} demos from `{data['data']}` (validation: "
                      f"`{data.get('validation_data')}`); `bimanualshift collect --task {config.get('task')}` "
                      "writes them on the same seeds.")
    return "\n".join([_front_matter(["bimanual", "residual", str(config.get("task"))]),
                      f"# BimanualShift: {config.get('task')}", "",
                      "A residual branch over a frozen single-arm prior, one prior for both arms "
                      f"(bimanualshift {__version__}).", "", *table, "",
                      results_section(results, method, str(config.get("task", ""))),
                      "## Reproduce", "", reproduce, "", _usage("--checkpoint", repo_id)])


def dataset_card(folder: Path, out: Path, results: str | Path | None, method: str, repo_id: str) -> str:
    info_path = folder / "meta" / "info.json"
    if info_path.is_file():
        info = read_json_file(info_path, "LeRobot info")
        what = (f"A LeRobot {info.get('codebase_version')} dataset: {info.get('total_episodes')} episodes, "
                f"{info.get('total_frames')} frames, robot `{info.get('robot_type')}`.")
        use = (f"Turn it into episodes with `bimanualshift import-lerobot hf://datasets/{repo_id} --out "
               f"data/{repo_id.split('/')[-1]}`, or load it with LeRobot.")
    else:
        tasks = {p.parent.name for p in out.glob(f"*/{EPISODE_GLOB}")}
        counts = ", ".join(f"{t} ({len(list((out / t).glob(EPISODE_GLOB)))})" for t in sorted(tasks))
        what = f"BimanualShift episodes (HDF5, one file per demo) by task: {counts}."
        use = f"Pass it as `--data hf://datasets/{repo_id}` to `train`, `pretrain` or `bench`."
    body = ["---", "license: apache-2.0", "task_categories:", "- robotics", "tags:", "- bimanualshift", "---", "",
            f"# {folder.name}", "", what, "", use, ""]
    if results:
        body.append(results_section(results, method))
    return "\n".join(body)


def _usage(flag: str, repo_id: str) -> str:
    return (f"## Use\n\nPass `{flag} hf://{repo_id}` (or `hf://{repo_id}@REVISION`) to any bimanualshift command "
            f"that takes it; `bimanualshift pull {repo_id}` downloads it into the shared Hugging Face cache first.\n")


def upload_plan(staged: Staged) -> list[dict[str, Any]]:
    """What an upload would send, file by file: the client's own commit operations (size and sha256), computed
    without a network."""
    from huggingface_hub import CommitOperationAdd

    plan = []
    for name in staged.files:
        op = CommitOperationAdd(path_in_repo=name, path_or_fileobj=str(staged.folder / name))
        plan.append({"path": name, "bytes": op.upload_info.size, "sha256": op.upload_info.sha256.hex()})
    return plan


def push(staged: Staged, repo_id: str, private: bool = False, revision: str | None = None, message: str = "",
         tag: str = "") -> str:
    """Upload ``staged`` to ``repo_id`` (created if missing); returns the commit's URL."""
    ref = as_hub_ref(repo_id, staged.repo_type)
    if offline():
        raise ConnectionError("HF_HUB_OFFLINE=1 is set, so nothing can be uploaded: unset it (`make` sets it for "
                              "the tests) or use --dry-run to see what would be sent")
    from huggingface_hub import HfApi
    from huggingface_hub.errors import HfHubHTTPError

    api = HfApi(library_name="bimanualshift", library_version=__version__)
    try:
        api.create_repo(ref.repo_id, repo_type=staged.repo_type, private=private, exist_ok=True)
        if revision:
            api.create_branch(ref.repo_id, branch=revision, repo_type=staged.repo_type, exist_ok=True)
        info = api.upload_folder(folder_path=staged.folder, repo_id=ref.repo_id, repo_type=staged.repo_type,
                                 revision=revision, commit_message=message or f"bimanualshift push ({staged.kind})")
        if tag:
            api.create_tag(ref.repo_id, tag=tag, revision=info.oid, repo_type=staged.repo_type)
    except HfHubHTTPError as err:
        status = getattr(err.response, "status_code", None)
        hint = " (log in with `hf auth login` or set HF_TOKEN)" if status in (401, 403) else ""
        raise ConnectionError(f"the hub refused the upload to {ref.repo_id}: {err}{hint}") from err
    except OSError as err:
        raise ConnectionError(f"could not reach the hub to upload {ref.repo_id}: {err}") from err
    return str(info.commit_url)


def pull(text: str, repo_type: str = "") -> tuple[Path, str, HubRef]:
    """Download ``ORG/NAME[@REV]`` (or an ``hf://`` reference) into the shared cache; returns (its local folder,
    its kind, the reference), after checking that what arrived loads."""
    ref = as_hub_ref(text, repo_type or "model")
    folder = snapshot(ref.repo) / ref.path
    kind = detect_kind(folder)
    if kind == "prior":
        from bimanualshift.priors.base import UnimanualPrior

        UnimanualPrior.from_pretrained(folder)
    elif kind == "checkpoint":
        from bimanualshift.methods.bimanualshift import checkpoint_prior
        from bimanualshift.residual.checkpoint import read_residual_config

        config, _ = read_residual_config(folder)
        resolve_prior_path(checkpoint_prior(folder, str(config["prior"])))
    return folder, kind, ref

