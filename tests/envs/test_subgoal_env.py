"""The lifted environment: one step = one subgoal executed by the motion generator."""

import numpy as np
import pybullet as p
import pytest
import torch

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import decode_indices, encode_indices
from relmogen.motion_generation.generator import collides_beyond, contact_depths
from relmogen.motion_generation.planners import BACKENDS
from relmogen.simulation.contacts import Collision


@pytest.fixture(scope="module")
def nav():
    env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64)
    yield env
    env.close()


def base_action(angle_deg=0.0, distance=1.0, yaw=0.0):
    """subgoal-r action for a base subgoal (distance in metres, 0-2)."""
    return np.array([1.0, angle_deg / 110.0, distance - 1.0, yaw / np.pi, 0, 0, 0, 0], dtype=np.float32)


def world_snapshot(env):
    robot = env.robot
    joints = robot.get_joint_positions(range(p.getNumJoints(robot.robot_id, physicsClientId=env.world.client)))
    return np.concatenate([robot.base_pose(), joints])


def test_episode_lengths_are_counted_in_subgoals(nav):
    assert nav.control.episode_steps == 25
    reach = RelmogenEnv(task="TabletopReachM", control="subgoal-r", image_size=64)
    assert reach.control.episode_steps == 5
    reach.close()


def test_rotation_in_place_is_a_valid_plan(nav):
    nav.reset(seed=0)
    x, y, yaw = nav.robot.base_pose()
    _, _, _, _, info = nav.step(base_action(distance=0.0, yaw=90.0 * np.pi / 180 * 180 / np.pi))
    assert info["plan_found"] and info["reason"] == "rotation in place"
    assert np.allclose(nav.robot.base_pose()[:2], (x, y), atol=1e-6)
    assert info["path_length_m"] == 0.0 and info["sim_time_s"] > 0.0


def test_failed_plan_is_a_no_op_that_still_counts(nav):
    nav.reset(seed=0)
    before = world_snapshot(nav)
    outcomes = []
    for seed_angle in np.linspace(-110, 110, 12):  # some of these goals are in walls or furniture
        _, reward, _, _, info = nav.step(base_action(seed_angle, 2.0))
        if not info["plan_found"]:
            outcomes.append(info["reason"])
            assert reward == 0.0
            np.testing.assert_allclose(world_snapshot(nav), before, atol=1e-9)
        else:
            before = world_snapshot(nav)
    assert outcomes, "expected at least one infeasible goal among 12 directions at 2 m"
    assert nav.elapsed_steps == 12
    assert all(isinstance(r, str) and r for r in outcomes)


def test_every_executed_base_waypoint_is_collision_free_in_the_full_simulation(monkeypatch):
    env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64)
    visited = []
    original = env.robot.set_base_pose
    monkeypatch.setattr(env.robot, "set_base_pose", lambda *pose: (visited.append(pose), original(*pose)))
    rng = np.random.default_rng(0)
    executed = 0
    for episode in range(4):
        env.reset(seed=episode)
        for _ in range(10):
            visited.clear()
            start = env.robot.base_pose()
            _, _, terminated, _, info = env.step(base_action(rng.uniform(-110, 110), rng.uniform(0.3, 2.0),
                                                             rng.uniform(-180, 180)))
            if not info["plan_found"]:
                continue
            executed += 1
            end = env.robot.base_pose()
            original(*start)
            p.performCollisionDetection(physicsClientId=env.world.client)
            touching_at_start = contact_depths(env.collisions())
            for pose in visited:  # replay: every pose the MG put the robot at and kept
                original(*pose)
                p.performCollisionDetection(physicsClientId=env.world.client)
                if collides_beyond(env.collisions(), touching_at_start):
                    assert "stopped before a collision" in info["reason"]
                    assert not np.allclose(pose, end)
            original(*end)
            assert info["path_length_m"] >= np.hypot(*(end[:2] - start[:2])) - 1e-6
            if terminated:
                break
    assert executed >= 10
    env.close()


def nearest_wall(env):
    """After a seed-0 reset: the robot's (x, y), the world direction of the nearest LiDAR hit and its range."""
    env.reset(seed=0)
    scan = env.scan()
    nearest = int(np.argmin(scan))
    x, y, yaw = env.robot.base_pose()
    return x, y, yaw + env.lidar.angles[nearest], float(scan[nearest])


