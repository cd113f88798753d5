"""The local web page (``pipeline.ui.page``), served in this process on an ephemeral 127.0.0.1 port and driven
through its own API and its controls: it binds to 127.0.0.1 only; dragging the target to a known pose yields
the known branches, drawn as ghosts and listed; a program built on the page, saved and run from the CLI's
runner gives the page's profile sample for sample; a bad value in a field is shown next to it and changes
nothing; and one headless Chromium screenshot of the page (skipped where Debian's ``chromium`` is missing).
"""

from __future__ import annotations

import socket
import threading
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from pipeline.cell.tool import rigid_inverse
from pipeline.errors import ConfigurationError
from pipeline.model.ik.branches import configuration_labels
from pipeline.runner import run_job_file
from pipeline.ui.page import LOCALHOST, Page, load_source
from pipeline.ui.screenshot import chromium, take_screenshot

JOBS = Path(__file__).resolve().parents[2] / "trajectories" / "jobs"
#: Joint values [deg] of the GP7 in gp7_shelf_cell that are collision-free, off every singular set.
FREE_DEG = (-20.0, 10.0, -20.0, 10.0, -70.0, 0.0)
#: ... and ones whose tool is in the middle board.
COLLIDING_DEG = (10.0, 20.0, -10.0, 15.0, -60.0, 20.0)


@pytest.fixture(scope="module")
def shelf_page():
    page = Page(load_source("gp7_shelf_cell"), port=0)
    yield page
    page.stop()


@pytest.fixture
def robot_page():
    page = Page(load_source("gp7"), port=0)
    yield page
    page.stop()


def connects(host: str, port: int) -> bool:
    """Whether the page answers an HTTP request at host:port."""
    try:
        with urllib.request.urlopen(f"http://{host}:{port}/", timeout=2.0) as answer:
            return answer.status == 200
    except OSError:                                    # refused, unreachable, timed out (URLError is one)
        return False


def other_addresses() -> list[str]:
    """This machine's IPv4 addresses other than loopback (the UDP socket sends nothing)."""
    addresses = set()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))             # TEST-NET-1: routing lookup only, no packet
            addresses.add(probe.getsockname()[0])
        except OSError:
            pass
    return sorted(a for a in addresses if not a.startswith("127."))


def test_the_server_binds_to_127_0_0_1_only(shelf_page):
    assert shelf_page.host == LOCALHOST and shelf_page.server.get_host() == LOCALHOST
    assert connects(LOCALHOST, shelf_page.port)
    others = other_addresses()
    if not others:
        pytest.skip("this machine has no address besides loopback")
    assert not any(connects(address, shelf_page.port) for address in others)


def test_dragging_the_target_to_a_known_pose_yields_its_branches(shelf_page):
    q0 = np.radians(FREE_DEG)
    shelf_page.set_joints(q0)
    X_WT = shelf_page.X_WB @ shelf_page.robot.fk(q0)
    view = shelf_page.drag_target(X_WT)
    assert 2 <= len(view.branches) <= 8
    ours = [b for b in view.branches if np.abs(b.q - q0).max() < 1e-9]
    assert len(ours) == 1 and ours[0].name == configuration_labels(shelf_page.robot, q0[None])[0]
    assert ours[0].state == "free" and ours[0].vendor_config is not None      # the GP7 on a Yaskawa: RCONF
    X_BT = rigid_inverse(shelf_page.X_WB) @ X_WT
    for branch in view.branches:
        np.testing.assert_allclose(shelf_page.robot.fk(branch.q), X_BT, atol=1e-9)
    ghosts = shelf_page.scene.ghosts
    assert [line.visible for line in ghosts.lines] == [k < len(view.branches) for k in range(len(ghosts.lines))]
    assert all(b.name in shelf_page.branch_table.content for b in view.branches)
    assert len(shelf_page.branch_choice.options) == len(view.branches)


def test_a_target_in_a_shelf_board_is_colliding_with_its_closest_pair(shelf_page):
    q = np.radians(COLLIDING_DEG)
    view = shelf_page.drag_target(shelf_page.X_WB @ shelf_page.robot.fk(q))
    ours = next(b for b in view.branches if np.abs(b.q - q).max() < 1e-9)
    assert ours.state == "colliding" and ours.clearance.obstacle_pair == ("tool", "board_middle")
    assert ours.clearance.obstacle < 0.0 and "board_middle" in shelf_page.branch_table.content
    k = view.branches.index(ours)
    assert shelf_page.scene.ghosts.handles[k].color == (215, 40, 40)


def test_adopting_a_branch_jogs_the_arm_and_the_sliders(shelf_page):
    shelf_page.set_joints(np.radians(FREE_DEG))
    view = shelf_page.drag_target(shelf_page.X_WB @ shelf_page.robot.fk(np.radians(FREE_DEG)))
    k = len(view.branches) - 1
    shelf_page.adopt(k)
    np.testing.assert_array_equal(shelf_page.q, view.branches[k].q)
    np.testing.assert_allclose([s.value for s in shelf_page.sliders], np.degrees(view.branches[k].q), atol=1e-6)


