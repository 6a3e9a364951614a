"""Where the table, the robot bases and the reachable workspace are (world frame, metres).

Plain numbers, so task files, props and methods can read them without importing robosuite.
"""

import numpy as np

TABLE_SIZE = (0.8, 1.6, 0.05)
TABLE_TOP_Z = 0.8
ROBOT_X = -0.16 - TABLE_SIZE[0] / 2  # robosuite's default base offset for a table
BIMANUAL_ARM_Y = {"left": 0.3, "right": -0.3}  # the robot's left is +y when it faces +x
UNIMANUAL_ARM_Y = {"right": 0.0}
WORKSPACE_LOW = np.array([-0.55, -0.75, TABLE_TOP_Z - 0.02])
WORKSPACE_HIGH = np.array([0.45, 0.75, TABLE_TOP_Z + 0.65])


def skill_side(rng: np.random.Generator) -> float:
    """Which side of its arm a single-arm skill's object stands, drawn from the seed's generator: +1 left, -1 right."""
    return 1.0 if rng.random() < 0.5 else -1.0


def arms_by_side(left_y: float, right_y: float) -> tuple[str, str]:
    """(the arm for the object at ``left_y``, the arm for the one at ``right_y``): each arm takes what stands on its
    side (+y: left), so a left-right exchange hands the two jobs over."""
    return ("left", "right") if left_y > right_y else ("right", "left")
