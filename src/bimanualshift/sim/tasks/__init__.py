"""Importing this package registers every task."""

from bimanualshift.sim.tasks.bimanual import push_two_buttons  # noqa: F401
from bimanualshift.sim.tasks.unimanual import pick_cube, push_button  # noqa: F401
