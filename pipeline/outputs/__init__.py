"""Stage 6, outputs: what leaves the pipeline. Profile files and reports (``formats``), figures (``plots``),
3-D views (``views``), ROS 2 trajectories (``ros2``), installed versions for reports (``versions``), and the
controller programs (``controllers/``: writers, readers and lint)."""
