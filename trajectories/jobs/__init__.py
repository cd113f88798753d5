"""The demo job files (``<name>.yaml``), installed with the package as ``pipeline.demo_jobs``.

This folder holds data only; ``pipeline.program.job`` finds the demo jobs here through ``importlib.resources``,
so ``load_job("gp7_pick_place")`` and ``python -m pipeline run gp7_pick_place ...`` work from any folder.
"""
