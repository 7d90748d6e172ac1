"""The fixed prose of the config reference page (:mod:`robokit.checks.config_reference`), in English and Korean.

Keys and the schemas' own descriptions are not here: they come from the code, in English, on both pages.
"""

from __future__ import annotations

TEXT: dict[str, dict[str, str]] = {
    "en": {
        "lang": "en",
        "title": "# Config reference",
        "other": "[한국어](config-reference.ko.md) · [README](../README.md)",
        "generated": ("Generated from the schemas by `python -m robokit.checks.config_reference`; a test fails when "
                      "this page and the schemas differ, so what you read here is what `robokit validate` checks."),
        "rules_title": "## Rules for every key",
        "rules": """\
- **Units.** Lengths and positions in metres, angles in degrees where the key ends in `_deg` (else radians, as
  the description says), times in seconds of **sim time**, rates in Hz of sim time, forces in newtons, masses in
  kilograms. Positions are in the world frame (x forward, y left, z up) unless the description names another.
- **Colours** are `[red, green, blue, alpha]` floats from 0 to 1 (`[0.9, 0.1, 0.1, 1]`); 0-255 values are refused
  with the 0-1 equivalent.
- **Numbers.** Every float is finite and within ±1e9 unless its bounds say otherwise; an integer is accepted where
  a float is expected, `true` is not a number and `1` is not a boolean. A list has exactly the length shown.
- **Unknown keys are errors** (with a "did you mean"); so is a missing required key. Every error is one line
  naming the file and the key path: `robokit validate CONFIG` checks a config without running it.
- **Body names.** `[bodies.red]` with `count = 1` (the default) is one body named `red`; with `count = N` the
  copies are `red_0`, `red_1` … `red_{N-1}` (scattered in the body's `region`). An SDF or MJCF file holding
  several models gives `NAME`, `NAME_1`, `NAME_2` … Sensors, actuators and behaviours name bodies, joints and
  links by these names; an unknown name fails with the list of valid ones.
- **Model files** (`urdf`, `sdf`, `mjcf`) are paths relative to the config file, robokit's bundled robots, or
  `pybullet_data` names (`"franka_panda/panda.urdf"`). The key must match the file: `urdf = "x.sdf"` is an error
  naming `sdf =`.
- **Plugin sections** (`[sensors.NAME]`, `[actuators.NAME]`, `[behaviour]`, `[monitors.NAME]`,
  `[report.NAME]`, `[env.task]`) take `type` (a registered type name; `DIST:type` when two distributions register
  the same name) and, except `[env.task]` and reporters, `rate_hz`: how often it runs, in Hz of sim time (default:
  every physics tick); it must divide the physics rate (`1 / world.time_step`, 240 Hz by default). The other keys
  are the type's own, listed below; `robokit plugins` lists every installed type.""",
        "core": "## Core sections",
        "components": "## Sections that name a plugin type",
        "kinds": ("`[sensors.NAME]` takes a sensor type, `[actuators.NAME]` an actuator type, `[behaviour]` and "
                  "`[monitors.NAME]` a behaviour type, `[report.NAME]` a reporter type (`local` is always on "
                  "unless `[report] keep_local = false`), `[env.task]` a task type. Common keys:"),
        "common": "| key | type | default | bounds | meaning |\n|---|---|---|---|---|\n"
                  "| `type` | string | (required) | | the type's name (`dist:type` when names clash) |\n"
                  "| `rate_hz` | float (optional) | every tick | > 0, divides the physics rate | Hz of sim time |\n"
                  "| `action` | string | \"observe\" | observe, abort, recover | `[monitors.NAME]` only: what its "
                  "ending failed or aborted does to the task |\n"
                  "| `recovery` | string (optional) | (none) | a `[recoveries.NAME]` | `[monitors.NAME]` with action "
                  "recover: the behaviour that takes over |\n"
                  "| `watch_recovery` | bool | true | | `[monitors.NAME]` with action recover: a fresh instance "
                  "watches the recovery; tripping again ends the run aborted |\n"
                  "| `name` | string (optional) | the type | | a composite's child: its name in results and traces |\n"
                  "| `must_last` | bool | false | | a composite's child: its goal, judged when it ended, is asked "
                  "again when the run ends |",
        "header": "| key | type | default | bounds | meaning |\n|---|---|---|---|---|",
        "sensor": "## Sensor types (`[sensors.NAME]`)",
        "actuator": "## Actuator types (`[actuators.NAME]`)",
        "behaviour": "## Behaviour types (`[behaviour]`, `[monitors.NAME]`)",
        "reporter": "## Reporter types (`[report.NAME]`)",
        "task": "## Task types (`[env.task]`, see [gym.md](gym.md))",
        "no_keys": "No keys besides `type`{rate}.",
        "rate": " and `rate_hz`",
        "nested": "{owner}: `{key}` is a table with these keys:",
        "regions": "Bodies with `region = NAME` are placed at seeded random spots inside it.",
        "bodies": ("Exactly one of `shape`, `urdf`, `sdf`, `mjcf`; a pose from `position` or `region` (or "
                   "`mount`). `count = N` makes N copies named `NAME_0` … `NAME_{N-1}` (see the rules above)."),
        "report": "Besides these keys, one sub-table per reporter: `[report.local]`, `[report.http]` (below).",
        "env": "Read by `robokit.gym.make(config)`; `robokit run` ignores it. See [gym.md](gym.md).",
        "from": "from",
        "below": "(see below)",
    },
    "ko": {
        "lang": "ko",
        "title": "# 설정 파일 참고서",
        "other": "[English](config-reference.md) · [README](../README.md)",
        "generated": ("`python -m robokit.checks.config_reference`가 스키마에서 만든 페이지입니다. "
                      "이 페이지와 스키마가 다르면 테스트가 실패하므로, 여기 적힌 내용이 곧 "
                      "`robokit validate`가 검사하는 내용입니다. 키 이름과 '설명' 열은 코드의 스키마에 적힌 "
                      "영어 그대로입니다."),
        "rules_title": "## 모든 키에 통하는 규칙",
        "rules": """\
- **단위.** 길이와 위치는 미터, 키 이름이 `_deg`로 끝나면 각도는 도(그 밖에는 설명에 적힌 대로 라디안), 시간은
  **시뮬레이션 시간**의 초, 주기는 시뮬레이션 시간 기준 Hz, 힘은 뉴턴, 질량은 킬로그램입니다. 설명에 다른 좌표계가
  없으면 위치는 월드 좌표계(x 앞, y 왼쪽, z 위)입니다.
- **색**은 0에서 1 사이 실수 `[빨강, 초록, 파랑, 알파]`입니다(`[0.9, 0.1, 0.1, 1]`). 0-255 값은 0-1로 바꾼 값을
  알려 주며 거부됩니다.
- **숫자.** 범위가 따로 없으면 모든 실수는 유한하고 ±1e9 안이어야 합니다. 실수 자리에 정수를 써도 되지만 `true`는
  숫자가 아니고 `1`은 불리언이 아닙니다. 목록은 표에 적힌 길이와 정확히 같아야 합니다.
- **모르는 키는 오류입니다**("did you mean" 제안과 함께). 필수 키가 빠져도 오류입니다. 오류는 언제나 파일과 키
  경로를 적은 한 줄이며, `robokit validate CONFIG`로 실행하지 않고 설정만 검사할 수 있습니다.
- **물체 이름.** `[bodies.red]`에 `count = 1`(기본값)이면 물체 하나, 이름은 `red`입니다. `count = N`이면 복사본의
  이름은 `red_0`, `red_1` … `red_{N-1}`이고 그 물체의 `region` 안에 흩어 놓입니다. 모델이 여러 개 든 SDF나 MJCF
  파일은 `NAME`, `NAME_1`, `NAME_2` …가 됩니다. 센서, 액추에이터, 행동은 물체·관절·링크를 이 이름으로 부르며,
  모르는 이름은 올바른 이름 목록과 함께 실패합니다.
- **모델 파일**(`urdf`, `sdf`, `mjcf`)은 설정 파일 기준 상대 경로, robokit에 들어 있는 로봇, 또는 `pybullet_data`
  이름(`"franka_panda/panda.urdf"`)입니다. 키는 파일 종류와 맞아야 합니다: `urdf = "x.sdf"`는 `sdf =`를 알려 주는
  오류입니다.
- **플러그인 섹션**(`[sensors.NAME]`, `[actuators.NAME]`, `[behaviour]`, `[monitors.NAME]`, `[report.NAME]`,
  `[env.task]`)은 `type`(등록된 타입 이름, 두 배포판이 같은 이름을 등록하면 `DIST:type`)을 받고, `[env.task]`와
  리포터를 빼면 `rate_hz`(시뮬레이션 시간 기준 실행 주기 Hz, 기본값은 물리 스텝마다)도 받습니다. `rate_hz`는 물리
  주기(`1 / world.time_step`, 기본 240 Hz)를 나누어떨어지게 해야 합니다. 나머지 키는 아래에 적힌 타입별 키이며,
  설치된 모든 타입은 `robokit plugins`로 볼 수 있습니다.""",
        "core": "## 핵심 섹션",
        "components": "## 플러그인 타입을 고르는 섹션",
        "kinds": ("`[sensors.NAME]`은 센서 타입, `[actuators.NAME]`은 액추에이터 타입, `[behaviour]`와 "
                  "`[monitors.NAME]`은 행동 타입, `[report.NAME]`은 리포터 타입(`[report] keep_local = false`가 "
                  "아니면 `local`은 항상 켜짐), `[env.task]`는 태스크 타입을 받습니다. 공통 키:"),
        "common": "| 키 | 타입 | 기본값 | 범위 | 설명 |\n|---|---|---|---|---|\n"
                  "| `type` | string | (필수) | | 타입 이름 (이름이 겹치면 `dist:type`) |\n"
                  "| `rate_hz` | float (선택) | 매 틱 | > 0, 물리 주기를 나누어떨어지게 | 시뮬레이션 시간 기준 Hz |\n"
                  "| `action` | string | \"observe\" | observe, abort, recover | `[monitors.NAME]`만: 모니터가 "
                  "failed 또는 aborted로 끝났을 때 작업에 하는 일 |\n"
                  "| `recovery` | string (선택) | (없음) | `[recoveries.NAME]` | action recover인 `[monitors.NAME]`: "
                  "이어받을 행동 |\n"
                  "| `watch_recovery` | bool | true | | action recover인 `[monitors.NAME]`: 새 인스턴스가 복구를 "
                  "계속 감시하고, 다시 걸리면 실행은 aborted로 끝남 |\n"
                  "| `name` | string (선택) | 타입 이름 | | 복합 행동의 자식: 결과와 트레이스에 쓰이는 이름 |\n"
                  "| `must_last` | bool | false | | 복합 행동의 자식: 끝날 때 판정한 목표를 실행이 끝날 때 "
                  "다시 확인 |",
        "header": "| 키 | 타입 | 기본값 | 범위 | 설명 |\n|---|---|---|---|---|",
        "sensor": "## 센서 타입 (`[sensors.NAME]`)",
        "actuator": "## 액추에이터 타입 (`[actuators.NAME]`)",
        "behaviour": "## 행동 타입 (`[behaviour]`, `[monitors.NAME]`)",
        "reporter": "## 리포터 타입 (`[report.NAME]`)",
        "task": "## 태스크 타입 (`[env.task]`, [gym.md](gym.md) 참고)",
        "no_keys": "`type`{rate} 말고는 키가 없습니다.",
        "rate": "과 `rate_hz`",
        "nested": "{owner}: `{key}`는 다음 키를 가진 표입니다:",
        "regions": "`region = NAME`인 물체는 이 사각형 안의 시드에 따른 무작위 위치에 놓입니다.",
        "bodies": ("`shape`, `urdf`, `sdf`, `mjcf` 중 정확히 하나, 자세는 `position`이나 `region`(또는 `mount`)에서 "
                   "옵니다. `count = N`이면 `NAME_0` … `NAME_{N-1}`이라는 복사본 N개가 생깁니다(위 규칙 참고)."),
        "report": "이 키들 말고도 리포터마다 하위 표가 하나씩 있습니다: `[report.local]`, `[report.http]`(아래).",
        "env": "`robokit.gym.make(config)`가 읽고 `robokit run`은 무시합니다. [gym.md](gym.md)를 보세요.",
        "from": "출처",
        "below": "(아래 참고)",
    },
}


WORDS = {"ko": (
    (r"^\(required\)$", "(필수)"), (r"^\(none\)$", "(없음)"), (r" \(optional\)$", " (선택)"),
    (r"^each ", "각 항목 "), (r" or ", " 또는 "), (r"^table of (.*)$", r"\1의 표"),
    (r"at least (\d+) long", r"길이 \1 이상"), (r"table of ", "표: "),
)}
"""The page's own words in type, default and bounds cells, per language other than English (regex, replacement)."""
