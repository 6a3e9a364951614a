"""What `bimanualshift serve` serves: a registered method loaded from its checkpoint, what it expects from a
robot (the metadata sent on connect), and the one check the schema cannot make alone (segmentation maps)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bimanualshift import __version__
from bimanualshift.core.policy import Policy
from bimanualshift.deploy.schema import SCHEMA_VERSION, ParsedObservation, SchemaError
from bimanualshift.utils.config_files import read_json_file

# The cameras and size the benchmark's checkpoints saw; a residual checkpoint names its own demos, which say better.
SIM_IMAGE_SIZE = 128


@dataclass
class ServedPolicy:
    policy: Policy
    metadata: dict[str, Any]
    needs_maps: bool  # it segments with the simulator's instance and class maps

    def check(self, parsed: ParsedObservation) -> None:
        if self.needs_maps and not parsed.has_maps:
            name = parsed.observation.scene.camera_names[0]
            raise SchemaError(f"cameras.{name}.instance", "instance and class maps (this checkpoint segments with "
                              "the simulator's maps; a real robot's server runs with --segmenter grounded_sam)",
                              "no maps")


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
        path = Path(checkpoint)
        cfg = read_json_file(path / "config.json", "BimanualShift checkpoint")
        if cfg.get("type") != "bimanualshift":
            raise ValueError(f"{path} is not a BimanualShift checkpoint (config.json type {cfg.get('type')!r}); "
                             "serve a residual run's best/ folder, or a frozen prior with --prior NAME")
        policy = load_bimanualshift(path, text_encoder, segmenter=segmenter or None)
        policy.name = method
        source = str(path)
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
    names, size = cameras or (["(any calibrated RGB-D cameras)"], [SIM_IMAGE_SIZE, SIM_IMAGE_SIZE])
    metadata = {"server": f"bimanualshift {__version__}", "schema_version": SCHEMA_VERSION, "method": method,
                "checkpoint": source, "cameras": names, "image_size": size, "segmenter": used_segmenter,
                "action": "per arm x, y, z, qx, qy, qz, qw, gripper_open, ignore_collisions (world frame)"}
    return ServedPolicy(policy, metadata, needs_maps=used_segmenter == "simulator")
