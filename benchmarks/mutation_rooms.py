"""Mutation testing room by room with mutmut: every mutant mutmut makes in a room, against the tests that cover it.

mutmut (https://github.com/boxed/mutmut, ``pip install mutmut``) mutates every function of the files it is given
(operators, constants, comparisons, arguments, return values ...) and runs, for each mutant, only the tests that
call the mutated function (it records which ones in a first, clean run). A mutant that no test notices *survived*;
the score of a room is killed / (killed + survived + timeout-free others that ran).

Why a copy: robokit's editable install maps ``robokit_plugins`` / ``robokit_behaviours`` to ``plugins/`` /
``behaviours/``, a layout mutmut cannot mutate in place. For each room this script exports the committed tree
(``git archive HEAD``: a consistent snapshot, never your uncommitted edits) into a folder of its own under the
temporary directory, lays the two packages out under their import names, writes the room's ``[tool.mutmut]`` table
into the copy's ``pyproject.toml`` (the checkout's ``[tool.mutmut]`` table plus the room's files and tests) and
runs ``python -m mutmut run`` there. Mutants run in the test process; subprocesses (``robokit`` CLI runs, sweep
workers) import the copy's unmutated code, so a mutant only a subprocess would show survives (a test that calls the
code in-process kills it). The checkout is never written to.

    python benchmarks/mutation_rooms.py --list                     # the rooms, their files and tests
    python benchmarks/mutation_rooms.py contact config_schema      # run two rooms, one child process each
    python benchmarks/mutation_rooms.py contact --children 2 --survivors   # and list every survivor
    python benchmarks/mutation_rooms.py contact --keep                     # keep the copy (then: mutmut show NAME)
    python benchmarks/mutation_rooms.py contact --mutants 'robokit_plugins.contact.*read*'   # re-check some
    python benchmarks/mutation_rooms.py pid --mutants 'robokit_plugins.pid.xǁPidǁupdate__mutmut_7'  # one survivor

``--mutants`` takes the names ``--survivors`` prints (a pasted ``survived:`` prefix, blanks and look-alikes of the
``ǁ`` in a method's name are mended) under any locale; a run in which no named mutant was checked exits 1 saying so.

Afterwards ``cd <copy> && mutmut show <mutant>`` prints a survivor's diff. The rooms below cover the whole package;
a run of every room takes hours on two cores: run the rooms you changed.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parents[1]

# room -> (files to mutate, as import paths in the copy; test files that cover them)
ROOMS: dict[str, tuple[list[str], list[str]]] = {
    "contact": (["robokit_plugins/contact.py"],
                ["tests/test_prop_contact.py", "tests/test_arm_contact_joints.py", "tests/test_arm_config_errors.py",
                 "tests/test_composition_monitors.py", "tests/test_engine_mujoco_devices.py",
                 "tests/test_mobile_patrol.py", "tests/test_conformance.py"]),
    "force_torque": (["robokit_plugins/force_torque.py"], ["tests/test_arm_contact_joints.py",
                                                           "tests/test_prop_plugin_force_torque.py"]),
    "gripper": (["robokit_plugins/gripper.py"], ["tests/test_arm_gripper.py", "tests/test_gripper_watch.py",
                                                 "tests/test_prop_plugin_gripper.py"]),
    "ik_arm": (["robokit_plugins/ik_arm.py", "robokit_plugins/kinematics.py"],
               ["tests/test_arm_ik.py", "tests/test_pins_arm.py", "tests/test_prop_frames.py",
                "tests/test_prop_plugin_ik_arm.py", "tests/test_prop_plugin_ik_follow.py"]),
    "detector": (["robokit_plugins/colour_detector.py"],
                 ["tests/test_vision_detector.py", "tests/test_pins_vision.py", "tests/test_prop_plugin_detector.py"]),
    "lidar": (["robokit_plugins/lidar.py", "robokit_plugins/raycast.py"],
              ["tests/test_mobile_lidar.py", "tests/test_mobile_raycast.py", "tests/test_prop_frames.py",
               "tests/test_prop_plugin_lidar.py", "tests/test_prop_plugin_lidar_heading.py"]),
    "diff_drive": (["robokit_plugins/diff_drive.py"],
                   ["tests/test_mobile_drive.py", "tests/test_pins_drive.py", "tests/test_prop_drive.py",
                    "tests/test_prop_stop_actuators.py", "tests/test_prop_plugin_diff_drive.py"]),
    "suction": (["robokit_plugins/suction.py"], ["tests/test_arms_grippers.py", "tests/test_pins_arm.py",
                                                 "tests/test_prop_plugin_suction.py"]),
    "camera": (["robokit_plugins/camera.py"],
               ["tests/test_vision_camera.py", "tests/test_vision_config.py", "tests/test_pins_vision.py",
                "tests/test_prop_frames.py", "tests/test_prop_plugin_camera.py"]),
    "collector": (["robokit_plugins/collector.py"],
                  ["tests/test_pins_mobile.py", "tests/test_mobile_patrol.py", "tests/test_prop_plugin_collector.py"]),
    "pid": (["robokit_plugins/pid.py"],
            ["tests/test_pid.py", "tests/test_pins_pid.py", "tests/test_prop_plugin_pid.py"]),
    "config_schema": (["robokit/config/schema.py", "robokit/config/randomize.py"],
                      ["tests/test_core_config_errors.py", "tests/test_pins_config.py", "tests/test_randomize.py",
                       "tests/test_prop_config_errors.py"]),
    "config": (["robokit/config/*"],
               ["tests/test_core_config_errors.py", "tests/test_pins_config.py", "tests/test_sections.py",
                "tests/test_config_reference.py", "tests/test_randomize.py", "tests/test_prop_config_errors.py"]),
    # the config room without schema.py (whose `_harden` and `_field` run at import, when a section class is made,
    # before mutmut switches a mutant on: out of its reach; the config properties pin what they build)
    "config_sections": (["robokit/config/sections.py", "robokit/config/randomize.py", "robokit/config/__init__.py"],
                        ["tests/test_core_config_errors.py", "tests/test_pins_config.py", "tests/test_sections.py",
                         "tests/test_config_reference.py", "tests/test_randomize.py",
                         "tests/test_prop_config_errors.py", "tests/test_composition_composites.py",
                         "tests/test_pins_compose.py", "tests/test_composition_monitors.py",
                         "tests/test_prop_config_behaviours.py", "tests/test_prop_config_reporters.py"]),
    "composites": (["robokit/core/composites.py", "robokit/core/composite_base.py"],
                   ["tests/test_composition_composites.py", "tests/test_prop_composites.py",
                    "tests/test_pins_compose.py"]),
    "core": (["robokit/core/*"], ["tests/test_core_scheduler.py", "tests/test_core_world.py", "tests/test_pins_core.py",
                                  "tests/test_composition_composites.py", "tests/test_prop_composites.py",
                                  "tests/test_prop_core_scheduler.py"]),
    # the state machines behaviours are written in, and the monitors beside a task (robokit/core/compose.py)
    "core_fsm": (["robokit/fsm.py", "robokit/core/compose.py"],
                 ["tests/test_prop_core_fsm.py", "tests/test_pins_core.py", "tests/test_prop_monitors.py",
                  "tests/test_prop_core_monitors.py",
                  "tests/test_composition_monitors.py", "tests/test_compose.py"]),
    # the run's edges: its result, randomisation, preflight and reading checks, wall time, the runner
    "core_misc": (["robokit/core/result.py", "robokit/core/randomize.py", "robokit/core/preflight.py",
                   "robokit/core/reading_check.py", "robokit/core/walltime.py", "robokit/runner.py"],
                  ["tests/test_prop_sample3_core.py", "tests/test_lost_end_of_run.py", "tests/test_plugins_faults.py",
                   "tests/test_report_result_first.py", "tests/test_prop_core_monitors.py",
                   "tests/test_prop_core_scheduler.py", "tests/test_house.py", "tests/test_startup.py",
                   "tests/test_prop_core_randomize.py", "tests/test_prop_core_result.py",
                   "tests/test_prop_core_readings.py", "tests/test_prop_core_preflight.py", "tests/test_randomize.py",
                   "tests/test_preflight.py", "tests/test_composition_refusals.py"]),
    # reporting: the reporters' order, the outbox, submissions, artifact uploads, the HTTP reporter plugin
    "report": (["robokit/report/*", "robokit_plugins/http_report.py"],
               ["tests/test_pins_report.py", "tests/test_report_outbox.py", "tests/test_report_http.py",
                "tests/test_report_identity.py", "tests/test_report_result_first.py", "tests/test_report_fault.py",
                "tests/test_hardening_outbox.py", "tests/test_prop_config_reporters.py", "tests/test_promises.py",
                "tests/test_prop_sample3_report.py", "tests/test_prop_report_outbox.py",
                "tests/test_prop_report_cli.py", "tests/test_prop_report_submit.py", "tests/test_prop_report_http.py",
                "tests/test_prop_report_artifacts.py", "tests/test_prop_report_payload.py"]),
    "scheduler": (["robokit/core/scheduler.py"], ["tests/test_core_scheduler.py", "tests/test_pins_core.py",
                                                  "tests/test_prop_core_scheduler.py"]),
    "summary": (["robokit/sweep/summary.py"],
                ["tests/test_pins_sweep.py", "tests/test_lost_sweep_summary.py", "tests/test_prop_summary.py"]),
    "sweep": (["robokit/sweep/*"], ["tests/test_sweep.py", "tests/test_pins_sweep.py", "tests/test_prop_summary.py"]),
    "record": (["robokit/record/*"],
               ["tests/test_record.py", "tests/test_pins_record.py", "tests/test_prop_summary.py",
                "tests/test_prop_export.py", "tests/test_prop_record_runs.py"]),
    "record_export": (["robokit/record/export.py"],
                      ["tests/test_prop_export.py", "tests/test_export_viewers.py", "tests/test_export_portable.py",
                       "tests/test_prop_summary.py"]),
    "record_results": (["robokit/record/results.py", "robokit/record/format.py"],
                       ["tests/test_prop_record_results.py", "tests/test_prop_record_runs.py", "tests/test_record.py",
                        "tests/test_pins_record.py", "tests/test_results_where.py", "tests/test_prop_summary.py"]),
    "results_props": (["robokit/record/results.py", "robokit/record/format.py"],
                      ["tests/test_prop_record_results.py", "tests/test_prop_record_runs.py"]),
    "export_props": (["robokit/record/export.py"], ["tests/test_prop_export.py"]),
    "recorder": (["robokit/record/recorder.py"],
                 ["tests/test_prop_export.py", "tests/test_record.py", "tests/test_record_full_disk.py",
                  "tests/test_prop_record_results.py", "tests/test_prop_replay_state.py",
                  "tests/test_prop_record_samples.py"]),
    "sweep_engine": (["robokit/sweep/engine.py", "robokit/sweep/progress.py"],
                     ["tests/test_prop_sweep_resume.py", "tests/test_prop_sweep_spec.py", "tests/test_pins_sweep.py",
                      "tests/test_lost_sweep_summary.py", "tests/test_prop_sweep_progress.py"]),
    "replay": (["robokit/record/replay.py", "robokit/record/scene.py"],
               ["tests/test_prop_replay_state.py", "tests/test_replay_model.py", "tests/test_prop_export.py",
                "tests/test_prop_replay_frames.py", "tests/test_prop_record_runs.py"]),
    "server": (["robokit/server/*"], ["tests/test_server_pages.py", "tests/test_server_rules.py",
                                      "tests/test_prop_routes.py", "tests/test_pins_server.py",
                                      "tests/test_prop_server_timeline.py", "tests/test_prop_server_csv.py",
                                      "tests/test_prop_server_grades.py"]),
    # the server room by module: grades and the figures behind them; the queue; who may see and do what; exports
    "server_grading": (["robokit/server/grades.py", "robokit/server/ranking.py", "robokit/server/course_pages.py",
                        "robokit/server/evaluation.py"],
                       ["tests/test_prop_server_grades.py", "tests/test_prop_course_grades.py",
                        "tests/test_course_grades.py", "tests/test_course_dashboard.py", "tests/test_server_rules.py",
                        "tests/test_course_evaluation.py", "tests/test_pins_server.py",
                        "tests/test_prop_server_leaderboard.py", "tests/test_prop_course_dashboard.py",
                        "tests/test_prop_course_student_view.py", "tests/test_prop_course_queue.py",
                        "tests/test_course_assignments.py", "tests/test_course_student_plugins.py",
                        "tests/test_prop_server_ranking.py", "tests/test_prop_routes.py"]),
    "server_queue": (["robokit/server/fair_queue.py", "robokit/server/lease.py"],
                     ["tests/test_course_fairness.py", "tests/test_course_grading_lease.py",
                      "tests/test_prop_course_lease.py", "tests/test_prop_course_queue.py",
                      "tests/test_course_assignments.py"]),
    "server_access": (["robokit/server/pages.py", "robokit/server/course_api.py", "robokit/server/api.py",
                       "robokit/server/tokens.py"],
                      ["tests/test_prop_routes.py", "tests/test_prop_routes_roles.py", "tests/test_server_pages.py",
                       "tests/test_server_api.py", "tests/test_course_student_view.py",
                       "tests/test_course_assignments.py", "tests/test_prop_server_csv.py", "tests/test_pins_server.py",
                       "tests/test_prop_server_tokens.py", "tests/test_prop_course_deadlines.py",
                       "tests/test_prop_course_allowed_keys.py", "tests/test_prop_course_student_view.py",
                       "tests/test_prop_server_leaderboard.py", "tests/test_prop_server_timeline.py",
                       "tests/test_course_dashboard.py", "tests/test_prop_server_ranges.py"]),
    # the server's smaller modules: payloads, artifacts and uploads, submissions, assignments, middleware
    "server_misc": (["robokit/server/payload.py", "robokit/server/artifacts.py", "robokit/server/plugin_upload.py",
                     "robokit/server/submitted.py", "robokit/server/assignments.py", "robokit/server/middleware.py",
                     "robokit/server/private.py", "robokit/server/replay_page.py"],
                    ["tests/test_pins_server.py", "tests/test_server_api.py", "tests/test_server_hardening.py",
                     "tests/test_course_paths.py", "tests/test_prop_course_weeks_grades.py",
                     "tests/test_course_evaluation.py", "tests/test_course_fairness.py",
                     "tests/test_course_student_plugins.py", "tests/test_server_replay.py",
                     "tests/test_server_run_media.py", "tests/test_prop_routes_roles.py",
                     "tests/test_prop_sample3_server.py"]),
    # (not test_engine_seam.py: it reads the interface's method docstrings, which mutmut's trampolines replace)
    "engines": (["robokit/engines/*"], ["tests/test_engine_contract.py", "tests/test_prop_frames.py",
                                        "tests/test_prop_reset.py", "tests/test_engine_mujoco.py",
                                        "tests/test_engine_mujoco_contacts.py", "tests/test_engine_mujoco_devices.py",
                                        "tests/test_engine_mujoco_grip.py", "tests/test_mobile_raycast.py",
                                        "tests/test_prop_plugin_force_torque.py", "tests/test_vision_camera.py",
                                        "tests/test_prop_engines_rays.py", "tests/test_prop_engines_attach.py",
                                        "tests/test_prop_engines_wrench.py", "tests/test_prop_engines_render.py"]),
    "gym": (["robokit/gym/*"], ["tests/test_gym.py", "tests/test_pins_gym.py", "tests/test_prop_reset.py",
                                "tests/test_gym_goal.py", "tests/test_gym_engines.py", "tests/test_gym_images.py",
                                "tests/test_gym_policy.py", "tests/test_prop_gym_api.py"]),
    # the three behaviours the course ships and its users run most, against the tests that pin them
    "behaviours": (["robokit_behaviours/sort.py", "robokit_behaviours/pick_place.py", "robokit_behaviours/patrol.py"],
                   ["tests/test_pins_sort.py", "tests/test_pins_pick_place.py", "tests/test_pins_patrol.py",
                    "tests/test_prop_behaviours.py", "tests/test_prop_sample_behaviours.py",
                    "tests/test_prop_behaviours_pick_place_retries.py", "tests/test_prop_behaviours_sort_records.py",
                    "tests/test_prop_behaviours_patrol_legs.py", "tests/test_prop_behaviours_goals.py",
                    "tests/test_prop_behaviours_preflight.py"]),
}

# mutmut's exit-code statuses, grouped: what counts as caught, what as missed
CAUGHT = {"killed", "timeout", "caught by type check", "segfault"}
MISSED = {"survived"}


def export_tree(dest: Path) -> None:
    """The committed tree into ``dest``, with the plugin and behaviour packages under their import names."""
    dest.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", "HEAD"], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive, check=True)
    shutil.copytree(dest / "plugins", dest / "robokit_plugins")
    shutil.copytree(dest / "behaviours", dest / "robokit_behaviours")
    shutil.copytree(dest / "configs" / "gym", dest / "robokit_configs" / "gym")


def toml_value(value: object) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    return json.dumps(value)


def room_table(base: dict[str, object], files: list[str], tests: list[str]) -> str:
    table = {**base, "only_mutate": files, "pytest_add_cli_args_test_selection": tests}
    return "[tool.mutmut]\n" + "".join(f"{k} = {toml_value(v)}\n" for k, v in table.items())


def without_marker_filter(args: list[str]) -> list[str]:
    """pytest arguments whose ``-m EXPR`` selects slow tests too (pytest's last ``-m`` wins over addopts')."""
    out: list[str] = ["-m", "slow or not slow"]
    skip = False
    for a in args:
        if skip:
            skip = False
        elif a == "-m":
            skip = True
        elif not a.startswith("-m="):
            out.append(a)
    return out


def write_config(copy: Path, files: list[str], tests: list[str], slow: bool = False) -> None:
    """The copy's pyproject.toml with its ``[tool.mutmut]`` table replaced by the room's."""
    path = copy / "pyproject.toml"
    text = path.read_text(encoding="utf-8")
    mine = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))  # the checkout's settings
    base = dict(mine.get("tool", {}).get("mutmut", {}))
    if slow:
        base["pytest_add_cli_args"] = without_marker_filter(list(base.get("pytest_add_cli_args", [])))
    without = re.sub(r"(?ms)^\[tool\.mutmut\]\n.*?(?=^\[|\Z)", "", text)
    path.write_text(without.rstrip() + "\n\n" + room_table(base, files, tests), encoding="utf-8")


def statuses(copy: Path) -> dict[str, str]:
    """mutant name -> status, read from mutmut's own ``results --all`` listing."""
    out = subprocess.run([sys.executable, "-m", "mutmut", "results", "--all", "true"], cwd=copy, encoding="utf-8",
                         capture_output=True, env={**os.environ, "PYTHONUTF8": "1"}).stdout
    found = {}
    for line in out.splitlines():
        name, sep, status = line.strip().rpartition(": ")
        if sep:
            found[name] = status
    return found


