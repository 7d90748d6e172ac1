"""A corpus of bad configs, grown from the config reference (README "Config reference", docs/*.md) and each plugin
type's schema: every section and every built-in plugin type's parameters, wrong in the ways people get them wrong.

Each case is ``(toml text, key, fragment)``: ``robokit validate`` must refuse it with exit 2 and exactly one line,
``robokit: error: <file>: <key>: ...`` containing ``fragment``. The scenes are small on purpose: the bad part is
the only thing wrong with them.
"""

from __future__ import annotations

from typing import NamedTuple

PLANE = '[bodies.plane]\nurdf = "plane.urdf"\nposition = [0, 0, 0]\n'
BOX = PLANE + '\n[bodies.box]\nshape = "box"\nposition = [0, 0, 0.5]\n'
ROBOT = PLANE + '\n[robots.robot]\nurdf = "robots/diffbot.urdf"\nposition = [0, 0, 0.06]\n'
PANDA = PLANE + '\n[robots.panda]\nurdf = "franka_panda/panda.urdf"\nposition = [0, 0, 0]\nfixed_base = true\n'
DRIVE = ROBOT + '\n[sensors.scan]\ntype = "lidar"\nrate_hz = 10\n\n[actuators.drive]\ntype = "diff_drive"\n'
ARM = (PANDA + '\n[actuators.arm]\ntype = "ik_arm"\nbody = "panda"\nee_link = "panda_grasptarget"\n'
       "ready_pose = { panda_joint1 = 0.0, panda_joint2 = -0.4, panda_joint3 = 0.0, panda_joint4 = -2.2, "
       "panda_joint5 = 0.0, panda_joint6 = 1.8, panda_joint7 = 0.785 }\n"
       '\n[actuators.gripper]\ntype = "gripper"\nbody = "panda"\n')


class Case(NamedTuple):
    toml: str
    key: str
    fragment: str


def sensor(scene: str, type_name: str, options: str = "", name: str = "s") -> str:
    return f'{scene}\n[sensors.{name}]\ntype = "{type_name}"\n{options}\n'


def actuator(scene: str, type_name: str, options: str = "", name: str = "a") -> str:
    return f'{scene}\n[actuators.{name}]\ntype = "{type_name}"\n{options}\n'


def behaviour(scene: str, type_name: str, options: str = "") -> str:
    return f'{scene}\n[behaviour]\ntype = "{type_name}"\n{options}\n'


def body(options: str, name: str = "b") -> str:
    return f'{PLANE}\n[bodies.{name}]\n{options}\n'


def event(options: str) -> str:
    return f"{BOX}\n[[events]]\n{options}\n"


def world(options: str) -> str:
    return f"[world]\n{options}\n{BOX}"


