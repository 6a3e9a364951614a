"""Frozen unimanual priors. Importing this package registers every prior type."""

from bimanualshift.priors.act import modeling_act  # noqa: F401 - registers "act"
from bimanualshift.priors.base import PRIORS, PriorOutput, UnimanualPrior, register_prior
from bimanualshift.priors.diffusion import modeling_diffusion  # noqa: F401 - registers "diffusion"
from bimanualshift.priors.peract import modeling_peract  # noqa: F401 - registers "peract"
from bimanualshift.priors.rvt import modeling_rvt  # noqa: F401 - registers "rvt"

__all__ = ["PRIORS", "PriorOutput", "UnimanualPrior", "register_prior"]
