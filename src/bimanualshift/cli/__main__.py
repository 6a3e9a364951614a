"""``python -m bimanualshift.cli`` (what torchrun starts) is the ``bimanualshift`` command."""

from bimanualshift.cli import main

main()
