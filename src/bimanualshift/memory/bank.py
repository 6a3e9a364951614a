"""The memory bank M of verified successful executions (paper Eq. 8-9).

Each entry is keyed by K = [E_text(l); E_vision(o_0)]: the instruction embedding and a vision embedding of the
episode's first observation, each L2-normalised and the pair scaled by 1/sqrt(2), so the inner product of two
keys is the mean of their text and vision cosine similarities. Retrieval is an exact inner-product search
(FAISS ``IndexFlatIP``; ``index="hnsw"`` gives an approximate graph index for large banks). Below the
confidence threshold nothing is retrieved. A retrieved entry is a temporal reference for the residual branch
(its keyframe actions aligned to the current keyframe index), never replayed.

The bank is one ``.safetensors`` file (keys, concatenated trajectories, offsets; the entries' text metadata in
the file's string metadata), written atomically: an interrupted save leaves the previous bank intact.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import faiss
import numpy as np
import torch
from safetensors import safe_open
from safetensors.torch import save_file

from bimanualshift.utils.io import atomic_writer

INDEXES = ("flat", "hnsw")


def memory_key(text: np.ndarray, vision: np.ndarray) -> np.ndarray:
    """K = [E_text; E_vision] with both parts unit-normalised and the whole of unit norm."""
    text = np.asarray(text, dtype=np.float32).ravel()
    vision = np.asarray(vision, dtype=np.float32).ravel()
    for name, part in (("text", text), ("vision", vision)):
        if not np.all(np.isfinite(part)) or np.linalg.norm(part) == 0:
            raise ValueError(f"the {name} embedding of a memory key must be finite and non-zero")
    return np.concatenate([text / np.linalg.norm(text), vision / np.linalg.norm(vision)]) / np.sqrt(2)


@dataclass(frozen=True)
class MemoryEntry:
    task: str
    instruction: str
    source: str  # "demo" or "refinement"
    seed: int


@dataclass(frozen=True)
class Retrieval:
    index: int  # position of the entry in the bank
    entry: MemoryEntry
    similarity: float  # cosine similarity of the keys, in [-1, 1]
    trajectory: np.ndarray  # (K, A, D) keyframe actions of the stored execution

    def reference_at(self, keyframe: int) -> np.ndarray:
        """The stored action (A, D) aligned to ``keyframe`` (the last one past the stored episode's end)."""
        return self.trajectory[min(max(keyframe, 0), len(self.trajectory) - 1)]


class MemoryBank:
    def __init__(self, dim: int, threshold: float = 0.9, index: str = "flat") -> None:
        if index not in INDEXES:
            raise ValueError(f"unknown index {index!r}; choose from {INDEXES}")
        if not -1.0 <= threshold <= 1.0:
            raise ValueError(f"the confidence threshold is a cosine similarity in [-1, 1], got {threshold}")
        self.dim, self.threshold, self.index_kind = dim, threshold, index
        self.index = faiss.IndexFlatIP(dim) if index == "flat" else faiss.IndexHNSWFlat(dim, 32,
                                                                                         faiss.METRIC_INNER_PRODUCT)
        self.entries: list[MemoryEntry] = []
        self.trajectories: list[np.ndarray] = []
        self.frozen = False

    def __len__(self) -> int:
        return len(self.entries)

    def freeze(self) -> MemoryBank:
        """Evaluation uses a frozen bank: nothing is inserted while a method is being measured."""
        self.frozen = True
        return self

    def add(self, key: np.ndarray, trajectory: np.ndarray, entry: MemoryEntry) -> None:
        if self.frozen:
            raise RuntimeError("this memory bank is frozen (evaluation); insert successes during refinement only")
        key = np.asarray(key, dtype=np.float32).reshape(1, -1)
        if key.shape[1] != self.dim:
            raise ValueError(f"memory key has {key.shape[1]} values; this bank's keys have {self.dim}")
        if not np.isclose(np.linalg.norm(key), 1.0, atol=1e-3):
            raise ValueError("memory keys must have unit norm; build them with memory_key(text, vision)")
        trajectory = np.asarray(trajectory, dtype=np.float32)
        if trajectory.ndim != 3 or len(trajectory) == 0:
            raise ValueError(f"a trajectory is (keyframes, arms, action values), got shape {trajectory.shape}")
        if self.trajectories and trajectory.shape[1:] != self.trajectories[0].shape[1:]:
            raise ValueError(f"trajectory rows {trajectory.shape[1:]} differ from the bank's "
                             f"{self.trajectories[0].shape[1:]}")
        self.index.add(key)
        self.entries.append(entry)
        self.trajectories.append(trajectory)

    def search(self, query: np.ndarray, exclude: frozenset[int] | set[int] = frozenset()) -> Retrieval | None:
        """The most similar stored execution, or None when the bank is empty or the best similarity is below
        the confidence threshold. ``exclude`` skips entries by index (a training demo must not retrieve
        itself: the reference would be the answer)."""
        found = self.nearest(query, exclude)
        return found if found is not None and found.similarity >= self.threshold else None

    def nearest(self, query: np.ndarray, exclude: frozenset[int] | set[int] = frozenset()) -> Retrieval | None:
        """The most similar stored execution whatever its similarity (None for an empty bank): what ``search``
        would return below the threshold too, to log how close the nearest entry was."""
        query = np.asarray(query, dtype=np.float32).reshape(1, -1)
        if query.shape[1] != self.dim:
            raise ValueError(f"query has {query.shape[1]} values; this bank's keys have {self.dim}")
        if not self.entries:
            return None
        k = min(len(self), 1 + len(exclude))
        similarity, index = self.index.search(query, k)
        for best, score in zip(index[0].tolist(), similarity[0].tolist()):
            if best < 0 or best in exclude:
                continue
            return Retrieval(best, self.entries[best], float(score), self.trajectories[best])
        return None

    def extend(self, other: MemoryBank) -> MemoryBank:
        """Append every entry of ``other`` (e.g. an earlier task's bank, so its executions stay retrievable)."""
        for key, trajectory, entry in zip(other.keys(), other.trajectories, other.entries):
            self.add(key, trajectory, entry)
        return self

    def keys(self) -> np.ndarray:
        return self.index.reconstruct_n(0, len(self)) if len(self) else np.zeros((0, self.dim), np.float32)

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        lengths = np.array([len(t) for t in self.trajectories], dtype=np.int64)
        tensors = {
            "keys": torch.as_tensor(self.keys()),
            "offsets": torch.as_tensor(np.r_[0, np.cumsum(lengths)]),
            "trajectories": torch.as_tensor(np.concatenate(self.trajectories) if self.trajectories
                                            else np.zeros((0, 1, 1), np.float32)),
        }
        metadata = {"format": "bimanualshift-memory-1", "threshold": str(self.threshold), "index": self.index_kind,
                    "entries": json.dumps([vars(e) for e in self.entries])}
        with atomic_writer(path) as tmp:
            save_file({k: v.contiguous() for k, v in tensors.items()}, str(tmp), metadata=metadata)
        return path

    @staticmethod
    def load(path: str | Path) -> MemoryBank:
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"no memory bank at {path}; build one with MemoryBank(...).save(path)")
        with safe_open(str(path), framework="pt") as f:
            metadata = f.metadata() or {}
            if metadata.get("format") != "bimanualshift-memory-1":
                raise ValueError(f"{path} is not a BimanualShift memory bank (format {metadata.get('format')!r})")
            keys, offsets, trajectories = (f.get_tensor(k).numpy() for k in ("keys", "offsets", "trajectories"))
        bank = MemoryBank(keys.shape[1], float(metadata["threshold"]), metadata["index"])
        for i, raw in enumerate(json.loads(metadata["entries"])):
            bank.add(keys[i], trajectories[offsets[i]:offsets[i + 1]], MemoryEntry(**raw))
        return bank
