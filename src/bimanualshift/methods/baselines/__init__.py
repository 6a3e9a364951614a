"""Baselines the benchmark compares BimanualShift with; each composes the shared stages."""