def test_start_touching_an_obstacle_can_leave_it(nav):
    # back the robot up against the closest wall: face away from it at 0.30 m clearance
    x, y, toward, distance = nearest_wall(nav)
    gap = distance - 0.30
    nav.robot.set_base_pose(x + gap * np.cos(toward), y + gap * np.sin(toward), toward + np.pi)
    nav.robot.stop_wheels()
    _, _, _, _, info = nav.step(base_action(0.0, 0.8))
    assert info["plan_found"], info["reason"]


def test_a_robot_pressed_against_a_wall_can_turn_and_drive_away(nav):
    x, y, toward, distance = nearest_wall(nav)
    heading = toward + np.pi  # the wall behind the robot
    for along in np.arange(0.0, distance, 0.005):  # back up until the base touches it, then 5 mm more
        nav.robot.set_base_pose(x + along * np.cos(toward), y + along * np.sin(toward), heading)
        p.performCollisionDetection(physicsClientId=nav.world.client)
        if nav.collisions():
            nav.robot.set_base_pose(x + (along + 0.005) * np.cos(toward), y + (along + 0.005) * np.sin(toward),
                                    heading)
            break
    p.performCollisionDetection(physicsClientId=nav.world.client)
    assert nav.collisions(), "the robot should start in contact with the wall"
    nav.robot.stop_wheels()
    _, _, _, _, info = nav.step(base_action(60.0, 0.6))  # turn on the spot first: the contact persists
    assert info["plan_found"], info["reason"]
    assert info["reason"] != "stopped before a collision at waypoint 1" and info["path_length_m"] > 0.2


def test_a_waypoint_may_keep_a_contact_of_the_start_but_not_deepen_it_or_add_one():
    start = contact_depths([Collision("base_link", 3, -1, -0.004), Collision("base_link", 3, -1, -0.001)])
    assert start == {(3, -1): -0.004}
    assert not collides_beyond([Collision("base_link", 3, -1, -0.005)], start)  # within the tolerance
    assert collides_beyond([Collision("base_link", 3, -1, -0.010)], start)  # deeper
    assert collides_beyond([Collision("base_link", 4, -1, 0.0)], start)  # a new body
    assert collides_beyond([Collision("base_link", 3, 2, 0.0)], start)  # another link of it
    assert not collides_beyond([], start)


def test_goal_outside_the_window_or_in_a_wall_fails_at_once_with_a_reason(monkeypatch):
    env = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=64)
    monkeypatch.setattr(env.control.mg._base_planner, "plan", lambda *a, **k: pytest.fail("planner called"))
    _, info = env.reset(seed=0)
    control = env.control
    blocked = np.argwhere(~info["base_mask"])
    assert len(blocked), "expected occupied cells in the local map"
    i, j = blocked[0]
    _, reward, _, _, info = env.step(control.encode("base", 0, int(i), int(j)))
    assert not info["plan_found"] and info["reason"] in ("goal in collision", "goal outside local map")
    env.close()


