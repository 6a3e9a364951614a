"""The paper's real-world tasks (section IV-B, Table II), built for the UR5e twin (``sim.robots.UR5E``)."""
