"""Stage 5, program: a job file read against its robot (``job``), compiled into one frozen value of typed moves
(``model``: the Program; ``compile``: ``compile_job``), tool paths (``tool_path``: lines, arcs, zones) and the
joint paths that keep the TCP on them (``tool_moves``), timed and certified once (``timing``: ``time_program``,
each stretch of ``stretch`` as one path), with its lower bound (``bound``) and cycle-time report (``report``)."""
