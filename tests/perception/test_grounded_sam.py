"""Grounded-SAM wiring, end to end on tiny randomly initialised Grounding DINO and SAM models saved to disk."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bimanualshift.perception.segmenters.base import CameraView
from bimanualshift.perception.segmenters.grounded_sam import GroundedSamConfig, GroundedSamSegmenter, match_prompt

VOCAB = ["[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]", ".", "robotic", "arm", "button", "tray", "oven"]


@pytest.fixture(scope="module")
def tiny_models(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    from transformers import (
        BertConfig,
        BertTokenizerFast,
        GroundingDinoConfig,
        GroundingDinoForObjectDetection,
        GroundingDinoImageProcessor,
        GroundingDinoProcessor,
        SamConfig,
        SamImageProcessor,
        SamMaskDecoderConfig,
        SamModel,
        SamProcessor,
        SamPromptEncoderConfig,
        SamVisionConfig,
        SwinConfig,
    )

    root = tmp_path_factory.mktemp("models")
    tokenizer = BertTokenizerFast(vocab={w: i for i, w in enumerate(VOCAB)})
    detector = GroundingDinoForObjectDetection(GroundingDinoConfig(
        backbone_config=SwinConfig(embed_dim=8, depths=[1, 1, 1, 1], num_heads=[1, 1, 1, 1], window_size=2,
                                   image_size=64, out_features=["stage2", "stage3", "stage4"]),
        text_config=BertConfig(vocab_size=len(VOCAB), hidden_size=32, num_hidden_layers=1, num_attention_heads=2,
                               intermediate_size=32, max_position_embeddings=64),
        d_model=32, encoder_layers=1, decoder_layers=2, encoder_ffn_dim=32, decoder_ffn_dim=32,
        encoder_attention_heads=2, decoder_attention_heads=2, num_queries=8, num_feature_levels=3,
        encoder_n_points=1, decoder_n_points=1, max_text_len=32))
    detector.save_pretrained(root / "dino")
    GroundingDinoProcessor(image_processor=GroundingDinoImageProcessor(size={"shortest_edge": 64, "longest_edge": 64}),
                           tokenizer=tokenizer).save_pretrained(root / "dino")
    sam = SamModel(SamConfig(
        vision_config=SamVisionConfig(hidden_size=16, output_channels=16, num_hidden_layers=1, num_attention_heads=2,
                                      image_size=64, patch_size=8, mlp_dim=32, global_attn_indexes=[0],
                                      window_size=2, num_pos_feats=8),
        prompt_encoder_config=SamPromptEncoderConfig(hidden_size=16, image_size=64, patch_size=8,
                                                     mask_input_channels=4),
        mask_decoder_config=SamMaskDecoderConfig(hidden_size=16, num_hidden_layers=2, num_attention_heads=2, mlp_dim=32,
                                                 iou_head_hidden_dim=16)))
    sam.save_pretrained(root / "sam")
    SamProcessor(image_processor=SamImageProcessor(size={"longest_edge": 64}, pad_size={"height": 64, "width": 64})
                 ).save_pretrained(root / "sam")
    return root / "dino", root / "sam"


def test_prompts_become_masks_from_saved_models(tiny_models: tuple[Path, Path]) -> None:
    dino, sam = tiny_models
    # Thresholds at zero: a random detector's boxes all pass, so the whole box -> mask path runs.
    segmenter = GroundedSamSegmenter(GroundedSamConfig(detector=str(dino), sam=str(sam), box_threshold=0.0,
                                                       text_threshold=0.0, max_per_prompt=2))
    image = np.random.default_rng(0).integers(0, 255, (48, 64, 3), dtype=np.uint8)
    prompts = ["robotic arm", "button"]
    detections = segmenter.segment(CameraView(image), prompts)
    assert detections, "no detection passed zero thresholds"
    assert len(detections) <= 2 * len(prompts)
    for det in detections:
        assert det.mask.shape == (48, 64) and det.mask.dtype == bool
        assert det.label in prompts and 0.0 <= det.score <= 1.0
    strict = GroundedSamSegmenter(GroundedSamConfig(detector=str(dino), sam=str(sam), box_threshold=1.01))
    assert strict.segment(CameraView(image), prompts) == []


def test_phrases_match_the_prompt_they_answer() -> None:
    prompts = ["robotic arm", "button"]
    assert match_prompt("robotic arm", prompts) == "robotic arm"
    assert match_prompt("arm", prompts) == "robotic arm"
    assert match_prompt("button .", prompts) == "button"
    assert match_prompt("[SEP]", prompts) is None


def test_missing_weights_give_a_clear_error(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="no config.json"):
        GroundedSamSegmenter(GroundedSamConfig(detector=str(tmp_path / "empty"), sam=str(tmp_path / "empty")))


def test_training_config_points_the_projection_at_local_weights(tiny_models: tuple[Path, Path]) -> None:
    from bimanualshift.encoders.text import default_text_encoder
    from bimanualshift.methods.prior_step import FrozenPriorStep
    from bimanualshift.perception.segmenters.grounded_sam import GroundedSamSegmenter
    from bimanualshift.priors.peract.configuration_peract import PerActConfig
    from bimanualshift.priors.peract.modeling_peract import PerActPrior
    from bimanualshift.training.residual_trainer import segmenter_options

    detector, sam = tiny_models
    options = segmenter_options(str(detector), str(sam))
    assert options == {"detector": str(detector), "sam": str(sam)} and segmenter_options("", "") == {}
    prior = PerActPrior(PerActConfig(voxel_size=16, patch_size=4, dim=32, num_latents=8, self_attention_layers=1,
                                     heads=2))
    prior_step = FrozenPriorStep(prior, default_text_encoder(), segmenter="grounded_sam", segmenter_options=options)
    segmenter = prior_step.builder.projection.segmenter
    assert isinstance(segmenter, GroundedSamSegmenter)
    assert segmenter.config.detector == str(detector) and segmenter.config.sam == str(sam)
