"""`bimanualshift demo`: the whole method end to end (bimanualshift.demo)."""

from __future__ import annotations

from bimanualshift.demo import DemoConfig


def demo(cfg: DemoConfig) -> None:
    from bimanualshift.demo.run import run_demo

    run_demo(cfg)
