"""QoS profiles in rosbag2's YAML form, and the QoS to request (record) or offer (replay).

A profile is kept as a plain dict in the form rosbag2 Jazzy writes (metadata version 9):
policies by name (``"reliable"``, ``"best_effort"``, ``"keep_last"``, ``"transient_local"``,
``"automatic"``, ``"unknown"``, ...), ``depth`` an int, durations as ``{sec, nsec}`` with
rmw's infinite duration ``{sec: 9223372036, nsec: 854775807}``. Version 8 and older bags
store the policies as their rmw enum integers; :func:`normalize_profile` reads both.

The adaptation rules are rosbag2's (``Rosbag2QoS::adapt_request_to_offers`` and
``adapt_offer_to_recorded_offers``): record reliably only if every publisher offers
reliable, transient-local only if every publisher does; replay with the recorded offer when
all publishers offered the same compatibility-relevant policies, else with the default.
"""

from __future__ import annotations

from collections.abc import Iterable
from enum import IntEnum
from typing import TYPE_CHECKING, Any, TypeVar

import yaml

from tensegrity_core.excerpt import excerpt
from tensegrity_ros.bag.errors import BagError
from tensegrity_ros.bag.untrusted import load_bag_yaml

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile

_Policy = TypeVar("_Policy", bound=IntEnum)

INFINITE_NS = 9_223_372_036_854_775_807  # RMW_DURATION_INFINITE as nanoseconds

# rmw enum value -> rosbag2 name (rmw_qos_*_policy_to_str; "unknown" for UNKNOWN)
HISTORY = {0: "system_default", 1: "keep_last", 2: "keep_all", 3: "unknown"}
RELIABILITY = {0: "system_default", 1: "reliable", 2: "best_effort", 3: "unknown",
               4: "best_available"}
DURABILITY = {0: "system_default", 1: "transient_local", 2: "volatile", 3: "unknown",
              4: "best_available"}
LIVELINESS = {0: "system_default", 1: "automatic", 3: "manual_by_topic", 4: "unknown",
              5: "best_available"}
_POLICIES = {"history": HISTORY, "reliability": RELIABILITY, "durability": DURABILITY,
             "liveliness": LIVELINESS}
_DURATIONS = ("deadline", "lifespan", "liveliness_lease_duration")

DEFAULT_REPLAY_DEPTH = 100


