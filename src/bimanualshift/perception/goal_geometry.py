"""Where the goal object is, in an arm's frame: a few numbers from the projection's goal mask.

The frozen prior's pooled features say little about *where* things are, and the residual must move the
prior's target by tens of centimetres on tasks the prior never saw. The projection already segments the goal
object named in the instruction (Eq. 3); back-projecting those pixels through depth gives its points, and
their robust extent in the arm's frame is a precise, cheap location cue for the Manager (Eq. 6).

A box says where an object is but not where its ends are, and a long object is held by an end: a rope lying in
a curve, a brush's stick. The goal's two *extremities* are the ends of its longest path through a nearest-
neighbour graph of its points (two sweeps of Dijkstra; exact for a chain, and a curve's ends are not where its
box's corners are). Each end is given by its tip (the mean of the points within ``TIP_LENGTH_M`` of it along the
graph) and the horizontal direction into the object from there; the end lying nearer this arm's side (smaller
|y| in its frame) comes first, so each arm reads "its" end in the same slots.

A task with several goal objects ("take the tray out of the oven": tray and oven) gets one union box, in which the
larger object hides where the smaller one is. The *object boxes* give each goal noun's own box as well, in the
order the goal nouns are given (up to ``OBJECT_SLOTS``): the tray's box beside the oven's.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from bimanualshift.data.frames import KeyframeObservation
from bimanualshift.geometry.frames import ArmFrame
from bimanualshift.perception.projection import CameraPoints

BOX_GEOMETRY_DIM = 3 + 3 + 3 + 1  # centroid, 5th and 95th percentile corners, found flag
EXTREMITY_DIM = 2 * (3 + 3)  # per end: tip, unit horizontal direction into the object; this arm's end first
UNION_GEOMETRY_DIM = BOX_GEOMETRY_DIM + EXTREMITY_DIM  # all goal objects as one: box, extremities
OBJECT_SLOTS = 3  # goal nouns given a box of their own (a further noun counts in the union only)
OBJECT_GEOMETRY_DIM = OBJECT_SLOTS * BOX_GEOMETRY_DIM
# An arm's goal vector: the union's box, its extremities, each goal object's box; a residual reads its first 10,
# 22 or all of them.
GOAL_GEOMETRY_DIM = UNION_GEOMETRY_DIM + OBJECT_GEOMETRY_DIM
MIN_GOAL_POINTS = 10  # fewer back-projected goal points than this count as "goal not seen"
GRAPH_NEIGHBOURS = 8  # each goal point links to this many nearest others (a camera's pixels are ~mm apart)
GRAPH_POINTS = 1500  # above this many goal points, a fixed subsample builds the graph (Dijkstra's cost)
TIP_LENGTH_M = 0.04  # an end's tip: the points this close to it along the graph


def goal_world_points(obs: KeyframeObservation, goal_mask: np.ndarray) -> np.ndarray:
    """(N, 3) world points of the goal pixels (``goal_mask`` is (C, H, W)) that have a valid depth, through the
    projection's cached camera rays (only the goal's pixels are back-projected)."""
    parts = []
    for c in range(len(obs.depth)):
        mask = goal_mask[c] & (obs.depth[c] > 0)  # False for NaN depth too
        if mask.any():
            parts.append(CameraPoints(obs, c).at(mask))
    return np.concatenate(parts) if parts else np.zeros((0, 3), np.float32)


def _in_workspace(points_world: np.ndarray, frame: ArmFrame, bounds: tuple[float, ...]) -> np.ndarray:
    """The points in ``frame`` that lie inside the arm's workspace ``bounds`` (x0, y0, z0, x1, y1, z1)."""
    if len(points_world) == 0:
        return np.zeros((0, 3))
    points = frame.points_to_arm(np.asarray(points_world, np.float64))
    low, high = np.asarray(bounds[:3]), np.asarray(bounds[3:])
    return points[np.all((points >= low) & (points <= high), axis=1)]


