"""A small PerAct-style policy: voxels -> 3-D conv patches -> Perceiver latents (with language and
proprioception tokens) -> translation heat-map over voxels, discrete Euler rotation bins, gripper and
collision heads."""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from bimanualshift.geometry.frames import euler_bins_to_quat, quat_to_euler_bins
from bimanualshift.geometry.voxels import VOXEL_CHANNELS, VoxelGrid
from bimanualshift.priors.base import PriorOutput, UnimanualPrior, register_prior
from bimanualshift.priors.peract.configuration_peract import PerActConfig

STEM = 16  # channels of the full-resolution voxel stem
NUM_PEAKS = 4


class CrossAttention(nn.Module):
    def __init__(self, dim: int, heads: int) -> None:
        super().__init__()
        self.norm_q, self.norm_kv = nn.LayerNorm(dim), nn.LayerNorm(dim)
        self.attn = nn.MultiheadAttention(dim, heads, batch_first=True)
        self.ff = nn.Sequential(nn.LayerNorm(dim), nn.Linear(dim, 2 * dim), nn.GELU(), nn.Linear(2 * dim, dim))

    def forward(self, query: torch.Tensor, context: torch.Tensor) -> torch.Tensor:
        kv = self.norm_kv(context)
        x = query + self.attn(self.norm_q(query), kv, kv, need_weights=False)[0]
        return x + self.ff(x)


