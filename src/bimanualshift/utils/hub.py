"""``hf://`` references to the Hugging Face Hub, accepted wherever a prior, a checkpoint or a data folder is.

The spelling is huggingface_hub's own (``HfFileSystem``): ``hf://ORG/NAME`` is a model repository,
``hf://datasets/ORG/NAME`` a dataset repository, ``@REVISION`` (branch, tag or commit) pins a version and a path
after the name points inside the snapshot (``hf://datasets/ORG/NAME@v1/train``). A reference resolves to a snapshot
in the shared Hugging Face cache, downloaded once; with ``HF_HUB_OFFLINE=1`` only the cache is read. huggingface_hub
is imported on first use, so commands that never meet a reference do not pay for it.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

SCHEME = "hf://"
REPO_TYPES = {"models": "model", "datasets": "dataset"}
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclass(frozen=True)
class HubRef:
    repo_id: str  # ORG/NAME
    repo_type: str = "model"  # model | dataset
    revision: str | None = None  # None: the default branch
    path: str = ""  # inside the snapshot

    def __str__(self) -> str:
        kind = "datasets/" if self.repo_type == "dataset" else ""
        rev = f"@{self.revision}" if self.revision else ""
        return f"{SCHEME}{kind}{self.repo_id}{rev}" + (f"/{self.path}" if self.path else "")

    @property
    def repo(self) -> HubRef:
        """The same reference without its path inside the snapshot."""
        return HubRef(self.repo_id, self.repo_type, self.revision)


def is_hub_ref(text: str | Path) -> bool:
    return isinstance(text, str) and text.startswith(SCHEME)


def parse_hub_ref(text: str, repo_type: str = "model") -> HubRef:
    """``hf://[datasets/]ORG/NAME[@REV][/PATH]`` as a ``HubRef``; ``repo_type`` applies when the text names none."""
    if not is_hub_ref(text):
        raise ValueError(f"{text!r} is not a hub reference; write hf://ORG/NAME or hf://datasets/ORG/NAME")
    parts = text[len(SCHEME):].strip("/").split("/")
    if parts and parts[0] in REPO_TYPES:
        repo_type = REPO_TYPES[parts.pop(0)]
    if len(parts) < 2:
        raise ValueError(f"{text!r}: a hub reference names ORG/NAME (e.g. hf://my-lab/peract-ur5e or "
                         "hf://datasets/my-lab/block-threading)")
    org, name = parts[0], parts[1]
    name, _, revision = name.partition("@")
    for piece in (org, name):
        if not _NAME.match(piece) or "--" in piece or ".." in piece:
            raise ValueError(f"{text!r}: {piece!r} is not a valid repository name (letters, digits, '-', '_', '.'; "
                             "no '--' or '..')")
    if "@" in text and not revision:
        raise ValueError(f"{text!r}: nothing after '@'; give a branch, tag or commit, or drop the '@'")
    return HubRef(f"{org}/{name}", repo_type, revision or None, "/".join(parts[2:]))


def as_hub_ref(text: str, repo_type: str = "model") -> HubRef:
    """``parse_hub_ref`` of an ``hf://`` reference, or of a bare ``ORG/NAME[@REV]`` (what `push` and `pull` take)."""
    return parse_hub_ref(text if is_hub_ref(text) else f"{SCHEME}{text}", repo_type)


def cache_dir() -> Path:
    """The shared Hugging Face cache (``HF_HUB_CACHE``, else ``HF_HOME/hub``), read when called."""
    if os.environ.get("HF_HUB_CACHE"):
        return Path(os.environ["HF_HUB_CACHE"]).expanduser()
    home = os.environ.get("HF_HOME") or os.path.join(os.environ.get("XDG_CACHE_HOME", "~/.cache"), "huggingface")
    return Path(home).expanduser() / "hub"


def offline() -> bool:
    return os.environ.get("HF_HUB_OFFLINE", "").strip().lower() in ("1", "true", "yes", "on")


def snapshot(ref: HubRef, allow_patterns: list[str] | None = None) -> Path:
    """The local snapshot folder of ``ref``'s repository (downloaded into the shared cache unless it is there)."""
    from huggingface_hub import snapshot_download
    from huggingface_hub.errors import (
        GatedRepoError,
        LocalEntryNotFoundError,
        RepositoryNotFoundError,
        RevisionNotFoundError,
    )

    from bimanualshift import __version__

    try:
        folder = snapshot_download(ref.repo_id, repo_type=ref.repo_type, revision=ref.revision,
                                   cache_dir=str(cache_dir()), local_files_only=offline(),
                                   allow_patterns=allow_patterns, library_name="bimanualshift",
                                   library_version=__version__)
    except RevisionNotFoundError as err:
        raise FileNotFoundError(f"{ref.repo}: the repository has no revision {ref.revision!r} (a branch, tag or "
                                "commit)") from err
    except (RepositoryNotFoundError, GatedRepoError) as err:
        raise FileNotFoundError(f"{ref.repo}: no such {ref.repo_type} repository on the hub, or it is private or "
                                "gated (log in with `hf auth login`, or check the name)") from err
    except LocalEntryNotFoundError as err:
        why = "HF_HUB_OFFLINE=1 is set" if offline() else "the hub could not be reached"
        raise FileNotFoundError(f"{ref.repo} is not in the local cache ({cache_dir()}) and {why}: run "
                                f"`bimanualshift pull {ref.repo}` where the hub is reachable (unset HF_HUB_OFFLINE), "
                                "or give a local folder") from err
    return Path(folder)


def resolve_local(text: str | Path, repo_type: str = "model") -> Path:
    """A local folder for ``text``: the folder itself, or the cached snapshot (and path inside it) of an ``hf://``
    reference."""
    if not is_hub_ref(text):
        return Path(text)
    ref = parse_hub_ref(str(text), repo_type)
    local = snapshot(ref.repo) / ref.path
    if not local.exists():
        raise FileNotFoundError(f"{text}: the snapshot of {ref.repo} has no {ref.path!r}")
    return local