# mutmut names a method's mutants ``module.xǁClassǁmethod__mutmut_N`` with U+01C1 (LATIN LETTER LATERAL CLICK). Under
# a C/POSIX locale with UTF-8 mode off (PYTHONUTF8=0) Python reads that letter from the command line as two surrogate
# escapes, and a terminal, a font or a retyped name turns it into a look-alike; either way mutmut matched nothing,
# said so only by an AssertionError at the end of its log, and every mutant stayed "not checked"
LOOKALIKES = re.compile(r"\|\||[|\u2016\u2225\u00a6\u01c0]")


def mutant_pattern(name: str) -> str:
    """A name or glob as mutmut knows it: a survivor line's prefix and blanks dropped, look-alikes of ``ǁ`` mended."""
    name = name.encode("utf-8", "surrogateescape").decode("utf-8", "replace").strip()
    name = name.removeprefix("survived:").strip()
    return LOOKALIKES.sub("\u01c1", name)


def run_room(name: str, children: int, keep: bool, timeout: float, only: list[str],
             slow: bool = False) -> dict[str, object]:
    files, tests = ROOMS[name]
    work = Path(tempfile.mkdtemp(prefix=f"robokit-mutmut-{name}-"))
    copy = work / "tree"
    export_tree(copy)
    missing = [t for t in tests if not (copy / t).is_file()]
    tests = [t for t in tests if t not in missing]
    write_config(copy, files, tests, slow)
    # subprocesses (robokit CLI runs, sweep workers) import the copy's own, unmutated code: mutmut's trampolines
    # read their settings from the working directory, which a subprocess changes
    env = {**os.environ, "PYTHONPATH": str(copy), "PYTHONUTF8": "1",
           "ROBOKIT_CACHE_DIR": str(work / "cache"), "MPLBACKEND": "Agg"}
    start = time.monotonic()
    cpu = os.times()
    log = work / "mutmut.log"
    # a session of its own, so that --timeout stops mutmut's fork server and its workers too, not only mutmut
    with log.open("w", encoding="utf-8") as out:
        # the names as UTF-8 bytes, which the child (UTF-8 mode) reads back whatever the locale
        names = [n.encode("utf-8") for n in only]
        proc = subprocess.Popen([sys.executable, "-m", "mutmut", "run", "--max-children", str(children), *names],
                                cwd=copy, env=env, text=True, stdout=out, stderr=subprocess.STDOUT,
                                start_new_session=True)
        try:
            proc.wait(timeout=timeout)
            text = log.read_text(encoding="utf-8", errors="replace")
            tail = [x for x in text.splitlines() if x.startswith(("E ", "FAILED"))][:3]
            tail += text.strip().splitlines()[-2:]
            if "nothing matches" in text:
                tail = [f"no mutant of the room is named {' or '.join(only)} (`--keep`, then `mutmut results --all "
                        "true` in the copy lists their names)"]
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            tail = [f"stopped after {timeout:.0f} s (--timeout): the statuses so far"]
    wall = time.monotonic() - start
    done = os.times()
    found = statuses(copy)
    caught = sum(s in CAUGHT for s in found.values())
    missed = [m for m, s in found.items() if s in MISSED]
    other = {m: s for m, s in found.items() if s not in CAUGHT | MISSED}
    if not keep:
        shutil.rmtree(work, ignore_errors=True)
    return {"room": name, "files": files, "tests": tests, "missing_tests": missing, "mutants": len(found),
            "caught": caught, "survived": missed, "other": other,
            "score": caught / (caught + len(missed)) if caught + len(missed) else None,
            "wall_s": round(wall, 1), "cpu_s": round(done.children_user + done.children_system
                                                     - cpu.children_user - cpu.children_system, 1),
            "copy": str(copy) if keep else None, "tail": tail}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("rooms", nargs="*", help=f"rooms to run ({', '.join(ROOMS)})")
    parser.add_argument("--list", action="store_true", help="list the rooms, their files and tests; run nothing")
    parser.add_argument("--children", type=int, default=1, help="mutmut's worker processes (default 1)")
    parser.add_argument("--timeout", type=float, default=3600.0, help="seconds per room before it is stopped")
    parser.add_argument("--survivors", action="store_true", help="print every surviving mutant's name")
    parser.add_argument("--keep", action="store_true", help="keep each room's copy (to `mutmut show` survivors)")
    parser.add_argument("--slow", action="store_true",
                        help="the room's slow-tier tests count too (the settings and addopts run `-m 'not slow'`)")
    parser.add_argument("--json", type=Path, help="also write the results as JSON here")
    parser.add_argument("--mutants", nargs="+", default=[], metavar="NAME",
                        help="run only these mutants (names or globs, as --survivors prints them): re-check survivors")
    args = parser.parse_args(argv)
    sys.stdout.reconfigure(encoding="utf-8")  # type: ignore[union-attr]  # mutant names, whatever the locale
    if args.list:
        for name, (files, tests) in ROOMS.items():
            print(f"{name:14} {' '.join(files)}\n{'':14} tests: {' '.join(tests)}")
        return 0
    unknown = [r for r in args.rooms if r not in ROOMS]
    if unknown or not args.rooms:
        parser.error(f"unknown room(s) {unknown}; choose from: {', '.join(ROOMS)}" if unknown else
                     "name at least one room (--list shows them)")
    results = []
    failed = False
    print(f"{'room':14} {'mutants':>7} {'caught':>6} {'survived':>8} {'other':>5} {'score':>6} {'wall s':>7} "
          f"{'cpu s':>7}")
    for room in args.rooms:
        r = run_room(room, args.children, args.keep, args.timeout, [mutant_pattern(m) for m in args.mutants],
                     args.slow)
        results.append(r)
        score = "-" if r["score"] is None else f"{100 * r['score']:.1f}%"  # type: ignore[operator]
        print(f"{room:14} {r['mutants']:>7} {r['caught']:>6} {len(r['survived']):>8} {len(r['other']):>5} "  # type: ignore[arg-type]
              f"{score:>6} {r['wall_s']:>7} {r['cpu_s']:>7}", flush=True)
        if r["missing_tests"]:
            print(f"  (tests not in the tree, left out: {' '.join(r['missing_tests'])})")  # type: ignore[arg-type]
        if not r["mutants"]:
            print("  mutmut made no mutants: " + " | ".join(r["tail"]))  # type: ignore[arg-type]
        elif args.mutants and not r["caught"] and not r["survived"]:
            print("  no mutant checked: " + " | ".join(r["tail"]), file=sys.stderr)  # type: ignore[arg-type]
            failed = True
        if args.survivors:
            for m in r["survived"]:  # type: ignore[attr-defined]
                print(f"  survived: {m}")
        if r["copy"]:
            print(f"  copy kept: {r['copy']}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2), encoding="utf-8")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
