"""The per-arm instruction chooser: fitted deterministically, picks by what an arm observes, survives its JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bimanualshift.methods.instruction_chooser import OWN_PHRASING, InstructionChooser, chooser_features

DOOR = "open the oven door"


def role_data(n: int = 40, seed: int = 0) -> tuple[np.ndarray, list[str]]:
    """Features whose third column tells the role (as the goal's side does), the rest noise on other scales."""
    rng = np.random.default_rng(seed)
    features = rng.normal(size=(n, 6)) * np.array([1.0, 10.0, 0.05, 3.0, 1.0, 0.0])  # one constant column
    labels = [DOOR if f[2] > 0 else OWN_PHRASING for f in features]
    return features, labels


def test_fit_separates_roles_and_generalises() -> None:
    features, labels = role_data()
    chooser = InstructionChooser.fit(features, labels)
    assert chooser.instructions == sorted({DOOR, OWN_PHRASING})
    assert chooser.choose(features) == labels
    unseen, unseen_labels = role_data(200, seed=1)
    accuracy = np.mean([c == lb for c, lb in zip(chooser.choose(unseen), unseen_labels, strict=True)])
    assert accuracy > 0.9


def test_fit_is_deterministic_and_round_trips_through_json() -> None:
    features, labels = role_data()
    a, b = InstructionChooser.fit(features, labels), InstructionChooser.fit(features, labels)
    assert np.array_equal(a.weight, b.weight) and np.array_equal(a.bias, b.bias)
    loaded = InstructionChooser.from_dict(json.loads(json.dumps(a.to_dict())))
    probe = role_data(50, seed=2)[0]
    assert loaded.choose(probe) == a.choose(probe)


def test_one_class_always_chosen() -> None:
    features, _ = role_data(10)
    chooser = InstructionChooser.fit(features, [DOOR] * 10)
    assert chooser.choose(role_data(7, seed=3)[0]) == [DOOR] * 7


def test_bad_input_names_the_problem() -> None:
    features, labels = role_data()
    chooser = InstructionChooser.fit(features, labels)
    with pytest.raises(ValueError, match="reads 6 features"):
        chooser.choose(np.zeros((2, 5)))
    with pytest.raises(ValueError, match="one label per feature row"):
        InstructionChooser.fit(features, labels[:-1])
    saved = chooser.to_dict()
    del saved["weight"]
    with pytest.raises(ValueError, match="lacks weight"):
        InstructionChooser.from_dict(saved)
    saved = chooser.to_dict()
    saved["bias"] = [0.0]
    with pytest.raises(ValueError, match="shapes disagree"):
        InstructionChooser.from_dict(saved)


def test_features_drop_the_keyframe_fraction() -> None:
    goal, proprio, other = np.ones((3, 4)), np.arange(27.0).reshape(3, 9), np.full((3, 8), 2.0)
    features = chooser_features(goal, proprio, other)
    assert features.shape == (3, 4 + 8 + 8)
    assert np.array_equal(features[:, 4:12], proprio[:, :8])
    assert chooser_features(goal[0], proprio[0], other[0]).shape == (1, 20)
