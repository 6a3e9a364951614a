"""Deployment: the policy server and its client, the robot interface (a MuJoCo robot on the benchmark scene),
calibration and teleoperated recording. The layer above evaluation: it serves what the registry loads."""
