"""Orthographic re-rendering of an arm-frame point cloud into three virtual views (RVT's input), on the CPU.

Each view looks at a cube (centre ``c``, half side ``h``) along one axis of the arm frame and keeps, per pixel,
the point nearest its virtual camera (a z-buffer done with one ``scatter_reduce``):

=====  ============================  ==========  ==========  =====================
view   camera                        image row   image col   nearest point
=====  ============================  ==========  ==========  =====================
top    above, looking down (-z)      x (far up)  y           highest z
front  at the base, looking +x       z (high up) y           smallest x
side   on the left, looking -y       z (high up) x           largest y
=====  ============================  ==========  ==========  =====================

Zooming in (RVT-2's second stage) is the same call with a smaller cube around the first stage's guess, so a
point keeps its place relative to the cube: pixel = (p - c) / h mapped from [-1, 1] to [0, S).
"""

from __future__ import annotations

import torch

VIEWS = ("top", "front", "side")
# Per view: (arm-frame axis of the image row, its sign: +1 puts larger values lower in the image; axis of the
# column, sign; depth axis, sign: the nearest point has the largest sign * coordinate).
VIEW_AXES: dict[str, tuple[int, float, int, float, int, float]] = {
    "top": (0, -1.0, 1, -1.0, 2, 1.0),
    "front": (2, -1.0, 1, -1.0, 0, -1.0),
    "side": (2, -1.0, 0, 1.0, 1, 1.0),
}
# Channels of a rendered view: rgb, depth towards the camera (1 nearest, 0 the cube's far side), occupancy.
RENDER_CHANNELS = 5
DEPTH_LEVELS = 1 << 20  # quantisation of the z-buffer key (depth * levels * P + point index)


def project(points: torch.Tensor, centre: torch.Tensor, half: torch.Tensor, size: int
            ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Continuous pixel coordinates of arm-frame ``points`` (B, P, 3) in every view: rows and cols (B, V, P),
    in [0, size) inside the cube, and depth in [0, 1] (1 nearest the camera). ``centre`` (B, 3), ``half`` (B,)."""
    local = (points - centre[:, None]) / half[:, None, None]  # [-1, 1] inside the cube
    rows, cols, depth = [], [], []
    for view in VIEWS:
        r_axis, r_sign, c_axis, c_sign, d_axis, d_sign = VIEW_AXES[view]
        rows.append((r_sign * local[..., r_axis] + 1) / 2 * size)
        cols.append((c_sign * local[..., c_axis] + 1) / 2 * size)
        depth.append((d_sign * local[..., d_axis] + 1) / 2)
    return torch.stack(rows, 1), torch.stack(cols, 1), torch.stack(depth, 1)


def pixel_to_point(rows: torch.Tensor, cols: torch.Tensor, view: str, depth_coord: torch.Tensor,
                   centre: torch.Tensor, half: torch.Tensor, size: int) -> torch.Tensor:
    """Inverse of ``project`` for one view: arm-frame points (B, 3) from pixel coordinates (B,) and the arm-frame
    coordinate along the view's depth axis (B,)."""
    r_axis, r_sign, c_axis, c_sign, d_axis, _ = VIEW_AXES[view]
    local = torch.zeros(rows.shape[0], 3, dtype=centre.dtype)
    local[:, r_axis] = r_sign * (2 * rows / size - 1)
    local[:, c_axis] = c_sign * (2 * cols / size - 1)
    out = centre + local * half[:, None]
    out[:, d_axis] = depth_coord
    return out


def render_views(cloud: torch.Tensor, centre: torch.Tensor, half: torch.Tensor, size: int) -> torch.Tensor:
    """(B, V, RENDER_CHANNELS, size, size) images of ``cloud`` (B, P, 6: arm-frame xyz, rgb in [0, 1]) seen in the
    cube around ``centre`` (B, 3) of half side ``half`` (B,); points outside the cube are not drawn."""
    b, p, _ = cloud.shape
    v = len(VIEWS)
    rows, cols, depth = project(cloud[..., :3], centre, half, size)
    inside = ((rows >= 0) & (rows < size) & (cols >= 0) & (cols < size) & (depth >= 0) & (depth <= 1))
    pixel = rows.long().clamp(0, size - 1) * size + cols.long().clamp(0, size - 1)  # (B, V, P)
    # The nearest point per pixel: the largest (quantised depth, point index) key; ties go to the later point.
    index = torch.arange(p).expand(b, v, p)
    key = (depth.clamp(0, 1) * (DEPTH_LEVELS - 1)).long() * p + index
    key = torch.where(inside, key, torch.full_like(key, -1))
    slot = torch.arange(b * v).view(b, v, 1) * size * size + pixel
    best = torch.full((b * v * size * size,), -1, dtype=torch.long)
    best.scatter_reduce_(0, slot.reshape(-1), key.reshape(-1), reduce="amax")
    hit = best >= 0
    winner = (best.clamp(min=0) % p).view(b, v, size * size)  # point index per pixel
    win_depth = (best.clamp(min=0) // p).float().view(b, v, size * size) / (DEPTH_LEVELS - 1)
    rgb = torch.gather(cloud[:, None, :, 3:6].expand(b, v, p, 3), 2, winner[..., None].expand(-1, -1, -1, 3))
    occupied = hit.view(b, v, size * size).to(cloud.dtype)
    images = torch.cat([rgb * occupied[..., None], (win_depth * occupied)[..., None], occupied[..., None]], -1)
    return images.view(b, v, size, size, RENDER_CHANNELS).permute(0, 1, 4, 2, 3).contiguous()