@pytest.mark.parametrize("qmap_size,cell_pixels", [(None, 4), (32, 2)])
def test_arm_mask_marks_pixels_with_depth_within_reach_and_masked_pushes_find_no_plan(qmap_size, cell_pixels):
    env = RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=64, arm_collision=False,
                      qmap_size=qmap_size)
    _, info = env.reset(seed=1)
    control, frame = env.control, env.last_frame
    assert info["arm_mask"].shape == info["base_mask"].shape == (64 // cell_pixels,) * 2
    shoulder, reach = env.robot.arm_base_position(), env.robot.spec.arm_reach
    expected = np.zeros((control.q, control.q), dtype=bool)
    centre = cell_pixels // 2
    for i in range(control.q):
        for j in range(control.q):
            row, col = cell_pixels * i + centre, cell_pixels * j + centre
            if frame.has_point(row, col):
                expected[i, j] = np.linalg.norm(env.camera.pixel_to_world(frame, col, row) - shoulder) <= reach
    np.testing.assert_array_equal(info["arm_mask"], expected)
    far = [(int(i), int(j)) for i, j in np.argwhere(~expected)
           if frame.has_point(cell_pixels * i + centre, cell_pixels * j + centre)]
    assert far, "expected pixels beyond the arm's reach in a corridor view"
    for i, j in far[:2]:
        _, _, _, _, step_info = env.step(control.encode("arm", 0, i, j))
        assert not step_info["plan_found"], step_info["reason"]
    env.close()


def open_direction_deg(env):
    """Bearing (deg, robot frame) of the longest LiDAR range: somewhere to drive to."""
    return float(np.rad2deg(env.lidar.angles[int(np.argmax(env.scan()))]))


def test_planners_swap_at_test_time_on_the_same_subgoal_sequence():
    probe = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64)
    probe.reset(seed=5)
    bearing = open_direction_deg(probe)
    probe.close()
    actions = [base_action(0, 0.0, bearing), base_action(0, 1.0), base_action(0, 0.0, 90), base_action(0, 0.0, -90)]
    final_poses = {}
    for backend in sorted(BACKENDS):
        env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64, base_planner=backend)
        env.reset(seed=5)
        infos = [env.step(a)[4] for a in actions]
        assert {info["planner"] for info in infos} == {backend}
        assert all(info["plan_found"] for info in infos), [info["reason"] for info in infos]
        final_poses[backend] = env.robot.base_pose()
        env.close()
    poses = np.array(list(final_poses.values()))
    assert np.allclose(poses, poses[0], atol=0.05)  # the same subgoals end in the same place
    # and swapping inside one environment, between steps
    env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64)
    env.reset(seed=5)
    for backend, action in zip(sorted(BACKENDS), actions):
        env.control.mg.set_planners(base=backend)
        info = env.step(action)[4]
        assert info["planner"] == backend and info["plan_found"]
    env.close()


@pytest.mark.parametrize(
    "action,message",
    [(np.full(8, np.nan), "NaN"), (np.zeros(5), "shape"), (np.array([np.inf] * 8), "infinite")],
)
def test_malformed_subgoal_r_actions_raise(nav, action, message):
    nav.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        nav.step(action)


@pytest.mark.parametrize("action,message", [(-1, "outside"), (10**9, "outside"), (2.5, "integer"), ("a", "integer")])
def test_malformed_subgoal_d_actions_raise(action, message):
    env = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=64)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step(action)
    env.close()


def test_qmap_size_sets_the_map_side_independently_of_the_image():
    env = RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=64, qmap_size=32)
    control = env.control
    assert control.q == 32 and control.action_space.n == 24_576  # the paper's action count from 64 px
    assert [control.cell_pixel(i, j) for i, j in [(0, 0), (1, 2), (31, 31)]] == [(1, 1), (3, 5), (63, 63)]
    for row in range(64):
        assert control.pixel_cell(row, row) == (row // 2, row // 2)
    with pytest.raises(ValueError, match="divisor"):
        RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=64, qmap_size=24)
    env.close()


def test_subgoal_d_index_mapping_round_trips():
    env = RelmogenEnv(task="TabletopReachM", control="subgoal-d", image_size=128)
    control = env.control
    assert control.action_space.n == 24_576  # 12 x 32 x 32 base + 12 x 32 x 32 arm
    rng = np.random.default_rng(0)
    for index in rng.integers(0, control.action_space.n, 200):
        assert control.encode(*control.decode(int(index))) == index
    assert control.decode(0) == ("base", 0, 0, 0)
    assert control.decode(12 * 32 * 32) == ("arm", 0, 0, 0)
    with pytest.raises(ValueError, match="no arm action"):
        control.encode("arm", 12, 0, 0)
    env.close()


@pytest.mark.parametrize("as_array", [np.asarray, torch.as_tensor])
def test_encode_indices_inverts_decode_indices(as_array):
    indices = as_array(np.arange(24 * 16 * 16))
    decoded = decode_indices(indices, 16)
    assert (encode_indices(*decoded, 16) == indices).all()


def test_pointnav_subgoals_are_base_only(nav):
    nav.reset(seed=0)
    _, _, _, _, info = nav.step(np.array([-1, 0, 0, 0.5, 0, 0, 0, 0], dtype=np.float32))  # a[0] < 0 is ignored
    assert info["subgoal_type"] == "base"


