"""Inputs the engine property files generate: the engines, and turns to pose bodies at."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

ENGINES = ["pybullet", "mujoco"]

axes = st.tuples(*(st.floats(-1.0, 1.0),) * 3).filter(lambda a: np.linalg.norm(a) > 0.3)
turns = st.floats(0.3, 2.8)  # rad: never the identity, never a half turn (its own inverse)


def tool_urdf(joint_xyz: tuple, joint_rpy: tuple, com: tuple, com_rpy: tuple, mass: float,
              base_collision: bool = False) -> str:
    """A base holding a ``tool`` link by a fixed ``wrist`` joint at ``joint_xyz``/``joint_rpy``, the tool's centre of
    mass at ``com``/``com_rpy`` in its link frame, and a ``spare`` link on a revolute joint (so the robot has a
    movable joint besides the wrist)."""
    j = " ".join
    collision = '\n    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>' if base_collision else ""
    return f"""<?xml version="1.0"?>
<robot name="probe">
  <link name="base">
    <inertial><origin xyz="0 0 0"/><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>{collision}
  </link>
  <link name="tool">
    <inertial><origin xyz="{j(map(str, com))}" rpy="{j(map(str, com_rpy))}"/><mass value="{mass}"/>
      <inertia ixx="0.004" iyy="0.006" izz="0.008" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="spare">
    <inertial><origin xyz="0 0 0"/><mass value="0.1"/>
      <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="spin" type="revolute">
    <parent link="base"/><child link="spare"/><origin xyz="0 0 -0.1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/>
  </joint>
  <joint name="wrist" type="fixed">
    <parent link="base"/><child link="tool"/>
    <origin xyz="{j(map(str, joint_xyz))}" rpy="{j(map(str, joint_rpy))}"/>
  </joint>
</robot>
"""
