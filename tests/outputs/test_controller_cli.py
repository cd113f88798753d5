"""The controller programs from the command line and as job outputs: ``python -m pipeline program JOB --lang L``
writes the GP7 demo job in each of the four languages of its makers and a UR5 job in URScript (URScript on the GP7
is refused), ``read-program`` reads each back into a job file that
``load_job`` accepts with the same waypoints (kinds, branches, positions within the formats' rounding), mistakes
are one ``error:`` line with exit status 2, and a job listing ``rapid`` among its outputs writes program.mod.

The CLI runs in this process (``pipeline.__main__.main``: about 0.1 s per call), writing only into tmp_path.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import yaml

from pipeline.__main__ import MAX_PROGRAM_BYTES, main
from pipeline.errors import OutputError
from pipeline.files.atomic import written_here
from pipeline.program.job import load_job
from pipeline.runner import PROGRAM_FILES, program_name, run_job_file

from .test_urscript import UR5_JOB

ROOT = Path(__file__).resolve().parents[2]
GP7_JOB = ROOT / "trajectories" / "jobs" / "gp7_pick_place.yaml"
#: Language -> the files ``program`` writes into a folder for the GP7 demo job (its name made valid), or URScript's
#: for the UR5 job (``ur5_job``).
WRITTEN = {"rapid": ["gp7_pick_place.mod"], "ls": ["GP7_PICK.ls"], "jbi": ["GP7_PICK.jbi"],
           "krl": ["gp7_pick_place.dat", "gp7_pick_place.src"], "urscript": ["ur5_moves.script"]}
#: The formats' position rounding [m]: 0.001 mm everywhere, URScript 1e-6 m.
POSITION_TOL = 1.5e-6
#: ... and the orientations' (JBI: 0.01 deg) [1].
ROTATION_TOL = 2e-4
#: A pose from joint values rounded to 1e-6 rad (URScript) is further off, by up to this factor.
JOINT_ROUNDING = 5.0


def cli(capsys, *args: str) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def ur5_job(tmp_path_factory) -> Path:
    """test_urscript's UR5 job as a job file ur5_moves.yaml (its robot file tests/data/ur5.yaml, a UR arm)."""
    path = tmp_path_factory.mktemp("ur5") / "ur5_moves.yaml"
    path.write_text(yaml.safe_dump(UR5_JOB))
    return path


def job_of(language: str, ur5_job: Path) -> Path:
    """The job written in ``language``: the UR5 job in URScript, the GP7 demo job in the other languages."""
    return ur5_job if language == "urscript" else GP7_JOB


@pytest.fixture(scope="module")
def written(tmp_path_factory, ur5_job) -> Path:
    """The GP7 demo job written in the four languages of its makers, and the UR5 job in URScript, into one folder."""
    folder = tmp_path_factory.mktemp("programs")
    for language in WRITTEN:
        assert main(["program", str(job_of(language, ur5_job)), "--lang", language, "--out", str(folder)]) == 0
    return folder


@pytest.mark.parametrize("language", list(WRITTEN))
def test_program_writes_each_language_named_from_the_job(written, language):
    names = WRITTEN[language]
    assert all((written / name).is_file() for name in names)
    text = (written / names[-1]).read_text()
    if language in ("ls", "jbi"):       # the name was cut: the header says what it was made from
        assert "gp7_pick_place (written as" in text
    if language == "urscript":
        assert "def certified_replay():" in text and "servoj(" in text


@pytest.mark.parametrize("language", list(WRITTEN))
def test_read_program_gives_back_a_job_with_the_same_waypoints(written, ur5_job, tmp_path, capsys, language):
    program = written / next(name for name in WRITTEN[language] if not name.endswith(".dat"))
    out = tmp_path / "read" / "job.yaml"
    original = load_job(job_of(language, ur5_job))
    code, stdout, err = cli(capsys, "read-program", program, "--robot", original.robot.spec.source, "--out", out)
    assert code == 0, err
    assert f"wrote {out}" in stdout
    job = load_job(out)
    assert job.robot.name == original.robot.name and len(job.waypoints) == len(original.waypoints)
    for read, given in zip(job.waypoints[1:], original.waypoints[1:]):
        assert read.move == given.move
        if hasattr(given, "X_BE"):     # URScript has no configuration data: its joint moves are joint targets
            X_read, tol = (read.X_BE, 1.0) if hasattr(read, "X_BE") else (job.robot.fk(read.q), JOINT_ROUNDING)
            np.testing.assert_allclose(X_read[:3, 3], given.X_BE[:3, 3], atol=POSITION_TOL * tol)
            np.testing.assert_allclose(X_read[:3, :3], given.X_BE[:3, :3], atol=ROTATION_TOL)