def test_arm_pixel_without_depth_is_a_no_op_with_a_reason():
    nav = RelmogenEnv(task="PushDoorNav", control="subgoal-r", image_size=64)
    nav.reset(seed=0)
    nav.last_frame.points_depth[0, 0] = 0.0  # force: the top-left pixel sees nothing
    before = world_snapshot(nav)
    action = np.array([-1, 0, 0, 0, -1, -1, 0.5, 0], dtype=np.float32)
    _, reward, _, _, info = nav.step(action)
    assert info["subgoal_type"] == "arm" and info["reason"] == "pixel has no depth"
    assert not info["plan_found"]
    np.testing.assert_allclose(world_snapshot(nav), before, atol=1e-9)
    nav.close()


def test_pushing_into_a_wall_reports_a_blocked_push():
    env = RelmogenEnv(task="TabletopReachM", control="subgoal-r", image_size=64, arm_collision=False)
    env.reset(seed=0)
    # the table top straight ahead, pushed down into the table: the gripper cannot go far
    h, w = env.last_frame.depth.shape
    rows = [r for r in range(h // 2, h) if env.last_frame.depth[r, w // 2] > 0]
    row = rows[len(rows) // 2]
    action = np.array([-1, 0, 0, 0, 2 * row / h - 1, 0.0, 1.0, 0.0], dtype=np.float32)
    reasons = []
    for _ in range(3):
        _, _, terminated, _, info = env.step(action)
        reasons.append(info["reason"])
        if terminated:
            break
    assert any(r.startswith("push") for r in reasons), reasons
    env.close()


def subgoal_r_equivalent(control, index: int) -> np.ndarray:
    """The subgoal-r action that means what discrete ``index`` means (its cell centre, its bin)."""
    part, bin_, i, j = control.decode(index)
    if part == "base":
        cell = 5.0 / control.q
        x, y = (i + 0.5) * cell - 2.5, (j + 0.5) * cell - 2.5
        yaw = -np.pi + bin_ * 2 * np.pi / 12
        return np.array([1.0, np.arctan2(y, x) / np.deg2rad(110.0), np.hypot(x, y) - 1.0, yaw / np.pi, 0, 0, 0, 0])
    size = control.map_pixels
    c = size // control.q  # pixels per cell: the arm acts at the cell's centre pixel
    row, col = c * i + c // 2, c * j + c // 2
    heading = control.push_heading(bin_, i, j)
    return np.array([-1.0, 0, 0, 0, 2 * (row + 0.5) / size - 1, 2 * (col + 0.5) / size - 1,
                     np.cos(heading), np.sin(heading)])


@pytest.mark.parametrize("push_frame,qmap_size", [("base", None), ("surface", None), ("surface", 32)])
def test_nearest_index_inverts_the_discrete_actions(push_frame, qmap_size):
    """How oracles act through subgoal-d (demonstrations): each discrete action's own meaning,
    written as a subgoal-r action, maps back to it, at the default 16 x 16 maps of 64 px and at
    the paper's 32 x 32 from the same 64 px."""
    env = RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=64, push_frame=push_frame,
                      qmap_size=qmap_size)
    env.reset(seed=1)
    control, q = env.control, env.control.q
    cell = 5.0 / q
    centre = (np.arange(q) + 0.5) * cell - 2.5
    x, y = np.meshgrid(centre, centre, indexing="ij")
    in_range = (np.hypot(x, y) <= 2.0) & (np.abs(np.arctan2(y, x)) < np.deg2rad(110.0))  # subgoal-r can say it
    rng = np.random.default_rng(0)
    base = [control.encode("base", int(rng.integers(12)), int(i), int(j)) for i, j in np.argwhere(in_range)]
    arm = [control.encode("arm", int(k), int(i), int(j)) for k, i, j in
           zip(rng.integers(12, size=200), rng.integers(q, size=200), rng.integers(q, size=200))]
    for index in base + arm:
        assert control.nearest_index(subgoal_r_equivalent(control, index)) == index
    env.close()


def test_surface_frame_pushes_go_into_steep_surfaces_and_never_the_floor():
    env = RelmogenEnv(task="ArrangeKitchenMM", control="subgoal-d", image_size=64, push_frame="surface")
    _, info = env.reset(seed=0)  # facing cabinets over the floor
    control, frame, q = env.control, env.last_frame, env.control.q
    centres = 4 * np.arange(q) + 2
    rows, cols = np.meshgrid(centres, centres, indexing="ij")
    points, has_depth = env.camera.pixels_to_world(frame, cols, rows)
    normals = env.camera.surface_normals(frame, cols, rows)
    floor = has_depth & (points[..., 2] < 0.025)  # the floor's top is at 1-2 cm
    assert floor.any() and not info["arm_mask"][floor].any()
    np.testing.assert_allclose(normals[floor][:, 2], 1.0, atol=0.02)  # the floor faces up (depth is quantised)
    allowed = np.argwhere(info["arm_mask"])
    assert len(allowed) > 10
    yaw = env.robot.base_pose()[2]
    for i, j in allowed:
        inward = -normals[i, j, :2] / np.linalg.norm(normals[i, j, :2])
        headings = [control.push_heading(k, i, j) + yaw for k in range(12)]
        into = [np.dot([np.cos(h), np.sin(h)], inward) for h in headings]
        assert min(into) > 0.1 and max(into) > 0.99  # every bin into the surface, the middle ones head-on
        view = points[i, j] - frame.position
        assert np.dot(normals[i, j], view) < 0  # normals face the camera
    env.close()


def test_measured_reach_mask_drops_far_cells_of_the_sphere_mask():
    masks = {}
    for reach_mask in ("sphere", "measured"):
        env = RelmogenEnv(task="ArrangeKitchenMM", control="subgoal-d", image_size=64, push_frame="surface",
                          qmap_size=32, reach_mask=reach_mask)
        masks[reach_mask] = env.reset(seed=0)[1]["arm_mask"]
        env.close()
    sphere, measured = masks["sphere"], masks["measured"]
    assert measured.sum() > 100 and not (measured & ~sphere).any() and (sphere & ~measured).any()


def test_unknown_reach_mask_is_refused():
    with pytest.raises(ValueError, match="unknown reach_mask 'cube'"):
        RelmogenEnv(task="PointNav", control="subgoal-d", image_size=64, reach_mask="cube")


def test_unknown_push_frame_is_refused():
    with pytest.raises(ValueError, match="unknown push_frame 'tool'"):
        RelmogenEnv(task="PointNav", control="subgoal-d", image_size=64, push_frame="tool")



@pytest.mark.parametrize("control", ["subgoal-r", "subgoal-d"])
def test_arm_subgoal_beyond_reach_is_a_no_op_without_ik(monkeypatch, control):
    """A pixel seeing a point farther than ``arm_reach`` from the arm's base fails at once, with
    the distance in the reason, and never reaches IK or the planner; a reachable one does."""
    from relmogen.envs.subgoal_controls import arm_base_distance
    from relmogen.motion_generation.generator import MotionGenerator
    from relmogen.motion_generation.ik import ArmIK

    env = RelmogenEnv(task="ButtonDoorNav", control=control, image_size=64, arm_collision=False)
    env.reset(seed=1)  # a corridor view: the far wall is out of reach
    monkeypatch.setattr(ArmIK, "solve", lambda *a, **k: pytest.fail("IK called"))
    monkeypatch.setattr(MotionGenerator, "reach_and_push", lambda *a, **k: pytest.fail("MG called"))
    frame, reach = env.last_frame, env.robot.spec.arm_reach
    rows, cols = np.meshgrid(4 * np.arange(16) + 2, 4 * np.arange(16) + 2, indexing="ij")  # SGP-D's cell pixels
    points, has_depth = env.camera.pixels_to_world(frame, cols, rows)
    distance = arm_base_distance(env, points)

    def arm_action(i, j):
        if control == "subgoal-d":
            return env.control.encode("arm", 0, int(i), int(j))
        return np.array([-1, 0, 0, 0, 2 * (rows[i, j] + 0.5) / 64 - 1, 2 * (cols[i, j] + 0.5) / 64 - 1, 0.5, 0],
                        dtype=np.float32)

    far = np.argwhere(has_depth & (distance > reach + 0.2))
    near = np.argwhere(has_depth & (distance < reach - 0.3))
    assert len(far) and len(near), "expected pixels both beyond and within reach in this view"
    i, j = far[len(far) // 2]
    before = world_snapshot(env)
    _, _, _, _, info = env.step(arm_action(i, j))
    assert info["subgoal_type"] == "arm" and not info["plan_found"] and info["sim_time_s"] == 0.0
    assert info["reason"] == f"point {distance[i, j]:.2f} m from the arm base, beyond its reach of {reach:.2f} m"
    np.testing.assert_allclose(world_snapshot(env), before, atol=1e-9)
    with pytest.raises(pytest.fail.Exception, match="MG called"):  # the same rule lets a reachable pixel through
        env.step(arm_action(*near[0]))
    env.close()


def test_noop_cost_charges_a_subgoal_that_executed_nothing_and_nothing_else():
    env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64, noop_cost=0.25)
    env.reset(seed=0)
    charged = []
    for angle in np.linspace(-110, 110, 12):  # some of these 2 m goals are in walls (strict: no plan)
        _, reward, _, _, info = env.step(base_action(angle, 2.0))
        no_op = not info["plan_found"] or info["sim_time_s"] == 0.0
        assert info["reward_terms"].get("no_op", 0.0) == (-0.25 if no_op else 0.0)
        charged.append(no_op)
    assert any(charged) and not all(charged)
    _, _, _, _, info = env.step(base_action(distance=0.0, yaw=0.0))  # a rotation by nothing moves nothing
    assert info["plan_found"] and info["reward_terms"]["no_op"] == -0.25
    env.close()
    with pytest.raises(ValueError, match="noop_cost"):
        RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64, noop_cost=-1.0)


def test_nearest_free_base_goals_plan_where_strict_ones_find_none():
    strict = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64)
    loose = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64, base_goal="nearest_free")
    strict.reset(seed=0)
    loose.reset(seed=0)
    moved_back = 0
    for angle in np.linspace(-110, 110, 12):
        _, _, _, _, info = strict.step(base_action(angle, 2.0))
        if info["reason"] == "goal in collision":
            strict_pose = strict.robot.base_pose()
            _, _, _, _, loose_info = loose.step(base_action(angle, 2.0))
            assert loose_info["plan_found"] and loose_info["reason"].startswith("goal in collision, moved")
            moved_back += 1
            loose.robot.set_base_pose(*strict_pose)  # both continue from the same pose
        else:
            loose.robot.set_base_pose(*strict.robot.base_pose())
    assert moved_back
    strict.close()
    loose.close()


