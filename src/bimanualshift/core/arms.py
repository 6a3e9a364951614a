"""Arm names, in the order every (arms, ...) array uses."""

ARM_NAMES_BIMANUAL = ("left", "right")
ARM_NAMES_UNIMANUAL = ("right",)
