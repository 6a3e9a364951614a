"""MJCF builders for the objects tasks put on the table, with the expert helpers that go with them.

robosuite computes inertia from geom group 0 only, while cameras render group 1: object geoms are group 1
(visible and colliding) and every moving body states its inertia explicitly.
"""
