"""Print a ROS_DOMAIN_ID on which no DDS participant is seen (for scripts/run_mission.sh).

Why: two graphs on one domain cross (both vehicles answer one goal). A random id is only likely
to be free; this one is checked: it joins the domain with Cyclone DDS (pip ``cyclonedds``, or the
one of a ROS 2 install) and listens ``--listen`` seconds for other participants (SPDP discovery).
Candidates are 10..99 (their ports stay clear of the ephemeral range), tried in a random order.
Exit 1 when none is free (or Cyclone DDS's Python binding is missing: then it says so).
"""
from __future__ import annotations

import argparse
import random
import sys
import time


def others_on(domain: int, listen: float) -> int:
    """How many participants besides our own are seen on ``domain`` within ``listen`` seconds."""
    from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant
    from cyclonedds.domain import DomainParticipant
    dp = DomainParticipant(domain)
    try:
        reader = BuiltinDataReader(dp, BuiltinTopicDcpsParticipant)
        seen: set[str] = set()
        deadline = time.monotonic() + listen
        while time.monotonic() < deadline:
            seen.update(str(s.key) for s in reader.take(N=64))
            time.sleep(0.05)
        seen.discard(str(dp.guid))
        return len(seen)
    finally:
        del dp


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--listen", type=float, default=1.0, help="seconds to listen on each candidate")
    ap.add_argument("--tries", type=int, default=8)
    args = ap.parse_args()
    try:
        import cyclonedds  # noqa: F401
    except ImportError:
        print("free_domain: no cyclonedds Python binding; cannot check", file=sys.stderr)
        return 1
    for domain in random.sample(range(10, 100), args.tries):
        n = others_on(domain, args.listen)
        if n == 0:
            print(domain)
            return 0
        print(f"free_domain: ROS_DOMAIN_ID {domain} has {n} participant(s); trying another", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
