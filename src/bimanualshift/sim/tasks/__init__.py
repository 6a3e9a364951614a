"""Importing this package registers every task."""

from bimanualshift.sim.tasks.bimanual import lift_ball, pick_up_plate, push_two_buttons, straighten_rope  # noqa: F401
from bimanualshift.sim.tasks.unimanual import pick_cube, push_button  # noqa: F401