CASES: dict[str, Case] = {
    # ----------------------------------------------------------------- sections and [world]
    "unknown section": Case("[wrold]\nseed = 1\n" + BOX, "wrold", "did you mean 'world'?"),
    "world not a table": Case("world = 5\n" + BOX, "world", "expected a table"),
    "world unknown key": Case(world("gravty = [0, 0, -9.81]"), "world.gravty", "did you mean 'gravity'?"),
    "world gravity too few": Case(world("gravity = [0, -9.81]"), "world.gravity", "too few values"),
    "world gravity string": Case(world('gravity = "down"'), "world.gravity", "list"),
    "world gravity absurd": Case(world("gravity = [0, 0, -1e6]"), "world.gravity.2", "-1000"),
    "world time_step zero": Case(world("time_step = 0"), "world.time_step", "greater than 0"),
    "world time_step huge": Case(world("time_step = 1"), "world.time_step", "less than or equal to 0.1"),
    "world solver_iterations zero": Case(world("solver_iterations = 0"), "world.solver_iterations", ">= 1"
                                         .replace(">= 1", "greater than or equal to 1")),
    "world solver_iterations float": Case(world("solver_iterations = 1.5"), "world.solver_iterations",
                                          "valid integer"),
    "world seed negative": Case(world("seed = -1"), "world.seed", "greater than or equal to 0"),
    "world max_time zero": Case(world("max_time = 0"), "world.max_time", "greater than 0"),
    "world max_time absurd": Case(world("max_time = 1e9"), "world.max_time", "less than or equal to 1000000"),
    "world max_wall_time negative": Case(world("max_wall_time = -5"), "world.max_wall_time", "greater than 0"),
    "world realtime string": Case(world('realtime = "yes"'), "world.realtime", "valid boolean"),
    "record pose_hz negative": Case("[record]\npose_hz = -1\n" + BOX, "record.pose_hz",
                                    "greater than or equal to 0"),
    "record save_frames string": Case('[record]\nsave_frames = "yes"\n' + BOX, "record.save_frames",
                                      "valid boolean"),
    "gui unknown key": Case("[gui]\nbogus = 1\n" + BOX, "gui.bogus", "unknown key 'bogus'"),
    "nothing to run": Case("[world]\nseed = 3\n", "", "nothing to run"),
    # ----------------------------------------------------------------- [regions]
    "region low missing": Case(PLANE + '[regions.r]\nhigh = [1, 1]\n[bodies.b]\nshape = "box"\nregion = "r"\n',
                               "regions.r.low", "Field required"),
    "region inverted": Case(PLANE + '[regions.r]\nlow = [1, 1]\nhigh = [0, 0]\n[bodies.b]\nshape = "box"\n'
                                    'region = "r"\n', "regions.r", "must be <="),
    "region min_spacing negative": Case(PLANE + '[regions.r]\nlow = [0, 0]\nhigh = [1, 1]\nmin_spacing = -1\n',
                                        "regions.r.min_spacing", "greater than or equal to 0"),
    "region unknown": Case(body('shape = "box"\nregion = "tabel"'), "bodies.b.region", "unknown region 'tabel'"),
    "region avoid unknown body": Case(PLANE + '[regions.r]\nlow = [0, 0]\nhigh = [1, 1]\navoid = ["ghost"]\n'
                                              '[bodies.b]\nshape = "box"\nregion = "r"\n',
                                      "regions.r.avoid", "unknown body 'ghost'"),
    "region too crowded": Case(PLANE + '[regions.r]\nlow = [0, 0]\nhigh = [0.5, 0.5]\nmin_spacing = 1.0\n'
                                       '[bodies.b]\nshape = "box"\nregion = "r"\ncount = 20\n', "regions.r", ""),
    "absurd count": Case(PLANE + '[regions.r]\nlow = [0, 0]\nhigh = [9, 9]\n[bodies.b]\nshape = "box"\n'
                                 'region = "r"\ncount = 1000000\n', "bodies.b.count", "less than or equal to 10000"),
    # ----------------------------------------------------------------- [bodies] / [robots]
    "body shape and urdf": Case(body('shape = "box"\nurdf = "cube.urdf"\nposition = [0, 0, 1]'), "bodies.b",
                                "exactly one of 'shape'"),
    "body neither shape nor urdf": Case(body("position = [0, 0, 1]"), "bodies.b", "exactly one of 'shape'"),
    "body no position": Case(body('shape = "box"'), "bodies.b", "give 'position' or 'region'"),
    "body unknown shape": Case(body('shape = "cube"\nposition = [0, 0, 1]'), "bodies.b.shape", "'box'"),
    "body missing urdf": Case(body('urdf = "no_such_robot.urdf"\nposition = [0, 0, 1]'), "bodies.b",
                              "no_such_robot.urdf"),
    "body position too few": Case(body('shape = "box"\nposition = [0, 1]'), "bodies.b.position", "too few"),
    "body radius zero": Case(body('shape = "sphere"\nradius = 0\nposition = [0, 0, 1]'), "bodies.b.radius",
                             "greater than 0"),
    "body height nan": Case(body('shape = "cylinder"\nheight = nan\nposition = [0, 0, 1]'), "bodies.b.height",
                            "finite"),
    "body mass negative": Case(body('shape = "box"\nmass = -1\nposition = [0, 0, 1]'), "bodies.b.mass",
                               "greater than or equal to 0"),
    "body mass absurd": Case(body('shape = "box"\nmass = 1e12\nposition = [0, 0, 1]'), "bodies.b.mass",
                             "less than or equal to 1000000"),
    "body scale zero": Case(body('urdf = "cube.urdf"\nscale = 0\nposition = [0, 0, 1]'), "bodies.b.scale",
                            "greater than 0"),
    "body friction negative": Case(body('shape = "box"\nlateral_friction = -0.1\nposition = [0, 0, 1]'),
                                   "bodies.b.lateral_friction", "greater than or equal to 0"),
    "body damping above 1": Case(body('shape = "box"\nlinear_damping = 2\nposition = [0, 0, 1]'),
                                 "bodies.b.linear_damping", "less than or equal to 1"),
    "body rpy and quaternion": Case(body('shape = "box"\nposition = [0, 0, 1]\nrpy_deg = [0, 0, 90]\n'
                                         'quaternion = [0, 0, 0, 1]'), "bodies.b", "not both"),
    "body quaternion zeros": Case(body('shape = "box"\nposition = [0, 0, 1]\nquaternion = [0, 0, 0, 0]'),
                                  "bodies.b", "all zeros"),
    "body yaw range reversed": Case(body('shape = "box"\nposition = [0, 0, 1]\nyaw_deg_range = [45, -45]'),
                                    "bodies.b", "yaw_deg_range"),
    "body rgba too few": Case(body('shape = "box"\nposition = [0, 0, 1]\nrgba = [1, 0, 0]'), "bodies.b.rgba",
                              "too few"),
    "body mesh sphere": Case(body('shape = "sphere"\nmass = 0\ncollision = "mesh"\nposition = [0, 0, 1]'),
                             "bodies.b", "static boxes only"),
    "body count without region": Case(body('shape = "box"\ncount = 3\nposition = [0, 0, 1]'), "bodies.b",
                                      "needs a 'region'"),
    "body fixed_base string": Case(body('urdf = "cube.urdf"\nfixed_base = "true"\nposition = [0, 0, 1]'),
                                   "bodies.b.fixed_base", "valid boolean"),
    "body unknown key": Case(body('shape = "box"\ncolour = [1, 0, 0, 1]\nposition = [0, 0, 1]'),
                             "bodies.b.colour", "unknown key 'colour'"),
    "body names clash": Case(BOX + '[robots.box]\nurdf = "r2d2.urdf"\nposition = [2, 0, 1]\n', "robots.box",
                             "already used"),
    "robot unknown joint": Case(PANDA.replace("fixed_base = true", "fixed_base = true\n"
                                                                   "joint_positions = { panda_joint9 = 0.1 }"),
                                "robots.panda.joint_positions.panda_joint9", "panda_joint1"),
    "robot urdf empty": Case(PLANE + '[robots.r]\nurdf = ""\nposition = [0, 0, 0]\n', "robots.r.urdf",
                             "at least 1 character"),
    "bodies overlap": Case(PLANE + '[bodies.a]\nshape = "box"\nmass = 0\nposition = [1, 0, 0.5]\n'
                                   '[bodies.b]\nshape = "box"\nposition = [1, 0, 0.5]\n', "bodies.b", "overlapping"),
    # ----------------------------------------------------------------- [sensors.NAME]: common keys
    "sensor without type": Case(BOX + "[sensors.s]\nrate_hz = 10\n", "sensors.s", "missing 'type'"),
    "sensor unknown type": Case(sensor(BOX, "lidr"), "sensors.s.type", "did you mean 'lidar'?"),
    "sensor type not a string": Case(BOX + "[sensors.s]\ntype = 5\n", "sensors.s.type", "type name string"),
    "sensor rate zero": Case(sensor(BOX, "body_pose", "rate_hz = 0"), "sensors.s.rate_hz", "positive"),
    "sensor rate not dividing": Case(sensor(BOX, "body_pose", "rate_hz = 7"), "sensors.s.rate_hz",
                                     "does not divide the physics rate 240 Hz"),
    "sensor rate string": Case(sensor(BOX, "body_pose", 'rate_hz = "fast"'), "sensors.s.rate_hz", "Hz"),
    "sensors and actuators share names": Case(sensor(actuator(DRIVE, "diff_drive", name="scan"), "body_pose"),
                                              "actuators.scan", "already used"),
    # ----------------------------------------------------------------- each sensor type
    "body_pose unknown body": Case(sensor(BOX, "body_pose", 'bodies = ["bx"]'), "sensors.s.bodies[0]",
                                   "did you mean 'box'?"),
    "camera width too small": Case(sensor(BOX, "camera", "width = 4"), "sensors.s.width",
                                   "greater than or equal to 8"),
    "camera fov 180": Case(sensor(BOX, "camera", "fov = 180"), "sensors.s.fov", "less than 179"),
    "camera renderer": Case(sensor(BOX, "camera", 'renderer = "vulkan"'), "sensors.s.renderer", "pattern"),
    "camera eye nan": Case(sensor(BOX, "camera", "eye = [1, nan, 1]"), "sensors.s.eye.1", "finite"),
    "camera unknown mount": Case(sensor(BOX, "camera", 'mount_body = "drone"\nmount_link = "cam"'),
                                 "sensors.s.mount_body", "drone"),
    "colour_detector min_area zero": Case(sensor(sensor(BOX, "camera", name="camera"), "colour_detector",
                                                 "min_area = 0"), "sensors.s.min_area", "greater than or equal to 1"),
    "colour_detector hue missing": Case(sensor(sensor(BOX, "camera", name="camera"), "colour_detector",
                                               "colours = { red = { saturation = [0.5, 1] } }"),
                                        "sensors.s.colours.red.hue_deg", "Field required"),
    "colour_detector unknown camera": Case(sensor(BOX, "colour_detector", 'camera = "cam"'), "sensors.s.camera",
                                           "cam"),
    "contact body missing": Case(sensor(BOX, "contact", "min_force = 1"), "sensors.s.body", "Field required"),
    "contact unknown body": Case(sensor(BOX, "contact", 'body = "bx"'), "sensors.s.body", "did you mean 'box'?"),
    "contact min_force negative": Case(sensor(BOX, "contact", 'body = "box"\nmin_force = -1'),
                                       "sensors.s.min_force", "greater than or equal to 0"),
    "keyboard press at negative": Case(sensor(BOX, "keyboard", 'script = [{ at = -1, keys = ["up"] }]'),
                                       "sensors.s.script.0.at", "greater than or equal to 0"),
    "keyboard press without keys": Case(sensor(BOX, "keyboard", "script = [{ at = 1 }]"),
                                        "sensors.s.script.0.keys", "Field required"),
    "lidar no rays": Case(sensor(ROBOT, "lidar", "rays = 0"), "sensors.s.rays", "greater than or equal to 1"),
    "lidar absurd rays": Case(sensor(ROBOT, "lidar", "rays = 1000000"), "sensors.s.rays",
                              "less than or equal to 16384"),
    "lidar fov above 360": Case(sensor(ROBOT, "lidar", "fov_deg = 400"), "sensors.s.fov_deg",
                                "less than or equal to 360"),
    "lidar range_max inf": Case(sensor(ROBOT, "lidar", "range_max = inf"), "sensors.s.range_max", "finite"),
    "lidar unknown link": Case(sensor(ROBOT, "lidar", 'link = "laser"'), "sensors.s.link", "lidar_link"),
    # ----------------------------------------------------------------- each actuator type
    "diff_drive wheel radius zero": Case(actuator(ROBOT, "diff_drive", "wheel_radius = 0"),
                                         "actuators.a.wheel_radius", "greater than 0"),
    "diff_drive no wheels": Case(actuator(ROBOT, "diff_drive", "left_wheels = []"), "actuators.a.left_wheels",
                                 "at least 1 item"),
    "diff_drive unknown wheel": Case(actuator(ROBOT, "diff_drive", 'left_wheels = ["wheel_l"]'),
                                     "actuators.a.left_wheels[0]", "left_wheel"),
    "gripper body missing": Case(actuator(PANDA, "gripper", "force = 10"), "actuators.a.body", "Field required"),
    "gripper gear_erp above 1": Case(actuator(PANDA, "gripper", 'body = "panda"\ngear_erp = 2'),
                                     "actuators.a.gear_erp", "less than or equal to 1"),
    "gripper force bool": Case(actuator(PANDA, "gripper", 'body = "panda"\nforce = true'), "actuators.a.force",
                               "valid number"),
    "ik_arm ee_link missing": Case(actuator(PANDA, "ik_arm", 'body = "panda"'), "actuators.a.ee_link",
                                   "Field required"),
    "ik_arm iterations zero": Case(actuator(PANDA, "ik_arm", 'body = "panda"\nee_link = "panda_hand"\n'
                                                             "ik_iterations = 0"), "actuators.a.ik_iterations",
                                   "greater than or equal to 1"),
    "ik_arm unknown ee_link": Case(actuator(PANDA, "ik_arm", 'body = "panda"\nee_link = "tcp"'),
                                   "actuators.a.ee_link", "panda_hand"),
    "ik_arm speed nan": Case(actuator(PANDA, "ik_arm", 'body = "panda"\nee_link = "panda_hand"\nspeed = nan'),
                             "actuators.a.speed", "finite"),
    "joint_control mode": Case(actuator(PANDA, "joint_control", 'body = "panda"\nmode = "fast"'),
                               "actuators.a.mode", "'position'"),
    "joint_control sine frequency zero": Case(actuator(PANDA, "joint_control", 'body = "panda"\n'
                                                       "sine = { panda_joint1 = { amplitude = 1, frequency_hz = 0 } }"),
                                              "actuators.a.sine.panda_joint1.frequency_hz", "greater than 0"),
    "joint_control unknown joint": Case(actuator(PANDA, "joint_control", 'body = "panda"\n'
                                                                         'targets = { elbow = 1.0 }'),
                                        "actuators.a", "elbow"),
    "ee_delta body missing": Case(actuator(PANDA, "ee_delta", 'ee_link = "panda_grasptarget"'), "actuators.a.body",
                                  "Field required"),
    "pid no joints": Case(actuator(PANDA, "pid", 'body = "panda"\njoints = {}'), "actuators.a.joints",
                          "at least 1 item"),
    "pid unknown joint": Case(actuator(PANDA, "pid", 'body = "panda"\njoints = { elbow = { kp = 1.0 } }'),
                              "actuators.a.joints.elbow", "unknown joint 'elbow'"),
    "policy file missing": Case(behaviour(PANDA, "policy", 'policy = "no_such_policy.npz"'), "behaviour.policy",
                                "not found"),
    "sequence without steps": Case(behaviour(PANDA, "sequence"), "behaviour.steps", "a sequence needs steps"),
    "fallback without children": Case(behaviour(PANDA, "fallback"), "behaviour.children",
                                      "a fallback needs children"),
    "retry attempts zero": Case(behaviour(BOX, "retry", 'attempts = 0\nchild = { type = "record" }'),
                                "behaviour.attempts", "greater than or equal to 1"),
    "timeout without seconds": Case(behaviour(BOX, "timeout", 'child = { type = "record" }'), "behaviour.seconds",
                                    "Field required"),
    "parallel with one child": Case(behaviour(BOX, "parallel", 'children = [{ type = "record" }]'),
                                    "behaviour.children", "2 or more"),
    "guard unknown sensor": Case(behaviour(BOX, "guard", 'sensor = "touch"'), "behaviour.sensor",
                                 "not a contact or force_torque sensor"),
    "force_torque unknown joint": Case(sensor(PANDA, "force_torque", 'body = "panda"\njoint = "wrist"'),
                                       "sensors.s.joint", "panda_hand_joint"),
    "suction max_force zero": Case(actuator(PANDA, "suction", 'body = "panda"\nmax_force = 0'),
                                   "actuators.a.max_force", "greater than 0"),
    "suction unknown link": Case(actuator(PANDA, "suction", 'body = "panda"\nlink = "cup"'), "actuators.a.link",
                                 "panda_hand"),
    "collector max_mass zero": Case(actuator(ROBOT, "collector", "max_mass = 0"), "actuators.a.max_mass",
                                    "greater than 0"),
    # ----------------------------------------------------------------- [behaviour]
    "behaviour without type": Case(BOX + "[behaviour]\nrate_hz = 10\n", "behaviour", "missing 'type'"),
    "behaviour unknown type": Case(behaviour(BOX, "sorter"), "behaviour.type", "did you mean 'sort'?"),
    "behaviour unknown key": Case(behaviour(sensor(BOX, "body_pose", name="poses"), "drop_test", "durration = 5"),
                                  "behaviour.durration", "did you mean 'duration'?"),
    "drop_test duration negative": Case(behaviour(sensor(BOX, "body_pose", name="poses"), "drop_test",
                                                  "duration = -1"), "behaviour.duration", "greater than 0"),
    "drop_test missing sensor": Case(behaviour(BOX, "drop_test"), "behaviour.pose_sensor", "poses"),
    "go_to_goal goal missing": Case(behaviour(DRIVE, "go_to_goal"), "behaviour.goal", "Field required"),
    "go_to_goal goal nan": Case(behaviour(DRIVE, "go_to_goal", "goal = [nan, 1]"), "behaviour.goal.0", "finite"),
    "patrol no waypoints": Case(behaviour(DRIVE, "patrol", "waypoints = []"), "behaviour.waypoints",
                                "at least 1 item"),
    "patrol laps zero": Case(behaviour(DRIVE, "patrol", "waypoints = [[1, 1]]\nlaps = 0"), "behaviour.laps",
                             "greater than or equal to 1"),
    "pick_place attempts absurd": Case(behaviour(ARM, "pick_place", "max_attempts = 100"),
                                       "behaviour.max_attempts", "less than or equal to 20"),
    "pick_place place out of reach": Case(behaviour(ARM + '[bodies.cube]\nshape = "box"\nsize = [0.05, 0.05, 0.05]'
                                                          '\nposition = [0.5, 0, 0.025]\n'
                                                          '[sensors.poses]\ntype = "body_pose"\n',
                                                    "pick_place", 'pose_sensor = "poses"\nobject = "cube"\n'
                                                                  "place_position = [3.0, 0, 0.025]"),
                                          "behaviour.place_position", "reach"),
    "patrol_collect attempts zero": Case(behaviour(actuator(DRIVE, "collector", name="collector"),
                                                   "patrol_collect", "waypoints = [[1, 1]]\nmax_attempts = 0"),
                                         "behaviour.max_attempts", "greater than or equal to 1"),
    "patrol_collect discovery nan": Case(behaviour(actuator(DRIVE, "collector", name="collector"),
                                                   "patrol_collect", "waypoints = [[1, 1]]\n"
                                                                     "discovery = { object_radius = nan }"),
                                         "behaviour.discovery.object_radius", "finite"),
    "record duration inf": Case(behaviour(BOX, "record", "duration = inf"), "behaviour.duration", "finite"),
    "record unknown component": Case(behaviour(BOX, "record", 'components = ["imu"]'), "behaviour.components[0]",
                                     "imu"),
    "sort bin floor negative": Case(behaviour(BOX, "sort", 'bins = { red = { body = "box", floor = -1 } }'),
                                    "behaviour.bins.red.floor", "greater than or equal to 0"),
    "joint_teleop too many joints": Case(behaviour(BOX, "joint_teleop", f"joints = {[f'j{i}' for i in range(10)]}"
                                                   .replace("'", '"')), "behaviour.joints", "at most 9 items"),
    "drive_teleop turn zero": Case(behaviour(BOX, "drive_teleop", "turn = 0"), "behaviour.turn", "greater than 0"),
    # ----------------------------------------------------------------- [report]
    "report student number": Case(BOX + "[report]\nstudent = 42\n", "report.student", "valid string"),
    "report keep_local string": Case(BOX + '[report]\nkeep_local = "no"\n', "report.keep_local", "valid boolean"),
    "report unknown reporter": Case(BOX + "[report.smtp]\nto = 'x@example.org'\n", "report.smtp",
                                    "unknown reporter type 'smtp'"),
    "report unknown key": Case(BOX + '[report]\nstudnet = "kim"\n', "report.studnet", "did you mean 'student'?"),
    "http url missing": Case(BOX + "[report.http]\nretries = 1\n", "report.http.url", "missing"),
    "http url no scheme": Case(BOX + '[report.http]\nurl = "course.example.org/api/"\n', "report.http.url",
                               "http:// or https://"),
    "http url no host": Case(BOX + '[report.http]\nurl = "http:///api/"\n', "report.http.url", "no host"),
    "http url port out of range": Case(BOX + '[report.http]\nurl = "http://course.example.org:99999/api/"\n',
                                       "report.http.url", "Port out of range"),
    "http url space": Case(BOX + '[report.http]\nurl = "http://course.example.org/my api/"\n', "report.http.url",
                           "spaces"),
    "http url unclosed ipv6": Case(BOX + '[report.http]\nurl = "http://[::1/api/"\n', "report.http.url",
                                   "Invalid IPv6 URL"),
    "http token in config": Case(BOX + '[report.http]\nurl = "http://h/api/"\ntoken = "s3cret"\n', "report.http",
                                 "never put a token in the config"),
    "http retries absurd": Case(BOX + '[report.http]\nurl = "http://h/api/"\nretries = 1000\n',
                                "report.http.retries", "less than or equal to 20"),
    "http verify missing bundle": Case(BOX + '[report.http]\nurl = "https://h/api/"\nverify = "no"\n',
                                       "report.http.verify", "does not exist"),
    "http timeout nan": Case(BOX + '[report.http]\nurl = "http://h/api/"\nread_timeout = nan\n',
                             "report.http.read_timeout", "finite"),
    "local dir empty": Case(BOX + '[report.local]\ndir = ""\n', "report.local.dir", "at least 1 character"),
    # ----------------------------------------------------------------- [[events]]
    "events not an array": Case("events = 5\n" + BOX, "events", "array of tables"),
    "event unknown body": Case(event('at = 1\ntype = "remove"\nbody = "bx"'), "events[0].body",
                               "did you mean 'box'?"),
    "event unknown type": Case(event('at = 1\ntype = "explode"\nbody = "box"'), "events[0].type", "'force'"),
    "event at negative": Case(event('at = -1\ntype = "remove"\nbody = "box"'), "events[0].at",
                              "greater than or equal to 0"),
    "event force missing": Case(event('at = 1\ntype = "force"\nbody = "box"'), "events[0]", "needs 'force'"),
    "event force inf": Case(event('at = 1\ntype = "force"\nbody = "box"\nforce = [0, 0, inf]'),
                            "events[0].force.2", "finite"),
    "event set_pose without position": Case(event('at = 1\ntype = "set_pose"\nbody = "box"'), "events[0]",
                                            "needs 'position'"),
}
