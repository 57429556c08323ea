"""Discovery range: ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_STATIC_PEERS, ROS_LOCALHOST_ONLY -> Cyclone config.

Read as rcl (Jazzy) reads them and turned into the Cyclone configuration rmw_cyclonedds_cpp builds in
`check_create_domain`, placed before `CYCLONEDDS_URI` (which can still override any of it):

| range | multicast | peers | participant index |
|---|---|---|---|
| SUBNET (default) | on | ROS_STATIC_PEERS | Cyclone's default, unless peers are given (auto, max 32) |
| LOCALHOST | off | localhost + ROS_STATIC_PEERS | auto, max 32 |
| OFF | off | none | none, and a domain tag unique to the process (nothing can discover it) |
| SYSTEM_DEFAULT | Cyclone's own configuration untouched | | |

`ROS_LOCALHOST_ONLY=1` (deprecated) wins and means LOCALHOST without static peers.  An unknown range
value is taken as LOCALHOST with a warning, as rcl does.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field

RANGES = ('SUBNET', 'LOCALHOST', 'OFF', 'SYSTEM_DEFAULT')


@dataclass
class DiscoveryOptions:
    automatic_range: str = 'SUBNET'
    static_peers: list[str] = field(default_factory=list)


def _warn(text: str) -> None:
    print(f'[WARN] [rcl]: {text}', file=sys.stderr, flush=True)


def from_environment(env: dict[str, str] | None = None) -> DiscoveryOptions:
    """The discovery options rcl derives from the environment."""
    env = os.environ if env is None else env
    if env.get('ROS_LOCALHOST_ONLY', '') == '1':
        _warn('ROS_LOCALHOST_ONLY is deprecated but still honored if it is enabled. '
              'Use ROS_AUTOMATIC_DISCOVERY_RANGE and ROS_STATIC_PEERS instead.')
        return DiscoveryOptions('LOCALHOST', [])
    text = env.get('ROS_AUTOMATIC_DISCOVERY_RANGE', '')
    if text == '':
        automatic = 'SUBNET'
    elif text in RANGES:
        automatic = text
    else:
        _warn(f"Invalid value '{text}' specified for 'ROS_AUTOMATIC_DISCOVERY_RANGE', "
              'assuming localhost only')
        automatic = 'LOCALHOST'
    peers: list[str] = []
    if automatic != 'OFF':
        peers = [p.strip() for p in env.get('ROS_STATIC_PEERS', '').split(';') if p.strip()]
    return DiscoveryOptions(automatic, peers)


def cyclone_config(options: DiscoveryOptions, pid: int | None = None) -> str:
    """The Cyclone XML fragment rmw_cyclonedds_cpp prepends to CYCLONEDDS_URI ('' when none is needed)."""
    rng = options.automatic_range
    add_localhost = rng == 'LOCALHOST'
    add_static = rng in ('SUBNET', 'LOCALHOST')
    no_multicast = rng in ('LOCALHOST', 'OFF')
    if not (add_localhost or (add_static and options.static_peers) or no_multicast):
        return ''
    config = '<CycloneDDS><Domain>'
    if no_multicast:
        config += '<General><AllowMulticast>false</AllowMulticast></General>'
    if no_multicast and not add_localhost and not add_static:
        config += '<Discovery><ParticipantIndex>none</ParticipantIndex>'
        config += f'<Tag>ros_discovery_off_{os.getpid() if pid is None else pid}</Tag>'
    else:
        config += '<Discovery><ParticipantIndex>auto</ParticipantIndex>'
        config += '<MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>'
    peers = (['localhost'] if add_localhost else []) + (options.static_peers if add_static else [])
    if peers:
        config += '<Peers>' + ''.join(f'<Peer address="{p}"/>' for p in peers) + '</Peers>'
    return config + '</Discovery></Domain></CycloneDDS>'


def domain_config(env: dict[str, str] | None = None) -> str | None:
    """Full configuration for `dds_create_domain`: our fragment, then CYCLONEDDS_URI (None: defaults)."""
    env = os.environ if env is None else env
    fragment = cyclone_config(from_environment(env))
    uri = env.get('CYCLONEDDS_URI', '')
    if not fragment:
        return None
    return fragment + (',' + uri if uri else '')