def test_read_program_prints_the_job_without_out(written, capsys):
    code, stdout, _ = cli(capsys, "read-program", written / "GP7_PICK.jbi", "--robot", "gp7")
    assert code == 0 and stdout.startswith("# ") and "waypoints:" in stdout


def test_program_into_a_named_file(tmp_path, capsys):
    code, _, err = cli(capsys, "program", GP7_JOB, "--lang", "krl", "--out", tmp_path / "pick.src")
    assert code == 0, err
    assert (tmp_path / "pick.src").read_text().startswith("DEF pick( )")    # KRL: the DEF is the file's name
    assert (tmp_path / "pick.dat").read_text().startswith("DEFDAT pick")


@pytest.mark.parametrize("args, message", [
    (["program", GP7_JOB, "--lang", "cobol"], "invalid choice: 'cobol'"),
    (["program", GP7_JOB, "--lang", "rapid", "--out", "x.ls"], "a rapid program is a .mod file"),
    (["program", GP7_JOB, "--lang", "rapid", "--servo-period", "0.008"], "servoj replay; rapid has none"),
    (["read-program", "missing.mod", "--robot", "gp7"], "cannot read the file"),
    (["read-program", "job.txt", "--robot", "gp7"], "unknown program file type '.txt'"),
])
def test_mistakes_are_one_error_line(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    try:
        code = main([str(a) for a in args])
    except SystemExit as usage:             # argparse's usage errors leave through sys.exit
        code = usage.code
    stdout, err = capsys.readouterr()
    assert code == 2 and stdout == "" and err.startswith("error: ") and err.count("\n") == 1 and message in err
    assert list(tmp_path.iterdir()) == []


def test_servo_period_sets_the_replay_period(ur5_job, tmp_path, capsys):
    """A CB3 takes servoj every 0.008 s: the replay has one servoj per period of the certified profile."""
    code, stdout, err = cli(capsys, "program", ur5_job, "--lang", "urscript", "--servo-period", "0.008", "--out",
                            tmp_path / "cb3.script")
    assert code == 0, err
    duration = float(stdout.split("the certified profile takes ")[1].split(" s")[0])
    calls = [line for line in (tmp_path / "cb3.script").read_text().splitlines() if "servoj(" in line]
    assert all("t=0.008," in line for line in calls)
    assert len(calls) == int(np.ceil(duration / 0.008 - 1e-9))


@pytest.mark.parametrize("job, maker", [
    (GP7_JOB, "a controller section of maker yaskawa"),
    (ROOT / "trajectories" / "jobs" / "arm6_joint_rad.yaml", "no controller section"),
])
def test_urscript_for_an_arm_that_is_not_a_ur_one_is_refused_before_any_work(tmp_path, capsys, job, maker):
    """URScript runs on Universal Robots controllers only: exit 2, one line naming the robot, its robot file's
    controller section and the fix, nothing written (it wrote a .script for the GP7)."""
    robot = load_job(job).robot
    code, out, err = cli(capsys, "program", job, "--lang", "urscript", "--out", tmp_path)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert all(words in err for words in (f"{robot.name}: URScript runs only on a Universal Robots controller",
                                          f"{robot.spec.source} has {maker}", "controller: {maker: ur}")), err
    assert list(tmp_path.iterdir()) == []


def test_a_krl_src_without_its_dat_reads_until_it_names_what_only_a_dat_declares(written, tmp_path, capsys):
    """An offline tool's .src comes without a .dat (RoboDK's posts) and is read; ours declares its points in the .dat,
    so the first one is one error line naming the line and the point."""
    (tmp_path / "lonely.src").write_text((written / "gp7_pick_place.src").read_text())
    code, _, err = cli(capsys, "read-program", tmp_path / "lonely.src", "--robot", "gp7")
    assert code == 2 and err.count("\n") == 1 and err.startswith(f"error: {tmp_path / 'lonely.src'}:")
    assert "is not declared as E6POS, POS, E6AXIS, AXIS or FRAME in the .src, and no .dat is beside it" in err


def test_a_job_listing_rapid_writes_program_mod(tmp_path):
    document = yaml.safe_load(GP7_JOB.read_text())
    document["outputs"] = ["json", "rapid"]
    job_file = tmp_path / "gp7_rapid.yaml"
    job_file.write_text(yaml.safe_dump(document))
    outcome = run_job_file(job_file, tmp_path / "out")
    assert [p.name for p in outcome.files] == ["report.json", *PROGRAM_FILES["rapid"]] == ["report.json", "program.mod"]
    assert (tmp_path / "out" / "program.mod").read_text().startswith("MODULE gp7_rapid")


@pytest.mark.parametrize("language, job_name, name", [
    ("ls", "gp7 pick & place", "GP7_PICK"), ("jbi", "3d-print", "P_3D_PRI"), ("rapid", "module", "P_module"),
    ("urscript", "end", "P_end"), ("krl", "a" * 30, "a" * 24), ("rapid", "---", "P"),
])
def test_program_names_are_made_valid(language, job_name, name):
    assert program_name(language, job_name) == name


def test_read_program_names_a_robot_file_relative_to_the_job_written(written, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    robot = Path("models") / "gp7.yaml"
    robot.parent.mkdir()
    robot.write_text((ROOT / "models" / "gp7.yaml").read_text())
    out = Path("jobs") / "deep" / "read.yaml"
    code, _, err = cli(capsys, "read-program", written / "gp7_pick_place.mod", "--robot", robot, "--out", out)
    assert code == 0, err
    assert yaml.safe_load(out.read_text())["robot"] == "../../models/gp7.yaml"
    assert load_job(out).robot.name == "gp7"


def test_an_existing_file_not_written_here_is_kept_unless_forced(tmp_path, capsys):
    """program --out onto a user's file: refused before any work, naming it; --force replaces it; our own file
    is replaced without asking."""
    mine = tmp_path / "cell.mod"
    mine.write_text("MODULE mine\nENDMODULE\n")
    code, _, err = cli(capsys, "program", GP7_JOB, "--lang", "rapid", "--out", mine)
    assert code == 2 and "was not written by dh-pipeline" in err and mine.read_text().startswith("MODULE mine")
    assert cli(capsys, "program", GP7_JOB, "--lang", "rapid", "--out", mine, "--force")[0] == 0
    assert cli(capsys, "program", GP7_JOB, "--lang", "rapid", "--out", mine)[0] == 0
    assert written_here(mine)


@pytest.mark.parametrize("kind", ["fifo", "device", "huge"])
def test_read_program_takes_regular_files_of_bounded_size_only(tmp_path, capsys, kind):
    """A FIFO named like a program blocked read-program forever, a link to /dev/zero grew it to 19 GB, 100 MB
    took 44 s: each is one error line, before the file is opened or read past the limit."""
    path = tmp_path / "prog.mod"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "device":
        path.symlink_to("/dev/zero")
    else:
        path.write_bytes(b"! x\n" * (MAX_PROGRAM_BYTES // 4 + 1))
    code, _, err = cli(capsys, "read-program", path, "--robot", "gp7")
    assert code == 2 and err.count("\n") == 1
    assert ("not a regular file" in err) if kind != "huge" else ("larger than 8192 KiB" in err)


@pytest.mark.parametrize("period", ["1e9", "1e-6", "0.001", "0.05"])
def test_a_servo_period_outside_the_controllers_is_refused_before_any_work(ur5_job, tmp_path, capsys, period):
    """--servo-period 1e9 replayed one servoj (the certified profile lost), 1e-6 wrote 525 MB."""
    code, out, err = cli(capsys, "program", ur5_job, "--lang", "urscript", "--servo-period", period, "--out",
                         tmp_path / "x.script")
    assert code == 2 and out == "" and "servoj period must be a time in [0.002, 0.032] s" in err
    assert list(tmp_path.iterdir()) == []


def test_a_replay_longer_than_the_guard_is_refused(monkeypatch):
    from pipeline.outputs.controllers import urscript

    monkeypatch.setattr(urscript, "MAX_REPLAY_LINES", 10)
    profile = type("P", (), {"t": np.linspace(0.0, 1.0, 11), "q": np.zeros((11, 6)), "qd": np.zeros((11, 6))})()
    with pytest.raises(OutputError, match="would be 500 lines, more than 10"):
        urscript.resample(profile, 0.002)


def test_read_program_blames_the_robot_file_for_its_own_errors(written, tmp_path, capsys):
    """--robot given a job file: the error names that file and its line, not the program (it said ok.mod:5)."""
    code, _, err = cli(capsys, "read-program", written / "gp7_pick_place.mod", "--robot", GP7_JOB)
    assert code == 2 and err.startswith(f"error: {GP7_JOB}:") and "gp7_pick_place.mod" not in err


@pytest.mark.parametrize("language, unit, orientation", [("rapid", "mm", "quaternion"), ("ls", "mm", "rpy"),
                                                         ("jbi", "mm", "rpy"), ("krl", "mm", "rpy"),
                                                         ("urscript", "m", None)])
def test_read_program_writes_the_programs_own_units(written, ur5_job, tmp_path, capsys, language, unit, orientation):
    """A program in mm and degrees reads back as a job in mm (and rpy in degrees where the language writes
    them): it came back in metres and quaternions."""
    program = written / next(name for name in WRITTEN[language] if not name.endswith(".dat"))
    out = tmp_path / "back.yaml"
    robot = load_job(job_of(language, ur5_job)).robot.spec.source
    assert cli(capsys, "read-program", program, "--robot", robot, "--out", out)[0] == 0
    document = yaml.safe_load(out.read_text())
    assert document["length_unit"] == unit
    poses = [w for w in document["waypoints"] if isinstance(w, dict) and "xyz" in w]
    if unit == "mm":
        assert poses and max(abs(v) for w in poses for v in w["xyz"]) > 100.0       # mm, not m
    if orientation is not None:
        assert all(orientation in w for w in poses)


def test_a_joint_waypoints_zone_is_written_back_in_the_programs_length_unit():
    """A joint waypoint with a zone reads back in mm like a pose's (a 40 mm zone came back as 0.04 mm)."""
    from pipeline.outputs.controllers.read_units import in_program_units

    document = {"length_unit": "m", "angle_unit": "deg", "waypoints": [
        [0, 0, 0, 0, 0, 0], {"q": [10, 0, 0, 0, 0, 0], "zone": 0.04}, {"xyz": [0.5, 0, 0.4], "rpy": [180, 0, 0],
                                                                        "zone": 0.025}]}
    for language in ("rapid", "ls", "jbi", "krl"):
        waypoints = in_program_units(document, language)["waypoints"]
        assert waypoints[0] == [0, 0, 0, 0, 0, 0] and waypoints[1] == {"q": [10, 0, 0, 0, 0, 0], "zone": 40.0}
        assert waypoints[2]["zone"] == 25.0 and waypoints[2]["xyz"] == [500.0, 0.0, 400.0]
    assert in_program_units(document, "urscript") == document


@pytest.mark.slow                                   # some 8 s; the settings-mark round trips cover arm6 in make test
def test_a_jbi_round_trip_of_the_arm6_demo_runs(tmp_path, capsys):
    """program -> read-program -> run on the arm6 demo: every waypoint read back names its configuration, and
    a branch change the configurations name is no error (it was refused as an unnamed one)."""
    job = ROOT / "trajectories" / "jobs" / "arm6_joint_rad.yaml"
    assert cli(capsys, "program", job, "--lang", "jbi", "--out", tmp_path / "ARM6.jbi")[0] == 0
    back = tmp_path / "back.yaml"
    assert cli(capsys, "read-program", tmp_path / "ARM6.jbi", "--robot", "arm6", "--out", back)[0] == 0
    code, _, err = cli(capsys, "run", back, "--out", tmp_path / "out")
    assert code == 0, err
