"""Stage 2, model: a robot file become a robot. ``chain/`` (the DH chain's numbers: the NumPy oracle, the
compiled core, link geometry, the Drake plant, singularity measures), ``ik/`` (inverse kinematics on the chain),
``vendors/`` (the makers' axis maps and configuration data: IK branches named as a controller names them), and
on top ``robot`` (``Robot``: FK, Jacobian and IK in one value) and ``jacobian_check``."""
