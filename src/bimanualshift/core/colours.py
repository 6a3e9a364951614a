"""Object colours: the 18 that training scenes draw from (RLBench's palette) and 6 held out for studies."""

from __future__ import annotations

RGB = tuple[float, float, float]

TRAIN_COLOURS: dict[str, RGB] = {  # in draw order (seeded choices depend on it)
    "red": (0.9, 0.1, 0.1), "maroon": (0.5, 0.0, 0.0), "lime": (0.3, 1.0, 0.1),
    "green": (0.1, 0.55, 0.1), "blue": (0.1, 0.25, 0.95), "navy": (0.0, 0.0, 0.45),
    "yellow": (0.95, 0.9, 0.1), "cyan": (0.1, 0.85, 0.9), "magenta": (0.9, 0.1, 0.85),
    "silver": (0.75, 0.75, 0.75), "gray": (0.4, 0.4, 0.4), "orange": (1.0, 0.5, 0.0),
    "olive": (0.5, 0.5, 0.05), "purple": (0.5, 0.05, 0.5), "teal": (0.0, 0.5, 0.5),
    "azure": (0.0, 0.5, 1.0), "violet": (0.55, 0.3, 0.95), "rose": (1.0, 0.3, 0.55),
}

# Never used by training data: the "unseen colours" perturbation draws from these instead.
UNSEEN_COLOURS: dict[str, RGB] = {  # in draw order (seeded choices depend on it)
    "black": (0.03, 0.03, 0.03), "white": (0.98, 0.98, 0.98), "brown": (0.45, 0.25, 0.08),
    "pink": (1.0, 0.7, 0.8), "gold": (0.85, 0.65, 0.15), "beige": (0.85, 0.8, 0.6),
}
