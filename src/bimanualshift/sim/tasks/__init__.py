"""Importing this package registers every task."""

from bimanualshift.sim.tasks.bimanual import (  # noqa: F401
    buttons_then_lift_ball,
    lift_ball,
    pick_up_plate,
    push_two_buttons,
    straighten_rope,
    sweep_to_dustpan,
    take_tray_out_of_oven,
)
from bimanualshift.sim.tasks.realworld import (  # noqa: F401
    block_threading,
    flower_arrangement,
    pouring_water,
    serve_toast,
    toaster_activation,
    toasting_completion,
    vegetable_sorting,
)
from bimanualshift.sim.tasks.unimanual import (  # noqa: F401
    drag_dustpan,
    hold_cup,
    hold_dustpan,
    hold_rod,
    insert_bread,
    insert_stem,
    open_oven_door,
    pick_cube,
    pick_up_small_plate,
    place_toast,
    place_vegetable,
    pour_cup,
    press_lever,
    pull_rope_end,
    push_ball_aside,
    push_button,
    slide_block,
    steady_toaster,
    sweep_dirt,
    take_tray_out_of_open_oven,
    thread_block,
)