def duration_dict(ns: int) -> dict[str, int]:
    """Nanoseconds -> rosbag2's ``{sec, nsec}``."""
    return {"sec": int(ns) // 1_000_000_000, "nsec": int(ns) % 1_000_000_000}


def duration_ns(d: dict[str, Any]) -> int:
    """rosbag2's ``{sec, nsec}`` -> nanoseconds (the Foxy-era infinities map to infinite)."""
    sec, nsec = int(d["sec"]), int(d["nsec"])
    if (sec, nsec) in {(0x7FFFFFFF, 0xFFFFFFFF), (0x7FFFFFFF, 0x7FFFFFFF)}:
        return INFINITE_NS
    return min(sec * 1_000_000_000 + nsec, INFINITE_NS)


def default_profile() -> dict[str, Any]:
    """rclcpp's default QoS: keep_last 10, reliable, volatile, everything else unspecified."""
    return {
        "history": "keep_last", "depth": 10, "reliability": "reliable",
        "durability": "volatile", "deadline": duration_dict(0), "lifespan": duration_dict(0),
        "liveliness": "system_default", "liveliness_lease_duration": duration_dict(0),
        "avoid_ros_namespace_conventions": False,
    }


def profile_to_dict(profile: Any) -> dict[str, Any]:
    """An rclpy ``QoSProfile`` (e.g. a publisher's offered QoS) -> rosbag2 dict."""
    out: dict[str, Any] = {}
    for key, names in _POLICIES.items():
        out[key] = names.get(int(getattr(profile, key)), "unknown")
    out["depth"] = int(profile.depth)
    for key in _DURATIONS:
        out[key] = duration_dict(getattr(profile, key).nanoseconds)
    out["avoid_ros_namespace_conventions"] = bool(profile.avoid_ros_namespace_conventions)
    order = ("history", "depth", "reliability", "durability", "deadline", "lifespan",
             "liveliness", "liveliness_lease_duration", "avoid_ros_namespace_conventions")
    return {k: out[k] for k in order}


def normalize_profile(item: object) -> dict[str, Any]:
    """A profile dict of any metadata version (names or enum ints) -> version-9 form."""
    if not isinstance(item, dict):
        raise BagError(f"a QoS profile must be a mapping, got {excerpt(item)}")
    out = default_profile()
    for key, names in _POLICIES.items():
        if key not in item:
            continue
        value = item[key]
        if isinstance(value, int):
            out[key] = names.get(value, "unknown")
        elif isinstance(value, str) and value.lower() in names.values():
            out[key] = value.lower()
        else:
            raise BagError(f"QoS {key} {excerpt(value)} is not one of {sorted(names.values())}")
    if "depth" in item:
        depth = item["depth"]
        if isinstance(depth, bool) or not isinstance(depth, int) or not 0 <= depth < 2**32:
            raise BagError(f"QoS depth must be an integer in [0, 2**32), got {excerpt(depth)}")
        out["depth"] = depth
    for key in _DURATIONS:
        if key in item:
            try:
                out[key] = duration_dict(duration_ns(item[key]))
            except (KeyError, TypeError, ValueError):
                raise BagError(f"QoS {key} must be {{sec, nsec}} integers, got "
                               f"{excerpt(item[key])}") from None
    if "avoid_ros_namespace_conventions" in item:
        out["avoid_ros_namespace_conventions"] = bool(item["avoid_ros_namespace_conventions"])
    return out


def parse_profiles(value: str | list[Any] | None) -> list[dict[str, Any]]:
    """``offered_qos_profiles`` as stored (YAML text, a list, ``""`` or None) -> dicts."""
    if value is None or value == "":
        return []
    if isinstance(value, str):
        value = load_bag_yaml(value, "offered_qos_profiles")
        if value is None:
            return []
    if not isinstance(value, list):
        raise BagError(f"offered_qos_profiles must be a list of profiles, got {excerpt(value)}")
    return [normalize_profile(item) for item in value]


def dump_profiles(profiles: Iterable[dict[str, Any]]) -> str:
    """Profiles -> the YAML text rosbag2 puts in the MCAP channel metadata."""
    items = list(profiles)
    if not items:
        return ""
    return yaml.safe_dump(items, default_flow_style=False, sort_keys=False)


def request_for_offers(offers: list[dict[str, Any]], depth: int) -> dict[str, Any]:
    """QoS to subscribe with so as to match every offer (rosbag2's rule; see module doc)."""
    req = default_profile()
    req["depth"] = int(depth)
    if offers and not all(o["reliability"] == "reliable" for o in offers):
        req["reliability"] = "best_effort"
    if offers and all(o["durability"] == "transient_local" for o in offers):
        req["durability"] = "transient_local"
    return req


def offer_for_replay(recorded: list[dict[str, Any]], depth: int = DEFAULT_REPLAY_DEPTH) -> dict[str, Any]:
    """QoS to publish a recorded topic with (rosbag2's rule), history ``keep_last(depth)``."""
    keys = ("reliability", "durability", "deadline", "liveliness", "liveliness_lease_duration")
    if recorded and all(all(p[k] == recorded[0][k] for k in keys) for p in recorded):
        offer = dict(recorded[0])
    else:
        offer = default_profile()
    offer["history"] = "keep_last"
    offer["depth"] = int(depth)
    for key, fallback in (("reliability", "reliable"), ("durability", "volatile")):
        if offer[key] in ("unknown", "best_available"):
            offer[key] = fallback
    if offer["liveliness"] in ("unknown", "best_available"):
        offer["liveliness"] = "system_default"
    return offer


def dict_to_profile(d: dict[str, Any]) -> QoSProfile:
    """rosbag2 dict -> rclpy ``QoSProfile`` (imports rclpy)."""
    from rclpy.duration import Duration
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, LivelinessPolicy, QoSProfile, ReliabilityPolicy

    def enum(cls: type[_Policy], names: dict[int, str], value: str) -> _Policy:
        return cls({v: k for k, v in names.items()}[value])

    return QoSProfile(
        history=enum(HistoryPolicy, HISTORY, d["history"]),
        depth=int(d["depth"]),
        reliability=enum(ReliabilityPolicy, RELIABILITY, d["reliability"]),
        durability=enum(DurabilityPolicy, DURABILITY, d["durability"]),
        deadline=Duration(nanoseconds=duration_ns(d["deadline"])),
        lifespan=Duration(nanoseconds=duration_ns(d["lifespan"])),
        liveliness=enum(LivelinessPolicy, LIVELINESS, d["liveliness"]),
        liveliness_lease_duration=Duration(
            nanoseconds=duration_ns(d["liveliness_lease_duration"])),
        avoid_ros_namespace_conventions=bool(d["avoid_ros_namespace_conventions"]),
    )
