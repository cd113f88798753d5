"""The local web page (python -m pipeline ui): jog the arm and read its TCP pose, drag a TCP target and see
every IK branch of it as a ghost arm with its branch name, vendor configuration and state (``branches``),
build a program of moves, plan and time it, and save it as a job file."""
