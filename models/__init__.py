"""The preset robot files (``<name>.yaml``), installed with the package as ``pipeline.models``.

This folder holds data only; ``pipeline.files.robot_spec`` finds the presets here through
``importlib.resources``, so they are there in editable and regular installs alike.
"""
