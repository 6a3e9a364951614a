from pathlib import Path

import numpy as np
import pytest

import bimanualshift.memory.bank as bank_module
from bimanualshift.memory.bank import MemoryBank, MemoryEntry, memory_key


def key(seed: int, dim_text: int = 8, dim_vision: int = 4) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return memory_key(rng.normal(size=dim_text), rng.normal(size=dim_vision))


def filled(n: int = 5, **kwargs: object) -> MemoryBank:
    bank = MemoryBank(12, **kwargs)
    for i in range(n):
        bank.add(key(i), np.full((3 + i, 2, 8), float(i)), MemoryEntry("lift_ball", f"lift {i}", "demo", i))
    return bank


def test_key_similarity_is_the_mean_of_text_and_vision_cosines() -> None:
    t1, t2, v1, v2 = np.array([1.0, 0]), np.array([0.0, 1]), np.array([3.0, 4]), np.array([3.0, 4])
    assert np.dot(memory_key(t1, v1), memory_key(t2, v2)) == pytest.approx((0.0 + 1.0) / 2)
    assert np.linalg.norm(memory_key(t1, v1)) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="non-zero"):
        memory_key(np.zeros(2), v1)


def test_retrieves_the_nearest_execution_and_aligns_it_in_time() -> None:
    bank = filled()
    found = bank.search(key(3))
    assert found is not None and found.entry.seed == 3 and found.similarity == pytest.approx(1.0, abs=1e-5)
    assert found.reference_at(1).shape == (2, 8) and found.reference_at(99)[0, 0] == 3.0  # clamped to the end
    assert len(found.trajectory) == 6


def test_below_the_threshold_nothing_is_retrieved() -> None:
    bank = filled(threshold=0.99)
    noisy = key(3) + 0.2 * key(100)
    assert bank.search(noisy / np.linalg.norm(noisy)) is None
    assert MemoryBank(12).search(key(0)) is None  # empty bank


def test_save_load_round_trip(tmp_path: Path) -> None:
    bank = filled(threshold=0.7)
    loaded = MemoryBank.load(bank.save(tmp_path / "memory.safetensors"))
    assert len(loaded) == 5 and loaded.threshold == 0.7
    np.testing.assert_array_equal(loaded.keys(), bank.keys())
    for i in range(5):
        a, b = bank.search(key(i)), loaded.search(key(i))
        assert a.entry == b.entry and np.array_equal(a.trajectory, b.trajectory)


def test_an_interrupted_save_leaves_the_old_bank_intact(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = filled(2).save(tmp_path / "memory.safetensors")
    before = path.read_bytes()

    def crash(tensors: dict, filename: str, metadata: dict) -> None:
        Path(filename).write_bytes(b"half a file")
        raise KeyboardInterrupt

    monkeypatch.setattr(bank_module, "save_file", crash)
    with pytest.raises(KeyboardInterrupt):
        filled(5).save(path)
    assert path.read_bytes() == before and len(MemoryBank.load(path)) == 2
    assert [p.name for p in tmp_path.iterdir()] == ["memory.safetensors"]  # no temporary left behind


def test_frozen_banks_refuse_insertions_and_bad_inputs_are_explained() -> None:
    bank = filled(1).freeze()
    with pytest.raises(RuntimeError, match="frozen"):
        bank.add(key(9), np.zeros((2, 2, 8)), MemoryEntry("t", "i", "demo", 0))
    bank = MemoryBank(12)
    with pytest.raises(ValueError, match="unit norm"):
        bank.add(np.ones(12), np.zeros((2, 2, 8)), MemoryEntry("t", "i", "demo", 0))
    with pytest.raises(ValueError, match="keys have 12"):
        bank.search(np.ones(5))
    with pytest.raises(ValueError, match="unknown index"):
        MemoryBank(12, index="ivf")


def test_the_approximate_index_finds_the_same_entries() -> None:
    exact, approximate = filled(40), filled(40, index="hnsw")
    for i in range(0, 40, 7):
        assert exact.search(key(i)).entry == approximate.search(key(i)).entry
