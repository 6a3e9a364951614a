"""A small RVT-2-style prior: the arm's point cloud -> three orthographic views -> a transformer over their
patches with language and proprioception tokens -> a translation heat-map per view, lifted to one 3-D point;
then the same again zoomed in around that point (the fine stage) for the final position, and rotation bins,
gripper and collision read from the fine stage's features at it."""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from bimanualshift.geometry.frames import euler_bins_to_quat, quat_to_euler_bins
from bimanualshift.priors.base import PriorOutput, UnimanualPrior, register_prior
from bimanualshift.priors.rvt.configuration_rvt import RVTConfig
from bimanualshift.priors.rvt.render import RENDER_CHANNELS, VIEWS, project, render_views


class ViewStage(nn.Module):
    """One stage: rendered views (B, V, C, S, S) -> per-view heat-map logits (B, V, S, S), full-resolution feature
    maps (B, V, D, S, S) and the pooled token (B, dim)."""

    def __init__(self, c: RVTConfig) -> None:
        super().__init__()
        if c.image_size % c.patch_size:
            raise ValueError(f"image_size {c.image_size} must be a multiple of patch_size {c.patch_size}")
        in_ch = RENDER_CHANNELS + 2  # + the pixel's normalised row and column
        n = c.image_size // c.patch_size
        self.patch = nn.Conv2d(in_ch, c.dim, c.patch_size, stride=c.patch_size)
        self.pos_embed = nn.Parameter(torch.randn(1, len(VIEWS) * n * n, c.dim) * 0.02)
        self.text_proj = nn.Linear(c.text_dim, c.dim)
        self.proprio_proj = nn.Linear(c.proprio_dim + 1, c.dim)
        layer = nn.TransformerEncoderLayer(c.dim, c.heads, 2 * c.dim, dropout=0.0, activation="gelu",
                                           batch_first=True, norm_first=True)
        self.transformer = nn.TransformerEncoder(layer, c.layers, enable_nested_tensor=False)
        # Patch tokens back to full resolution, plus a skip from the image itself: the pixel-level detail the
        # heat-map's peak needs survives the 8x8 patches.
        self.up = nn.ConvTranspose2d(c.dim, c.decoder_dim, c.patch_size, stride=c.patch_size)
        self.skip = nn.Conv2d(in_ch, c.decoder_dim, 3, padding=1)
        self.refine = nn.Sequential(nn.GELU(), nn.Conv2d(c.decoder_dim, c.decoder_dim, 3, padding=1), nn.GELU())
        self.heat = nn.Conv2d(c.decoder_dim, 1, 1)
        lin = (torch.arange(c.image_size) + 0.5) / c.image_size * 2 - 1
        self.register_buffer("coords", torch.stack(torch.meshgrid(lin, lin, indexing="ij"))[None], persistent=False)

    def forward(self, images: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        b, v, _, s, _ = images.shape
        x = torch.cat([images.flatten(0, 1), self.coords.expand(b * v, -1, -1, -1)], 1)
        tokens = self.patch(x)
        n = tokens.shape[-1]
        tokens = tokens.flatten(2).transpose(1, 2).reshape(b, v * n * n, -1) + self.pos_embed
        seq = torch.cat([self.text_proj(text)[:, None], self.proprio_proj(proprio)[:, None], tokens], 1)
        seq = self.transformer(seq)
        grid = seq[:, 2:].reshape(b * v, n, n, -1).permute(0, 3, 1, 2)
        maps = self.refine(self.up(grid) + self.skip(x))
        return self.heat(maps).view(b, v, s, s), maps.view(b, v, -1, s, s), seq.mean(1)


def sample_maps(maps: torch.Tensor, points: torch.Tensor, centre: torch.Tensor, half: torch.Tensor) -> torch.Tensor:
    """(B, V * D) each view's feature map (B, V, D, S, S) read bilinearly where arm-frame ``points`` (B, 3) project."""
    b, v, d, s, _ = maps.shape
    rows, cols, _ = project(points[:, None], centre, half, s)  # (B, V, 1)
    grid = torch.stack([cols / s * 2 - 1, rows / s * 2 - 1], -1).reshape(b * v, 1, 1, 2)
    out = F.grid_sample(maps.reshape(b * v, d, s, s), grid, align_corners=False, padding_mode="border")
    return out.view(b, v * d)


def view_scores(heat: torch.Tensor, centre: torch.Tensor, half: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
    """(B, M) the sum over views of the heat-maps' (B, V, S, S) log-probabilities where points (B, M, 3) project."""
    b, v, s, _ = heat.shape
    rows, cols, _ = project(points, centre, half, s)
    logp = F.log_softmax(heat.flatten(2), -1).view(b * v, 1, s, s)
    where = torch.stack([cols / s * 2 - 1, rows / s * 2 - 1], -1).reshape(b * v, -1, 1, 2)
    return F.grid_sample(logp, where, align_corners=False, padding_mode="border").view(b, v, -1).sum(1)


def lift(heat: torch.Tensor, centre: torch.Tensor, half: torch.Tensor, grid: int) -> torch.Tensor:
    """One 3-D point (B, 3) from the views' heat-maps (B, V, S, S): the candidate of a grid^3 lattice over the cube
    whose projections score highest (sum of the views' log-probabilities), refined to the score-weighted mean of
    its 3x3x3 neighbourhood."""
    b, v, s, _ = heat.shape
    lin = (torch.arange(grid, dtype=centre.dtype) + 0.5) / grid * 2 - 1
    local = torch.stack(torch.meshgrid(lin, lin, lin, indexing="ij"), -1).reshape(-1, 3)  # (G^3, 3)
    candidates = centre[:, None] + local[None] * half[:, None, None]  # (B, G^3, 3)
    score = view_scores(heat, centre, half, candidates).view(b, grid, grid, grid)
    best = score.flatten(1).argmax(-1)
    i, j, k = best // (grid * grid), (best // grid) % grid, best % grid
    padded = F.pad(score, (1, 1, 1, 1, 1, 1), value=float("-inf"))
    offsets = torch.stack(torch.meshgrid(*[torch.arange(-1, 2)] * 3, indexing="ij"), -1).reshape(-1, 3)  # (27, 3)
    cells = torch.stack([i, j, k], -1)[:, None] + offsets[None]  # (B, 27, 3) in the unpadded lattice
    batch = torch.arange(b)[:, None]
    neighbour = padded[batch, cells[..., 0] + 1, cells[..., 1] + 1, cells[..., 2] + 1]
    weights = torch.softmax(neighbour, -1)
    positions = centre[:, None] + ((cells.to(centre.dtype) + 0.5) / grid * 2 - 1) * half[:, None, None]
    return (weights[..., None] * positions).sum(1)


def gaussian_labels(points: torch.Tensor, centre: torch.Tensor, half: torch.Tensor, size: int, sigma: float
                    ) -> torch.Tensor:
    """(B, V, S * S) each view's target distribution: a normalised Gaussian around the points' projections."""
    rows, cols, _ = project(points[:, None], centre, half, size)  # (B, V, 1)
    pix = torch.arange(size, dtype=points.dtype) + 0.5
    d2 = (pix.view(1, 1, size, 1) - rows[..., None]) ** 2 + (pix.view(1, 1, 1, size) - cols[..., None]) ** 2
    label = torch.exp(-d2 / (2 * sigma**2)).flatten(2)
    return label / label.sum(-1, keepdim=True).clamp(min=1e-12)


@register_prior("rvt")
class RVTPrior(UnimanualPrior):
    config_class = RVTConfig
    observation = "points"
    proprio_weight = "coarse.proprio_proj.weight"
    extra_proprio_weights = ("fine.proprio_proj.weight",)  # both stages read the proprioception
    concurrent_predict = True  # predict reads its weights and writes nothing

    def __init__(self, config: RVTConfig) -> None:
        super().__init__(config)
        c = config
        self.coarse = ViewStage(c)
        self.fine = ViewStage(c)
        self.head = nn.Sequential(nn.Linear(len(VIEWS) * c.decoder_dim + c.dim, 256), nn.GELU(),
                                  nn.Linear(256, 3 * c.rotation_bins + 4))
        lo, hi = np.asarray(c.bounds[:3]), np.asarray(c.bounds[3:])
        # The coarse cube: centred on the workspace, its half side the workspace's largest half extent.
        self.register_buffer("workspace_centre", torch.as_tensor((lo + hi) / 2, dtype=torch.float32), persistent=False)
        self.workspace_half = float(np.max(hi - lo) / 2)

    @property
    def feature_dim(self) -> int:
        return 2 * self.config.dim + len(VIEWS) * self.config.decoder_dim

    @property
    def local_feature_dim(self) -> int:
        return len(VIEWS) * self.config.decoder_dim

    @property
    def proposal_feature_dim(self) -> int:
        return 2 * self.local_feature_dim

    def _coarse_cube(self, b: int) -> tuple[torch.Tensor, torch.Tensor]:
        return self.workspace_centre.expand(b, 3), torch.full((b,), self.workspace_half)

    def run_coarse(self, cloud: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor) -> dict[str, torch.Tensor]:
        c = self.config
        centre, half = self._coarse_cube(len(cloud))
        heat, maps, pooled = self.coarse(render_views(cloud.float(), centre, half, c.image_size), proprio, text)
        return {"heat": heat, "maps": maps, "pooled": pooled, "centre": centre, "half": half}

    def run_fine(self, cloud: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor, centre: torch.Tensor
                 ) -> dict[str, torch.Tensor]:
        c = self.config
        half = torch.full((len(cloud),), c.zoom_half_extent)
        # The fine stage sees its cube, not where the cube is: the gripper's position enters relative to the
        # cube (in half sides), which is what places a target in free space (a lift, a pre-grasp) from the gripper.
        local = torch.cat([(proprio[:, :3] - centre) / half[:, None], proprio[:, 3:]], -1)
        heat, maps, pooled = self.fine(render_views(cloud.float(), centre, half, c.image_size), local, text)
        return {"heat": heat, "maps": maps, "pooled": pooled, "centre": centre, "half": half}

    def forward(self, cloud: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor) -> dict[str, torch.Tensor]:
        """Both stages at inference: the coarse guess, the fine stage zoomed in around it, the heads there."""
        c = self.config
        coarse = self.run_coarse(cloud, proprio, text)
        first = lift(coarse["heat"], coarse["centre"], coarse["half"], c.lift_grid)
        fine = self.run_fine(cloud, proprio, text, first)
        final = lift(fine["heat"], fine["centre"], fine["half"], c.lift_grid)
        point = sample_maps(fine["maps"], final, fine["centre"], fine["half"])
        out = self.head(torch.cat([point, fine["pooled"]], -1))
        r = c.rotation_bins
        return {"coarse_position": first, "position": final, "coarse": coarse, "fine": fine, "point": point,
                "rotation": out[:, : 3 * r].view(-1, 3, r), "gripper": out[:, 3 * r: 3 * r + 2],
                "collision": out[:, 3 * r + 2:]}

    @torch.no_grad()
    def predict(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor) -> PriorOutput:
        """``voxels`` is this prior's observation: the arm's point cloud (B, P, 6), see ``observation``."""
        out = self.forward(voxels, proprio, text)
        bins = out["rotation"].argmax(-1).cpu().numpy()
        quat = torch.as_tensor(np.stack([euler_bins_to_quat(b, self.config.rotation_bin_degrees) for b in bins]),
                               dtype=torch.float32)
        features = torch.cat([out["coarse"]["pooled"], out["fine"]["pooled"], out["point"]], -1)
        coarse = out["coarse"]
        # at the proposal: the fine stage's per-view maps (already read there) and the coarse stage's
        proposal = torch.cat([out["point"], sample_maps(coarse["maps"], out["position"], coarse["centre"],
                                                        coarse["half"])], -1)
        return PriorOutput(
            position=out["position"], quat=quat, gripper_open=out["gripper"].softmax(-1)[:, 1],
            ignore_collisions=out["collision"].softmax(-1)[:, 1], features=features,
            logits={"translation": out["fine"]["heat"], "translation_coarse": out["coarse"]["heat"],
                    "rotation": out["rotation"], "gripper": out["gripper"], "collision": out["collision"]},
            coarse_position=out["coarse_position"], proposal_features=proposal)

    def translation_scores(self, out: PriorOutput, points: torch.Tensor) -> torch.Tensor:
        """The coarse stage's lifted score (its views cover the whole workspace; the fine cube only a corner)."""
        centre, half = self._coarse_cube(len(points))
        return view_scores(out.logits["translation_coarse"].float(), centre, half, points.float())

    def local_features(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor,
                       points: torch.Tensor) -> torch.Tensor:
        coarse = self.run_coarse(voxels, proprio, text)
        return sample_maps(coarse["maps"], points.float(), coarse["centre"], coarse["half"])

    def compute_loss(self, inputs: tuple[torch.Tensor, ...], actions: dict[str, torch.Tensor],
                     generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        """Both stages' heat-maps against Gaussians at the expert's target (the fine stage zoomed in around the
        target moved by up to ``zoom_noise`` per axis, as the coarse stage would miss it), and the heads read at the
        target (teacher forcing)."""
        cloud, proprio, text = inputs
        c = self.config
        target = actions["position"][:, 0].float()
        coarse = self.run_coarse(cloud, proprio, text)
        noise = (torch.rand(target.shape, generator=generator) * 2 - 1) * c.zoom_noise
        fine = self.run_fine(cloud, proprio, text, target + noise)
        losses = {}
        for name, stage in (("coarse", coarse), ("fine", fine)):
            label = gaussian_labels(target, stage["centre"], stage["half"], c.image_size, c.label_sigma)
            logp = F.log_softmax(stage["heat"].flatten(2), -1)
            losses[f"translation_{name}"] = -(label * logp).sum(-1).mean()
        point = sample_maps(fine["maps"], target, fine["centre"], fine["half"])
        out = self.head(torch.cat([point, fine["pooled"]], -1))
        r = c.rotation_bins
        bins = torch.as_tensor(np.stack([quat_to_euler_bins(q, c.rotation_bin_degrees)
                                         for q in actions["quat"][:, 0].detach().cpu().numpy()]))
        losses["rotation"] = F.cross_entropy(out[:, : 3 * r].reshape(-1, r), bins.flatten())
        losses["gripper"] = F.cross_entropy(out[:, 3 * r: 3 * r + 2], actions["gripper_open"][:, 0].long())
        losses["collision"] = F.cross_entropy(out[:, 3 * r + 2:], actions["ignore_collisions"][:, 0].long())
        losses["total"] = sum(losses.values())
        return losses
