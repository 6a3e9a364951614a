"""Commands that share: push a prior, checkpoint or dataset to the Hugging Face Hub, and pull one by name."""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass
from typing import Annotated, Literal

import tyro


@dataclass
class PushArgs:
    # a prior's folder (a shipped name works too), a BimanualShift run's best/, or a dataset folder
    path: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="PATH")]
    # ORG/NAME on the hub
    repo_id: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="REPO_ID")]
    results: str = ""  # a result file or bench/study folder whose success rows the model card shows
    method: str = ""  # the method (or prior) whose rows those are
    revision: str = ""  # a branch to commit to (created if missing; default: main)
    tag: str = ""  # tag the new commit, e.g. v1
    private: bool = False  # create the repository private
    message: str = ""  # the commit message
    dry_run: bool = False  # stage the files and print what would be uploaded (path, bytes, sha256); no network
    stage: str = ""  # keep the staged folder here (default: a temporary folder, removed afterwards)


def push(args: PushArgs) -> None:
    from pathlib import Path

    from bimanualshift.evaluation.hub import push as upload
    from bimanualshift.evaluation.hub import stage, upload_plan
    from bimanualshift.priors.base import resolve_prior_path
    from bimanualshift.utils.hub import as_hub_ref

    source = Path(args.path)
    if not source.is_dir():
        source = resolve_prior_path(args.path)  # a shipped prior by name; a clear error for anything else
    with tempfile.TemporaryDirectory(prefix="bimanualshift-push-") as tmp:
        repo_id = as_hub_ref(args.repo_id).repo_id
        staged = stage(source, args.stage or Path(tmp) / "repo", args.results or None, args.method, repo_id)
        plan = upload_plan(staged)
        total = sum(f["bytes"] for f in plan) / 2**20
        print(f"{staged.kind} {source} -> {staged.repo_type} repository {args.repo_id}: {len(plan)} files, "
              f"{total:.2f} MB")
        if args.dry_run:
            print(json.dumps(plan, indent=2))
            print(f"dry run: nothing was uploaded{f'; staged files in {staged.folder}' if args.stage else ''}")
            return
        url = upload(staged, args.repo_id, args.private, args.revision or None, args.message, args.tag)
    print(f"pushed: {url}")


@dataclass
class PullArgs:
    # ORG/NAME[@REVISION] (or hf://[datasets/]ORG/NAME[@REVISION])
    repo_id: Annotated[str, tyro.conf.Positional, tyro.conf.arg(metavar="REPO_ID")]
    repo_type: Literal["model", "dataset"] = "model"  # dataset: a LeRobot or episodes dataset


def pull(args: PullArgs) -> None:
    from bimanualshift.evaluation.hub import pull as download

    folder, kind, ref = download(args.repo_id, args.repo_type)
    flag = {"prior": "--prior", "checkpoint": "--checkpoint", "dataset": "--data"}[kind]
    print(f"{kind} {ref} in {folder}")
    print(f"use it as {flag} {ref} (read from the cache from now on; HF_HUB_OFFLINE=1 keeps it offline)")
