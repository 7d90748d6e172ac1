"""Robot design tools: xacro expansion (:mod:`~robokit.robot.expand`), the checker (:mod:`~robokit.robot.check`,
:mod:`~robokit.robot.physical`), scaffolds (:mod:`~robokit.robot.scaffold`) and drawings (:mod:`~robokit.robot.show`).

``robokit robot check | new | show`` (:mod:`~robokit.robot.cli`). Nothing here is imported at robokit's start-up.
"""