def test_subgoal_feedback_observes_the_previous_action_and_whether_it_executed_nothing():
    env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64, subgoal_feedback=True)
    assert env.observation_space["last_subgoal"].shape == (9,)
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs["last_subgoal"], np.zeros(9, dtype=np.float32))
    seen = set()
    for angle in np.linspace(-110, 110, 12):  # some of these 2 m goals are in walls (strict: no plan)
        action = base_action(angle, 2.0)
        obs, _, _, _, info = env.step(action)
        no_op = not info["plan_found"] or info["sim_time_s"] == 0.0
        np.testing.assert_allclose(obs["last_subgoal"][:8], action)
        assert obs["last_subgoal"][8] == float(no_op)
        assert env.observation_space.contains(obs)
        seen.add(no_op)
    assert seen == {True, False}
    obs, _ = env.reset(seed=1)
    np.testing.assert_array_equal(obs["last_subgoal"], np.zeros(9, dtype=np.float32))
    env.close()
    assert "last_subgoal" not in RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64).observation_space.spaces


def test_base_subgoals_plan_on_the_observation_scan_until_the_robot_moves():
    env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=64)
    obs, _ = env.reset(seed=0)
    np.testing.assert_allclose(obs["scan"] * env.lidar.max_range, env.last_scan, rtol=1e-6)
    assert env.observed_scan() is env.last_scan  # nothing moved: the observation's rays are reused
    x, y, yaw = env.robot.base_pose()
    env.robot.set_base_pose(x, y, yaw + 0.5)
    fresh = env.observed_scan()
    assert fresh is not env.last_scan and not np.allclose(fresh, env.last_scan)
    env.close()


def test_the_arm_rrt_budget_reaches_the_arm_planner_and_survives_a_planner_swap():
    env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=32, arm_rrt=(100, 4))
    try:
        arm = env.control.mg.arm
        assert (arm.planner.params.iterations, arm.planner.params.restarts) == (100, 4)
        env.control.mg.set_planners(arm="lazy_prm")
        env.control.mg.set_planners(arm="rrt_connect")
        assert (arm.planner.params.iterations, arm.planner.params.restarts) == (100, 4)
    finally:
        env.close()
