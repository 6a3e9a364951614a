"""What the investigations that read demos' goal geometry share: their command line, the projection that locates
the goal (the simulator's segmenter, no voxels) and each task's demos."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bimanualshift.data.episode import list_episodes
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.perception.observation import DEFAULT_ARM_BOUNDS, ArmObservationBuilder
from bimanualshift.perception.projection import ArmProjection
from bimanualshift.perception.segmenters.simulator import SimulatorSegmenter


def demo_arguments(doc: str, out: str) -> argparse.Namespace:
    """``--data`` (a folder of bimanual demos), ``--tasks`` and ``--out`` (the result file, ``out`` by default)."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--data", default="data/bench/train", help="a folder of bimanual demos (<task>/episode_*.h5)")
    parser.add_argument("--tasks", nargs="+", default=["straighten_rope"])
    parser.add_argument("--out", default=out)
    return parser.parse_args()


def goal_builder() -> ArmObservationBuilder:
    """Each arm's goal geometry from the same projection and segmentation training uses (no voxel grid)."""
    return ArmObservationBuilder(VoxelGrid(DEFAULT_ARM_BOUNDS, 16), ArmProjection(SimulatorSegmenter()),
                                 voxels=False, points=1)


def task_demos(data: str, task: str) -> list[Path]:
    paths = list_episodes(data, task)
    if not paths:
        sys.exit(f"error: no demos of {task} under {data}")
    return paths
