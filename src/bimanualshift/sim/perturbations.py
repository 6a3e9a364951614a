"""Switches for generalisation studies: every one is off in training data.

An environment is built with one ``Perturbations``; what it changes:

* ``unseen_colours`` — tasks draw object colours from ``UNSEEN_COLOURS`` instead of the 18 training colours.
* ``unseen_shapes`` — tasks build their objects with another shape (square caps, cubic ball, square plate...).
* ``lighting`` — light colour and intensity changed by this fraction (0.5 = dimmer, warm light).
* ``table_texture`` — a checkerboard table top and a dark floor instead of the plain ones.
* ``glare`` — over-bright lights, full specular highlights and reflective materials (burnt-out highlights).
* ``camera_shift_m`` / ``camera_rotate_deg`` — every static camera moved and turned by up to this much
  (seeded by ``seed``); the observation's extrinsics describe the moved cameras.
* ``swap_sides`` — the task layout mirrored left to right (y -> -y), so each arm faces the other's job.
* ``clutter`` — this many look-alike pieces in the goal objects' colours, in both arms' halves of the table, that
  only the cameras see (``sim.props.clutter``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

MAX_CLUTTER = 8


@dataclass(frozen=True)
class Perturbations:
    unseen_colours: bool = False
    unseen_shapes: bool = False
    lighting: float = 0.0
    table_texture: bool = False
    glare: bool = False
    camera_shift_m: float = 0.0
    camera_rotate_deg: float = 0.0
    swap_sides: bool = False
    clutter: int = 0
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0.0 <= self.lighting <= 1.0:
            raise ValueError(f"lighting must be a fraction in [0, 1], got {self.lighting}")
        if not 0.0 <= self.camera_shift_m <= 0.3:
            raise ValueError(f"camera_shift_m must be in [0, 0.3] metres, got {self.camera_shift_m}")
        if not 0.0 <= self.camera_rotate_deg <= 30.0:
            raise ValueError(f"camera_rotate_deg must be in [0, 30] degrees, got {self.camera_rotate_deg}")
        if not 0 <= self.clutter <= MAX_CLUTTER:
            raise ValueError(f"clutter must be a count of pieces in [0, {MAX_CLUTTER}], got {self.clutter}")

    @property
    def any(self) -> bool:
        return self != Perturbations(seed=self.seed)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @staticmethod
    def from_dict(values: dict[str, Any]) -> Perturbations:
        known = {f.name for f in fields(Perturbations)}
        unknown = set(values) - known
        if unknown:
            raise ValueError(f"unknown perturbation(s) {sorted(unknown)}; known: {sorted(known)}")
        return Perturbations(**values)


# Named presets: the generalisation studies' conditions (Table III's seven and the standard one), each also a value of
# the CLI's --perturb option.
PRESETS: dict[str, Perturbations] = {
    "none": Perturbations(),
    "unseen_colours": Perturbations(unseen_colours=True),
    "unseen_shapes": Perturbations(unseen_shapes=True),
    "lighting": Perturbations(lighting=0.6),
    "table_texture": Perturbations(table_texture=True),
    "glare": Perturbations(glare=True),
    "camera_pose": Perturbations(camera_shift_m=0.05, camera_rotate_deg=5.0),
    "swap_sides": Perturbations(swap_sides=True),
}


# Presets that probe where one component of the method should matter, outside the generalisation studies: look-alike
# clutter for the arm-conditioned projection.
REGIME_PRESETS: dict[str, Perturbations] = {
    "clutter": Perturbations(clutter=4),
}


def preset(name: str) -> Perturbations:
    known = {**PRESETS, **REGIME_PRESETS}
    if name not in known:
        raise KeyError(f"unknown perturbation preset {name!r}; choose from {', '.join(known)}")
    return known[name]
