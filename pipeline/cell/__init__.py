"""Stage 4, cell: the robot among obstacles. Cell files (``cell_file``), the tool and the shapes it carries
(``tool``), collision and distance on Drake (``collision``), planners side by side (``planning``: detours, the
lazy roadmap of ``roadmap``, OMPL), the tool kept level (``tilt``), and motion that keeps clear
(``clear_motion``: colliding IK answers skipped, planned paths timed until they clear)."""
