"""What `bimanualshift serve` serves: a registered method loaded from its checkpoint, what it expects from a
robot (the metadata sent on connect), and the one check the schema cannot make alone (segmentation maps)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from bimanualshift import __version__
from bimanualshift.core.arms import ARM_NAMES_BIMANUAL
from bimanualshift.core.policy import Policy
from bimanualshift.deploy.schema import SCHEMA_VERSION, ParsedObservation, SchemaError
from bimanualshift.geometry.cameras import view_coverage
from bimanualshift.rollout.loop import KEYFRAME_BUDGET
from bimanualshift.sim.layout import TABLE_SIZE, TABLE_TOP_Z
from bimanualshift.utils.config_files import read_json_file
from bimanualshift.utils.hub import resolve_local

# The cameras and size the benchmark's checkpoints saw; a residual checkpoint names its own demos, which say better.
SIM_IMAGE_SIZE = 128


# The table-top volume (world frame) the cameras must see between them: objects lie on the table and the arms act
# up to a few decimetres above it. The sim's six cameras see all of it, its front camera alone 73 %.
VIEW_LOW = np.array([-TABLE_SIZE[0] / 2, -TABLE_SIZE[1] / 2, TABLE_TOP_Z])
VIEW_HIGH = np.array([TABLE_SIZE[0] / 2, TABLE_SIZE[1] / 2, TABLE_TOP_Z + 0.25])
MIN_VIEW_COVERAGE = 0.5  # below it the projection would hand each arm's prior a scene with most of the table missing


@dataclass
class ServedPolicy:
    policy: Policy
    metadata: dict[str, Any]
    needs_maps: bool  # it segments with the simulator's instance and class maps
    arms: tuple[str, ...] = ARM_NAMES_BIMANUAL  # the arm names the checkpoint acts for, in its order
    exact_arms: bool = True  # a residual reads each arm's index: both arms, in order; a frozen prior takes a subset
    max_keyframe: int = KEYFRAME_BUDGET * 25 - 1  # the last keyframe index the checkpoint's prior encodes

    def check(self, parsed: ParsedObservation) -> dict[str, Any]:
        """Refuse what the checkpoint cannot act on, naming the field: arms it does not have, a keyframe past its
        episode bound, views that do not cover the table, and no segmentation maps where it needs them. What an
        accepted request's views are goes back in the reply's diagnostics."""
        obs = parsed.observation
        names = tuple(obs.scene.arm_names)
        # exact: the checkpoint's arms in its order; else any of them, still in its order (no other name)
        if names != (self.arms if self.exact_arms else tuple(a for a in self.arms if a in names)):
            want = f"the arms {list(self.arms)}" + (" in this order" if self.exact_arms else
                                                    " or a subset of them, in this order")
            raise SchemaError("arms", f"{want} (the checkpoint's; send each arm under its name)", f"{list(names)}",
                              code="unsupported")
        if obs.keyframe_index > self.max_keyframe:
            raise SchemaError("keyframe", f"an index from 0 to {self.max_keyframe} (the checkpoint's episode bound: "
                              "start a new episode_id, or reset at keyframe 0)", str(obs.keyframe_index),
                              code="unsupported")
        coverage = self.view_coverage(parsed)
        if coverage < MIN_VIEW_COVERAGE:
            raise SchemaError("cameras", f"calibrated views that together see at least {MIN_VIEW_COVERAGE:.0%} of "
                              "the table-top workspace (check each camera's extrinsics: camera-to-world, OpenCV "
                              "axes, and its intrinsics)", f"{coverage:.0%} seen by {list(obs.scene.camera_names)}",
                              code="unsupported")
        if self.needs_maps and not parsed.has_maps:
            name = obs.scene.camera_names[0]
            raise SchemaError(f"cameras.{name}.instance", "instance and class maps (this checkpoint segments with "
                              "the simulator's maps; a real robot's server runs with --segmenter grounded_sam)",
                              "no maps")
        trained = self.metadata.get("cameras", {}).get("trained_with", [])
        return {"views": {"cameras": list(obs.scene.camera_names), "coverage": round(coverage, 3),
                          "trained_with": trained,
                          "untrained_names": [n for n in obs.scene.camera_names if trained and n not in trained]}}

    @staticmethod
    def view_coverage(parsed: ParsedObservation) -> float:
        obs = parsed.observation
        for name, e in zip(obs.scene.camera_names, obs.extrinsics):
            if abs(float(np.linalg.det(np.asarray(e, np.float64)[:3, :3]))) < 1e-6:
                raise SchemaError(f"cameras.{name}.extrinsics", "a camera-to-world pose with a rotation block",
                                  "a singular matrix")
        return view_coverage(VIEW_LOW, VIEW_HIGH, obs.intrinsics, obs.extrinsics, obs.rgb.shape[1:3])


def _data_cameras(cfg: dict[str, Any]) -> tuple[list[str], list[int]] | None:
    """Camera names and image size of the first demo a residual checkpoint was trained on, when it is on disk."""
    from bimanualshift.data.episode import list_episodes, read_episode

    dataset = cfg.get("train_config", {}).get("dataset", {})
    if not dataset.get("data") or not cfg.get("task"):
        return None
    files = list_episodes(dataset["data"], cfg["task"])
    if not files:
        return None
    episode = read_episode(files[0])
    return list(episode.camera_names), list(episode.arrays["rgb"].shape[2:4])


def load_served_policy(method: str, checkpoint: str = "", prior: str = "", segmenter: str = "") -> ServedPolicy:
    """``method`` from the registry; ``bimanualshift`` and its ablations load ``checkpoint`` (a residual run's
    ``best/`` or ``refine/best``), the frozen-prior methods ``prior`` (a folder or shipped name). ``segmenter``
    replaces the checkpoint's (``grounded_sam`` for a real robot)."""
    from bimanualshift.encoders.text import default_text_encoder
    from bimanualshift.methods.bimanualshift import load_bimanualshift
    from bimanualshift.methods.frozen_prior import FrozenPriorPerArm

    text_encoder = default_text_encoder()
    cameras: tuple[list[str], list[int]] | None = None
    if checkpoint:
        path = resolve_local(checkpoint)
        cfg = read_json_file(path / "config.json", "BimanualShift checkpoint")
        if cfg.get("type") != "bimanualshift":
            raise ValueError(f"{path} is not a BimanualShift checkpoint (config.json type {cfg.get('type')!r}); "
                             "serve a residual run's best/ folder, or a frozen prior with --prior NAME")
        policy = load_bimanualshift(path, text_encoder, segmenter=segmenter or None)
        policy.name = method
        source = str(checkpoint)
        used_segmenter = segmenter or cfg.get("segmenter", "simulator")
        cameras = _data_cameras(cfg)
    elif prior:
        if method not in ("no_residual", "frozen_prior_per_arm"):
            raise ValueError(f"--prior serves the frozen prior alone (--method no_residual or frozen_prior_per_arm); "
                             f"--method {method} needs --checkpoint DIR")
        use_projection = method == "no_residual"
        policy = FrozenPriorPerArm.from_pretrained(prior, text_encoder, name=method, use_projection=use_projection,
                                                   segmenter=segmenter or "simulator")
        source = prior
        used_segmenter = (segmenter or "simulator") if use_projection else "none"  # the global scene: no masks
    else:
        raise ValueError("serve needs --checkpoint DIR (a trained BimanualShift run) or --prior NAME (a frozen prior)")
    names, size = cameras or ([], [SIM_IMAGE_SIZE, SIM_IMAGE_SIZE])
    # The projection back-projects every calibrated view into the world grid, so any set of cameras serves as long
    # as together they see the table: a real robot's one front camera as well as the simulator's six.
    arms = ARM_NAMES_BIMANUAL  # a frozen prior also serves one of them alone (a single-arm task's "right")
    max_keyframe = KEYFRAME_BUDGET * int(policy.prior_step.prior.config.max_keyframes) - 1
    metadata = {"server": f"bimanualshift {__version__}", "schema_version": SCHEMA_VERSION, "method": method,
                "checkpoint": source,
                "cameras": {"accepted": "any calibrated RGB-D cameras, by any name, that together see at least "
                                        f"{MIN_VIEW_COVERAGE:.0%} of the table-top workspace",
                            "trained_with": names, "min_view_coverage": MIN_VIEW_COVERAGE},
                "image_size": size, "arms": list(arms), "arms_exact": bool(checkpoint),
                "max_keyframe": max_keyframe, "segmenter": used_segmenter,
                "action": "per arm x, y, z, qx, qy, qz, qw, gripper_open, ignore_collisions (world frame)"}
    return ServedPolicy(policy, metadata, needs_maps=used_segmenter == "simulator", arms=arms,
                        exact_arms=bool(checkpoint), max_keyframe=max_keyframe)