@register_prior("peract")
class PerActPrior(UnimanualPrior):
    config_class = PerActConfig
    proprio_weight = "proprio_proj.weight"  # the input layer of the proprioception (widened by the baselines)
    concurrent_predict = True  # predict reads its weights and writes nothing

    def __init__(self, config: PerActConfig) -> None:
        super().__init__(config)
        c = config
        if c.voxel_size % c.patch_size:
            raise ValueError(f"voxel_size {c.voxel_size} must be a multiple of patch_size {c.patch_size}")
        self.grid = VoxelGrid(tuple(c.bounds), c.voxel_size)
        in_ch = VOXEL_CHANNELS + 3  # + normalised voxel coordinates
        self.patches = c.voxel_size // c.patch_size
        self.voxel_stem = nn.Sequential(nn.Conv3d(in_ch, STEM, 3, padding=1), nn.GELU())
        self.patch_embed = nn.Conv3d(STEM, c.dim, c.patch_size, stride=c.patch_size)
        self.pos_embed = nn.Parameter(torch.randn(1, self.patches**3, c.dim) * 0.02)
        self.text_proj = nn.Linear(c.text_dim, c.dim)
        # FiLM of the full-resolution stem by the instruction: lets "the red button" highlight red voxels
        # before any pooling, which a single language token attended to by the latents learns slowly.
        self.text_film = nn.Linear(c.text_dim, 2 * STEM)
        self.proprio_proj = nn.Linear(c.proprio_dim + 1, c.dim)
        self.latents = nn.Parameter(torch.randn(1, c.num_latents, c.dim) * 0.02)
        self.encode = CrossAttention(c.dim, c.heads)
        self.process = nn.ModuleList(CrossAttention(c.dim, c.heads) for _ in range(c.self_attention_layers))
        self.decode = CrossAttention(c.dim, c.heads)
        # Each decoded patch token predicts the logits of its patch_size^3 voxels (a 3-D pixel shuffle),
        # refined by a 1x1x1 read-out of the full-resolution stem: far cheaper than convolving at S^3.
        # 3x3x3 convolutions over the decoded patch grid give each patch its neighbours' context (a target
        # 8 cm above a button lies one or two patches away from the button itself).
        self.decoder_conv = nn.Sequential(
            nn.Conv3d(c.dim, c.dim, 3, padding=1), nn.GELU(), nn.Conv3d(c.dim, c.dim, 3, padding=1)
        )
        self.translation_patch = nn.Linear(c.dim, c.patch_size**3)
        self.translation_stem = nn.Conv3d(STEM, 1, 1)
        self.global_head = nn.Sequential(
            nn.Linear(2 * c.dim + STEM, 256), nn.GELU(), nn.Linear(256, 3 * c.rotation_bins + 4)
        )
        if c.subvoxel_offset:
            self.offset_head = nn.Sequential(nn.Linear(STEM + c.dim, 64), nn.GELU(), nn.Linear(64, 3))
        coords = torch.stack(torch.meshgrid(*[torch.linspace(-1, 1, c.voxel_size)] * 3, indexing="ij"))
        self.register_buffer("coords", coords[None], persistent=False)

    @property
    def feature_dim(self) -> int:
        return 2 * self.config.dim + 4 * NUM_PEAKS

    def heatmap_peaks(self, heatmap: torch.Tensor) -> torch.Tensor:
        """Top heat-map peaks after 3x3x3 non-maximum suppression: (B, NUM_PEAKS, 4) = arm-frame xyz
        and probability. Where the prior looks is the visual feature a residual can re-target from."""
        s = self.config.voxel_size
        prob = heatmap.softmax(-1).reshape(-1, 1, s, s, s)
        pooled = F.max_pool3d(prob, 3, stride=1, padding=1)
        suppressed = torch.where(prob >= pooled, prob, torch.zeros_like(prob)).flatten(1)
        values, flat = suppressed.topk(NUM_PEAKS, dim=-1)
        idx = torch.stack([flat // (s * s), (flat // s) % s, flat % s], dim=-1).float()
        lower = torch.as_tensor(self.grid.lower)
        xyz = lower + (idx + 0.5) * torch.as_tensor(self.grid.voxel_size)
        return torch.cat([xyz, values[..., None]], dim=-1)

    @property
    def local_feature_dim(self) -> int:
        return STEM + self.config.dim

    def local_features(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor,
                       points: torch.Tensor) -> torch.Tensor:
        """The full-resolution stem and the decoded patch grid, trilinearly sampled at arm-frame points (B, 3)."""
        return self.sample_maps(self.forward(voxels, proprio, text, keep_maps=True), points[:, None])[:, 0]

    def sample_maps(self, out: dict[str, torch.Tensor], points: torch.Tensor) -> torch.Tensor:
        """(B, K, STEM + dim) the stem and decoded maps of ``out`` (``forward(..., keep_maps=True)``) read
        trilinearly at arm-frame points (B, K, 3)."""
        lower = torch.as_tensor(self.grid.lower, dtype=torch.float32)
        upper = torch.as_tensor(self.grid.upper, dtype=torch.float32)
        unit = 2 * (points.float() - lower) / (upper - lower) - 1  # [-1, 1] per axis (x, y, z)
        # grid_sample reads (x, y, z) as (W, H, D); the maps are (D, H, W) = (x, y, z) index order: flip.
        where = unit.flip(-1)[:, :, None, None, :]  # (B, K, 1, 1, 3)
        sampled = [F.grid_sample(m, where, align_corners=False)[..., 0, 0] for m in (out["stem"], out["decoded"])]
        return torch.cat(sampled, dim=1).transpose(1, 2)

    @property
    def proposal_feature_dim(self) -> int:
        return 2 * self.local_feature_dim

    def proposal_maps(self, out: dict[str, torch.Tensor], position: torch.Tensor) -> torch.Tensor:
        """The maps at the proposed position and their mean over its six neighbours one voxel away: what the
        prior computed where it points, and just around it."""
        step = torch.as_tensor(self.grid.voxel_size, dtype=torch.float32)
        offsets = torch.cat([torch.diag(step), -torch.diag(step)])  # (6, 3)
        points = torch.cat([position[:, None], position[:, None] + offsets[None]], 1)  # (B, 7, 3)
        sampled = self.sample_maps(out, points)
        return torch.cat([sampled[:, 0], sampled[:, 1:].mean(1)], -1)

    def voxel_offset(self, out: dict[str, torch.Tensor], flat_index: torch.Tensor) -> torch.Tensor:
        """(B, 3) the target's offset inside voxel ``flat_index`` (B,), in voxels within [-0.5, 0.5], from the stem
        and the decoded token there (``out`` from ``forward(..., keep_maps=True)``)."""
        c = self.config
        s, q, p = c.voxel_size, c.patch_size, self.patches
        b = flat_index.shape[0]
        stem = out["stem"].flatten(2)[torch.arange(b), :, flat_index]  # (B, STEM)
        x, y, z = flat_index // (s * s), (flat_index // s) % s, flat_index % s
        patch = ((x // q) * p + y // q) * p + z // q
        token = out["decoded"].flatten(2)[torch.arange(b), :, patch]  # (B, dim)
        return 0.5 * torch.tanh(self.offset_head(torch.cat([stem, token], dim=-1)))

    def forward(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor, keep_maps: bool = False
                ) -> dict[str, torch.Tensor]:
        """voxels (B, 4, S, S, S), proprio (B, proprio_dim + 1) with the keyframe fraction last, text (B, T).
        ``keep_maps`` adds the spatial maps ``stem`` (B, STEM, S, S, S) and ``decoded`` (B, dim, P, P, P)."""
        c = self.config
        b = voxels.shape[0]
        x = torch.cat([voxels, self.coords.expand(b, -1, -1, -1, -1)], dim=1)
        gamma, beta = self.text_film(text).reshape(b, 2, STEM, 1, 1, 1).unbind(1)
        stem = self.voxel_stem(x) * (1 + gamma) + beta  # (B, STEM, S, S, S)
        tokens = self.patch_embed(stem).flatten(2).transpose(1, 2) + self.pos_embed  # (B, P^3, D)
        context = torch.cat([tokens, self.text_proj(text)[:, None], self.proprio_proj(proprio)[:, None]], dim=1)
        latents = self.encode(self.latents.expand(b, -1, -1), context)
        for layer in self.process:
            latents = layer(latents, torch.cat([latents, context[:, -2:]], dim=1))
        decoded = self.decode(tokens, latents)  # (B, P^3, D)
        p, q = self.patches, c.patch_size
        grid = decoded.transpose(1, 2).reshape(b, c.dim, p, p, p)
        decoded = decoded + self.decoder_conv(grid).flatten(2).transpose(1, 2)
        patch_logits = self.translation_patch(decoded).reshape(b, p, p, p, q, q, q)
        patch_logits = patch_logits.permute(0, 1, 4, 2, 5, 3, 6).reshape(b, 1, p * q, p * q, p * q)
        heatmap = (patch_logits + self.translation_stem(stem)).flatten(1)  # (B, S^3)
        # Global features: pooled latents, the decoded token and stem features where the heat-map points.
        attention = heatmap.softmax(-1)
        token_attention = attention.reshape(b, p, q, p, q, p, q).sum((2, 4, 6)).flatten(1)  # (B, P^3)
        at_token = torch.einsum("bn,bnc->bc", token_attention, decoded)
        at_stem = torch.einsum("bn,bcn->bc", attention, stem.flatten(2))
        features = torch.cat([latents.mean(1), at_token], dim=-1)
        logits = self.global_head(torch.cat([features, at_stem], dim=-1))
        features = torch.cat([features, self.heatmap_peaks(heatmap.detach()).flatten(1)], dim=-1)
        r = c.rotation_bins
        out = {
            "translation": heatmap,
            "rotation": logits[:, : 3 * r].reshape(b, 3, r),
            "gripper": logits[:, 3 * r : 3 * r + 2],
            "collision": logits[:, 3 * r + 2 :],
            "features": features,
        }
        if keep_maps or c.subvoxel_offset:
            out["stem"], out["decoded"] = stem, decoded.transpose(1, 2).reshape(b, c.dim, p, p, p)
        return out

    def decode_actions(self, out: dict[str, torch.Tensor]) -> PriorOutput:
        c = self.config
        s = c.voxel_size
        chosen = out["translation"].argmax(-1)
        index = np.stack(np.unravel_index(chosen.cpu().numpy(), (s, s, s)), axis=-1)
        position = torch.as_tensor(self.grid.index_to_point(index), dtype=torch.float32)
        if c.subvoxel_offset:
            position = position + self.voxel_offset(out, chosen) * torch.as_tensor(self.grid.voxel_size)
        bins = out["rotation"].argmax(-1).cpu().numpy()
        quat = torch.as_tensor(np.stack([euler_bins_to_quat(b, c.rotation_bin_degrees) for b in bins]),
                               dtype=torch.float32)
        return PriorOutput(
            position=position, quat=quat,
            gripper_open=out["gripper"].softmax(-1)[:, 1], ignore_collisions=out["collision"].softmax(-1)[:, 1],
            features=out["features"], logits={k: out[k] for k in ("translation", "rotation", "gripper", "collision")},
        )

    @torch.no_grad()
    def predict(self, voxels: torch.Tensor, proprio: torch.Tensor, text: torch.Tensor) -> PriorOutput:
        out = self.forward(voxels, proprio, text, keep_maps=True)
        decoded = self.decode_actions(out)
        decoded.proposal_features = self.proposal_maps(out, decoded.position)
        return decoded

    def translation_scores(self, out: PriorOutput, points: torch.Tensor) -> torch.Tensor:
        """The heat-map's log-softmax at the voxel of each point; points outside the grid score -1e4."""
        s = self.config.voxel_size
        logp = F.log_softmax(out.logits["translation"].float(), -1)  # (B, S^3)
        flat = points.detach().cpu().numpy().reshape(-1, 3)
        idx = self.grid.point_to_index(flat)
        linear = torch.as_tensor((idx[:, 0] * s + idx[:, 1]) * s + idx[:, 2]).view(points.shape[:2])
        scores = torch.gather(logp, 1, linear)
        inside = torch.as_tensor(self.grid.inside(flat)).view(points.shape[:2])
        return torch.where(inside, scores, torch.full_like(scores, -1e4))

    def discrete_targets(self, actions: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        """Continuous arm-frame targets (first keyframe of the chunk) -> voxel index, Euler bins, flags."""
        c = self.config
        s = c.voxel_size
        target = actions["position"][:, 0].detach().cpu().numpy()
        idx = self.grid.point_to_index(target)
        bins = np.stack([quat_to_euler_bins(q, c.rotation_bin_degrees)
                         for q in actions["quat"][:, 0].detach().cpu().numpy()])
        return {
            "translation_index": torch.as_tensor((idx[:, 0] * s + idx[:, 1]) * s + idx[:, 2]),
            "rotation_bins": torch.as_tensor(bins),
            "gripper_open": actions["gripper_open"][:, 0].long(),
            "ignore_collisions": actions["ignore_collisions"][:, 0].long(),
            # where inside its voxel the target lies, in voxels (the sub-voxel head's target)
            "offset": torch.as_tensor((target - self.grid.index_to_point(idx)) / self.grid.voxel_size,
                                      dtype=torch.float32).clamp(-0.5, 0.5),
        }

    def compute_loss(self, inputs: tuple[torch.Tensor, ...], actions: dict[str, torch.Tensor],
                     generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        return self.loss(self.forward(*inputs), self.discrete_targets(actions))

    def loss(self, out: dict[str, torch.Tensor], target: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        """Cross-entropy over voxels, rotation bins, gripper and collision (PerAct's objective)."""
        losses = {
            "translation": F.cross_entropy(out["translation"], target["translation_index"]),
            "rotation": F.cross_entropy(out["rotation"].flatten(0, 1), target["rotation_bins"].flatten()),
            "gripper": F.cross_entropy(out["gripper"], target["gripper_open"]),
            "collision": F.cross_entropy(out["collision"], target["ignore_collisions"]),
        }
        if self.config.subvoxel_offset:  # read at the expert's voxel (teacher forcing); in voxels, so O(1)
            predicted = self.voxel_offset(out, target["translation_index"])
            losses["offset"] = F.smooth_l1_loss(predicted, target["offset"], beta=0.1)
        losses["total"] = sum(losses.values())
        return losses
