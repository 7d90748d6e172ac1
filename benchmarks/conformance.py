"""What the conformance checks cost: wall time of ``check_sensor`` / ``check_actuator`` per registered type.

Each check builds three small DIRECT-mode simulations from the type's ``example`` (two for determinism, one
baseline for the close check) and steps two of them ``ticks`` ticks. Types that declare no ``example`` are listed
as missing. The median of ``--repeats`` runs is printed per type, then the total.

    python benchmarks/conformance.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import time

from robokit.plugin_api.plugins import load_plugins
from robokit.testing import ConformanceError, check_actuator, check_sensor

CHECKS = {"sensor": check_sensor, "actuator": check_actuator}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    plugins = load_plugins()
    total = 0.0
    print(f"{'type':<26} {'origin':<28} {'median s':>9}  result")
    for kind, check in CHECKS.items():
        for name, ptype in sorted(plugins.types[kind].items()):
            times, outcome = [], "ok"
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                try:
                    check(name)
                except ConformanceError as exc:
                    outcome = "FAIL: " + str(exc).split(": ", 2)[-1][:70]
                times.append(time.perf_counter() - t0)
                if outcome != "ok":
                    break
            median = statistics.median(times)
            total += median
            print(f"{kind + ':' + name:<26} {ptype.origin:<28} {median:>9.3f}  {outcome}")
    print(f"total (medians): {total:.2f} s")


if __name__ == "__main__":
    main()