def _box(points: np.ndarray) -> np.ndarray:
    """(BOX_GEOMETRY_DIM,) centroid, 5th / 95th percentile corners and the seen flag of arm-frame ``points``."""
    return np.r_[points.mean(0), np.percentile(points, 5, axis=0), np.percentile(points, 95, axis=0), 1.0]


def goal_geometry(points_world: np.ndarray, frame: ArmFrame, bounds: tuple[float, ...]) -> np.ndarray:
    """(UNION_GEOMETRY_DIM,) the goal's centroid, robust extent and two extremities in ``frame``, counting only
    points inside the arm's workspace ``bounds`` (x0, y0, z0, x1, y1, z1); all zeros when the goal is not seen."""
    out = np.zeros(UNION_GEOMETRY_DIM, np.float32)
    points = _in_workspace(points_world, frame, bounds)
    if len(points) < MIN_GOAL_POINTS:
        return out
    out[:BOX_GEOMETRY_DIM] = _box(points)
    out[BOX_GEOMETRY_DIM:] = extremities(points)
    return out


def object_boxes(points_per_object: list[np.ndarray], frame: ArmFrame, bounds: tuple[float, ...]) -> np.ndarray:
    """(OBJECT_GEOMETRY_DIM,) each goal object's box in ``frame`` (world points per goal noun, in the nouns'
    order), as ``goal_geometry``'s box; an object not seen, and a slot beyond the nouns given, stay zeros."""
    out = np.zeros(OBJECT_GEOMETRY_DIM, np.float32)
    for slot, points_world in enumerate(points_per_object[:OBJECT_SLOTS]):
        points = _in_workspace(points_world, frame, bounds)
        if len(points) >= MIN_GOAL_POINTS:
            out[slot * BOX_GEOMETRY_DIM:(slot + 1) * BOX_GEOMETRY_DIM] = _box(points)
    return out


def extremities(points: np.ndarray) -> np.ndarray:
    """(EXTREMITY_DIM,) the two ends of the points' longest nearest-neighbour path, each as (tip, unit horizontal
    direction from the tip into the object), the end with the smaller |y| first. The graph's largest connected
    piece stands for the object (an occluded middle splits a long one; the larger part holds more of it)."""
    if len(points) > GRAPH_POINTS:  # a subsample fixed by the point count alone (no global RNG)
        points = points[np.sort(np.random.default_rng(len(points)).choice(len(points), GRAPH_POINTS, replace=False))]
    k = min(GRAPH_NEIGHBOURS, len(points) - 1)
    distance, neighbour = cKDTree(points).query(points, k + 1)
    n = len(points)
    graph = coo_matrix((distance[:, 1:].ravel() + 1e-9, (np.repeat(np.arange(n), k), neighbour[:, 1:].ravel())),
                       shape=(n, n)).tocsr()
    graph = graph.maximum(graph.T)

    def along(start: int) -> np.ndarray:  # graph distance from ``start``; -1 where unreachable
        d = dijkstra(graph, directed=False, indices=start)
        return np.where(np.isfinite(d), d, -1.0)

    _, piece = connected_components(graph, directed=False)
    largest = np.flatnonzero(piece == np.bincount(piece).argmax())
    first = int(along(int(largest[0])).argmax())  # the far end of the largest piece, from any of its points
    from_first = along(first)
    second = int(from_first.argmax())
    ends = []
    for d in (from_first, along(second)):
        near = (d >= 0) & (d < TIP_LENGTH_M)
        tip = points[near].mean(0)
        inner = (d >= TIP_LENGTH_M) & (d < 2 * TIP_LENGTH_M)
        into = (points[inner].mean(0) if inner.any() else points[d >= 0].mean(0)) - tip
        into[2] = 0.0
        norm = np.linalg.norm(into)
        ends.append(np.r_[tip, into / norm if norm > 1e-6 else np.zeros(3)])
    ends.sort(key=lambda e: abs(float(e[1])))
    return np.concatenate(ends).astype(np.float32)
