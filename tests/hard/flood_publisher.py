"""A 10 kHz flood of actuator commands, good and bad, as its own process (so the test
process can listen without competing for one interpreter).

    python -m tests.hard.flood_publisher --rate 10000 --count 20000 --hold F1 F2

Waits for ``--subscribers`` matched subscriptions on ``actuator_forces``, publishes
``count`` ActuatorForces at ``rate`` Hz cycling through ``PATTERN`` (every third command
valid: the hold forces; the others NaN, inf, a wrong length, an unknown name, over the
force limit), waits until every reliable subscriber acknowledged them and prints one JSON
line: ``{"published": n, "valid": k, "start_ns": t0, "end_ns": t1, "last_valid": [f1, f2]}``
(wall clock, as the recorder's receive times).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

#: (names, forces) of each kind of command; ``None`` forces stand for the hold forces.
PATTERN = [
    ("valid", [], None),
    ("nan", ["f1", "f2"], [math.nan, 0.0]),
    ("inf", ["f1"], [math.inf]),
    ("valid", ["f1", "f2"], None),
    ("wrong_length", [], [1.0, 2.0, 3.0]),
    ("unknown_name", ["f3"], [1.0]),
    ("valid", [], None),
    ("over_limit", ["f2"], [1e9]),
    ("names_forces_mismatch", ["f1", "f2"], [1.0]),
]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rate", type=float, default=10_000.0)
    ap.add_argument("--count", type=int, default=20_000)
    ap.add_argument("--hold", type=float, nargs=2, required=True)
    ap.add_argument("--subscribers", type=int, default=1)
    ap.add_argument("--namespace", default="")
    args = ap.parse_args(argv)

    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import QoSProfile
    from tensegrity_msgs.msg import ActuatorForces

    from tensegrity_ros.rclpy_utils.matching import wait_for_matches

    rclpy.init()
    node = rclpy.create_node("flood_publisher", namespace=args.namespace)
    pub = node.create_publisher(ActuatorForces, "actuator_forces", QoSProfile(depth=args.count))
    wait_for_matches([pub], args.subscribers, 60, settle_s=0.5)
    msgs = []
    for k in range(args.count):
        _, names, forces = PATTERN[k % len(PATTERN)]
        msgs.append(ActuatorForces(name=names, force=list(args.hold) if forces is None else forces))
    valid = sum(1 for k in range(args.count) if PATTERN[k % len(PATTERN)][0] == "valid")
    period = 1.0 / args.rate
    start_ns = time.time_ns()
    t0 = time.perf_counter()
    for k, msg in enumerate(msgs):
        ahead = t0 + k * period - time.perf_counter()
        if ahead > 0.002:                    # sleep rather than spin: the machine has 2 cores
            time.sleep(ahead)
        pub.publish(msg)
    end_ns = time.time_ns()
    acked = pub.wait_for_all_acked(Duration(seconds=60))
    print(json.dumps({"published": args.count, "valid": valid, "start_ns": start_ns, "end_ns": end_ns,
                      "seconds": (end_ns - start_ns) / 1e9, "last_valid": list(args.hold), "acked": acked}),
          flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
