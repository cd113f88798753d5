"""Stage 1, files: what the package reads and writes before any robot is loaded. The one reader behind
every file (``schema``), units, the names a file chooses from (``choices``, ``branch_names``), array and pose
checks (``arrays``, ``poses``), what a path names (``special``), safe writing (``atomic``), and robot files
both ways (``robot_spec`` reads, ``robot_writer`` writes)."""