def test_a_slider_jogs_the_arm_and_the_readout(robot_page):
    robot_page.sliders[0].value = 30.0                 # as the browser sets it: the callback runs
    assert robot_page.q[0] == pytest.approx(np.radians(30.0))
    assert robot_page.tcp_readout() == robot_page.readout.content and "xyz" in robot_page.readout.content


def test_a_bad_zone_is_shown_next_to_the_field_and_changes_nothing(robot_page):
    before = len(robot_page.program.waypoints)
    robot_page.move_kind.value = "joint"
    robot_page.zone_text.value = "ten"
    robot_page.add_button.value = True                 # a click
    assert len(robot_page.program.waypoints) == before
    assert "zone" in robot_page.program_error.content


def test_a_program_built_on_the_page_runs_the_same_from_its_saved_job(robot_page, tmp_path):
    """Joint start, a joint move at 50 %, a linear move at 200 mm/s with a 20 mm zone, a linear stop: the
    page's profile and the CLI runner's on the saved file are equal sample for sample."""
    page = robot_page
    for q_deg, move, speed, zone in (((0, 10, -10, 0, -60, 0), "joint", "", ""),
                                     ((20, 20, -5, 0, -70, 10), "joint", "50", ""),
                                     ((20, 30, -5, 0, -60, 10), "linear", "200", "20"),
                                     ((10, 30, -5, 0, -60, 10), "linear", "200", "")):
        page.set_joints(np.radians(q_deg))
        page.add_waypoint(move, speed, zone)
    outcome = page.plan_and_time(wait=True)
    assert outcome.limit_report.passed and len(outcome.profile.t) > 10
    saved = page.save_job(tmp_path / "page_job.yaml")
    again = run_job_file(saved, tmp_path / "cli")
    assert np.array_equal(again.profile.t, outcome.profile.t) and np.array_equal(again.profile.q, outcome.profile.q)
    assert page.plots["q"].data[0][-1] == pytest.approx(outcome.profile.t[-1] - outcome.profile.t[0])
    assert page.scene.trace is not None
    exported = page.export("rapid", tmp_path)
    assert [p.name for p in exported] == [f"{page.program.name}.mod"] and exported[0].read_text().startswith("MODULE")


def test_urscript_for_the_gp7_is_refused_next_to_the_export_button_and_writes_nothing(robot_page, tmp_path):
    """The GP7 is a Yaskawa arm: exporting URScript (offered for every robot) shows the refusal with its fix, before
    any planning; it said only "plan and time the program first"."""
    robot_page.path_text.value = str(tmp_path / "page_job.yaml")
    robot_page.language.value = "urscript"
    robot_page.export_button.value = True              # a click
    shown = robot_page.program_error.content
    assert "gp7: URScript runs only on a Universal Robots controller" in shown and "maker yaskawa" in shown, shown
    assert "controller: {maker: ur}" in shown and "--lang jbi" in shown
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_headless_chromium_screenshot_of_the_page(shelf_page, tmp_path):
    if chromium() is None:
        pytest.skip("Debian's chromium is not installed")
    shelf_page.set_joints(np.radians(FREE_DEG))
    shelf_page.drag_target(shelf_page.X_WB @ shelf_page.robot.fk(np.radians(FREE_DEG)))
    picture = take_screenshot(f"http://{LOCALHOST}:{shelf_page.port}", tmp_path / "page.png")
    from PIL import Image

    pixels = np.asarray(Image.open(picture).convert("RGB"), dtype=float)
    middle = pixels[200:700, 200:900]                  # the 3-D view, left of the control panel
    assert middle.std() > 10.0                         # drawn: not a blank or single-colour view


def test_drag_events_are_drawn_one_at_a_time_and_the_newest_wins(robot_page, monkeypatch):
    """Events that arrive while a target is drawn are merged: the newest one is drawn next, none in parallel."""
    page, drawn, events = robot_page, [], []
    poses = [page.robot.fk(np.radians([a, 10, -10, 0, -60, 0])) for a in (0, 10, 20, 30)]

    def slow_draw(X_WT):
        drawn.append(X_WT[:3, 3].copy())
        if len(drawn) == 1:                  # while the first is drawn, three more events arrive
            for X in poses[1:]:
                page.place_target(X)
                events.append(threading.Thread(target=page._gizmo_moved))
                events[-1].start()
                events[-1].join()

    monkeypatch.setattr(page, "drag_target", slow_draw)
    page.place_target(poses[0])
    page._gizmo_moved()
    np.testing.assert_allclose(drawn, [poses[0][:3, 3], poses[3][:3, 3]], atol=1e-9)


def test_loading_a_job_of_another_robot_is_refused_with_the_command_that_opens_it(robot_page):
    before = robot_page.program
    with pytest.raises(ConfigurationError, match="python -m pipeline ui .*irb1600_tool_moves.yaml"):
        robot_page.load_job(JOBS / "irb1600_tool_moves.yaml")
    assert robot_page.program is before
    robot_page.load_job(JOBS / "gp7_pick_place.yaml")
    assert robot_page.program is not before and len(robot_page.program.waypoints) > 2
