"""hf:// references: parsed as huggingface_hub spells them, resolved from the shared cache offline, and refused
with a message that says what to do when the cache lacks them."""

from __future__ import annotations

from pathlib import Path

import pytest

from bimanualshift.utils.hub import HubRef, parse_hub_ref, resolve_local

COMMIT = "0123456789abcdef0123456789abcdef01234567"


def populate_cache(cache: Path, repo_id: str, files: dict[str, bytes], repo_type: str = "model",
                   revision: str = "main", commit: str = COMMIT) -> Path:
    """The layout huggingface_hub's download leaves in its cache: blobs, a snapshot of links, a ref."""
    import hashlib

    storage = cache / f"{repo_type}s--{repo_id.replace('/', '--')}"
    for name, data in files.items():
        blob = storage / "blobs" / hashlib.sha256(data).hexdigest()
        blob.parent.mkdir(parents=True, exist_ok=True)
        blob.write_bytes(data)
        link = storage / "snapshots" / commit / name
        link.parent.mkdir(parents=True, exist_ok=True)
        link.symlink_to(Path(*[".."] * (len(Path(name).parts) + 1), "blobs", blob.name))
    (storage / "refs").mkdir(exist_ok=True)
    (storage / "refs" / revision).write_text(commit)
    return storage / "snapshots" / commit


@pytest.fixture
def offline_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("HF_HUB_CACHE", str(tmp_path / "hub"))
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    return tmp_path / "hub"


@pytest.mark.parametrize("text, ref", [
    ("hf://lab/prior", HubRef("lab/prior")),
    ("hf://lab/prior@v1", HubRef("lab/prior", revision="v1")),
    ("hf://datasets/lab/demos", HubRef("lab/demos", "dataset")),
    ("hf://datasets/lab/demos@main/train", HubRef("lab/demos", "dataset", "main", "train")),
    ("hf://models/lab/prior/best", HubRef("lab/prior", path="best")),
])
def test_parses_huggingface_hub_spelling(text: str, ref: HubRef) -> None:
    assert parse_hub_ref(text) == ref
    assert parse_hub_ref(str(ref)) == ref


@pytest.mark.parametrize("text, match", [
    ("hf://prior", "names ORG/NAME"),
    ("hf://lab/bad--name", "not a valid repository name"),
    ("hf://lab/prior@", "nothing after '@'"),
    ("lab/prior", "not a hub reference"),
])
def test_refuses_malformed_references(text: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        parse_hub_ref(text)


def test_resolves_from_the_cache_offline(offline_cache: Path) -> None:
    snapshot = populate_cache(offline_cache, "lab/demos", {"train/a/episode_000000.h5": b"x", "README.md": b"#"},
                              repo_type="dataset", revision="v2")
    assert resolve_local("hf://datasets/lab/demos@v2/train") == snapshot / "train"
    assert (resolve_local("hf://datasets/lab/demos@v2") / "README.md").read_bytes() == b"#"
    assert resolve_local("data/local") == Path("data/local")  # a folder is left alone
    with pytest.raises(FileNotFoundError, match="has no 'validation'"):
        resolve_local("hf://datasets/lab/demos@v2/validation")


def test_missing_from_cache_says_how_to_get_it(offline_cache: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"not in the local cache .*HF_HUB_OFFLINE=1 is set.*bimanualshift "
                                                r"pull hf://lab/absent"):
        resolve_local("hf://lab/absent")
    populate_cache(offline_cache, "lab/prior", {"config.json": b"{}"})
    with pytest.raises(FileNotFoundError, match="not in the local cache"):
        resolve_local("hf://lab/prior@v9")  # a revision never downloaded
