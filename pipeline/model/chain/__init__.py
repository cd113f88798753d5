"""The DH chain as numbers: the NumPy oracle (``kinematics``), the compiled core (``compiled``), the link
geometry (``geometry``), the Drake plant (``drake_model``), singularity measures and the standard-to-modified
DH rewrite. Nothing here knows IK, a robot value or a cell."""
