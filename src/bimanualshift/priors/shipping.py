"""Shipping a pretrained prior in the repository (`bimanualshift ship-prior`): copy its weights, config and model
card into ``checkpoints/<name>/``, refuse anything over the size limit, and give the card a results block that
`bimanualshift report` fills from ``results/priors.json`` (or another result file)."""

from __future__ import annotations

import shutil
from pathlib import Path

from bimanualshift.priors.base import SHIPPED_DIR, UnimanualPrior
from bimanualshift.utils.io import atomic_write_text

MAX_MB = 25.0
FILES = ("model.safetensors", "config.json", "README.md")
RESULTS_BLOCK = """
## Measured single-arm success

<!-- results:{results} -->
<!-- /results:{results} -->

Generated from `results/{results}.json` by `bimanualshift report --readme checkpoints/{name}/README.md`.
"""


def ship_prior(source: str | Path, name: str, destination: str | Path = SHIPPED_DIR, max_mb: float = MAX_MB,
               results: str = "priors") -> Path:
    """``results`` names the result file (``results/<results>.json``) whose table fills the card."""
    source, target = Path(source), Path(destination) / name
    missing = [f for f in FILES if not (source / f).is_file()]
    if missing:
        raise FileNotFoundError(f"{source} lacks {missing}: ship the best/ folder of a `bimanualshift pretrain` run")
    UnimanualPrior.from_pretrained(source)  # refuses broken checkpoints before anything is copied
    size_mb = sum((source / f).stat().st_size for f in FILES) / 2**20
    if size_mb > max_mb:
        raise ValueError(f"{source} is {size_mb:.1f} MB; shipped checkpoints must stay under {max_mb} MB "
                         "(pick a smaller size, or host it elsewhere and load it from a path)")
    target.mkdir(parents=True, exist_ok=True)
    for f in FILES[:2]:
        tmp = target / f".{f}.tmp"
        shutil.copyfile(source / f, tmp)
        tmp.replace(target / f)
    card = (source / "README.md").read_text()
    if f"<!-- results:{results} -->" not in card:
        card = card.rstrip() + "\n" + RESULTS_BLOCK.format(name=name, results=results)
    atomic_write_text(target / "README.md", card)
    return target
