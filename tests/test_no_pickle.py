"""No module loads or writes pickles: not on disk, not on the wire."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = [
    (re.compile(r"^\s*(import|from)\s+(pickle|cPickle|dill|cloudpickle|joblib|shelve|marshal)\b", re.M), "imports"),
    (re.compile(r"\bpickle\.(loads?|dumps?|Unpickler|Pickler)\b"), "calls pickle"),
    (re.compile(r"allow_pickle\s*=\s*True"), "allows pickles in numpy"),
]
TORCH_LOAD = re.compile(r"torch\.load\(([^)]*)\)")


def sources() -> list[Path]:
    return sorted(p for folder in ("src", "benchmarks", "examples") for p in (ROOT / folder).rglob("*.py"))


def test_no_module_uses_pickle() -> None:
    found = []
    for path in sources():
        text = path.read_text()
        for pattern, what in FORBIDDEN:
            found += [f"{path.relative_to(ROOT)}: {what}: {m.group(0).strip()}" for m in pattern.finditer(text)]
        found += [f"{path.relative_to(ROOT)}: torch.load without weights_only=True" for m in TORCH_LOAD.finditer(text)
                  if "weights_only=True" not in m.group(1)]
    assert not found, "\n".join(found)


def test_the_check_catches_what_it_should(tmp_path: Path) -> None:
    bad = "import pickle\nx = pickle.loads(b'')\ntorch.load(f)\nnp.load(f, allow_pickle=True)\n"
    hits = [what for pattern, what in FORBIDDEN if pattern.search(bad)]
    assert hits == ["imports", "calls pickle", "allows pickles in numpy"]
    assert [m for m in TORCH_LOAD.finditer(bad) if "weights_only=True" not in m.group(1)]
    assert not [m for m in TORCH_LOAD.finditer("torch.load(f, weights_only=True)")
                if "weights_only=True" not in m.group(1)]
