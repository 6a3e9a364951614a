import numpy as np

from bimanualshift.encoders.text import default_text_encoder


def test_bundled_minilm_encodes_offline() -> None:
    enc = default_text_encoder()
    emb = enc.encode(["push the red button", "push the blue button", "sweep the dirt to the dustpan"])
    assert emb.shape == (3, 384)
    np.testing.assert_allclose(np.linalg.norm(emb, axis=1), 1.0, atol=1e-5)
    # Similar instructions are closer than unrelated ones: a real model, not random vectors.
    assert emb[0] @ emb[1] > emb[0] @ emb[2]
