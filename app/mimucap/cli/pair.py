"""``mimucap pair``: the paired suit, the devices the network sources let in.

    mimucap pair list
    mimucap pair listen --source udp:0.0.0.0:5555 [--duration S] [--sensors 1-10]
    mimucap pair add DEVICE_ID [DEVICE_ID ...] [--label NAME]
    mimucap pair remove DEVICE_ID [DEVICE_ID ...]

The network sources (``udp:``, ``slimevr:``) take data only from the paired devices; every
other device's packets are refused and counted (``unpaired_device``). ``listen`` opens the
source for ``--duration`` seconds (default 5) and pairs every device it hears that is not paired
yet: switch on your own suit only, away from others. ``add`` pairs a device by its id
(``mac:02A1B2C3D4E5``, ``mac:A1B2C3D4E5F6/0`` for a SlimeVR tracker's sensor 0, as ``list`` and
the GUI show them). The simulated suit, a replayed file and a serial line need no pairing, and
``mimucap record --allow IP ...`` names a fixed set-up's senders by address instead. The suit is
kept in ``paired_devices.json`` in the user data folder, beside the calibrations.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

from mimucap.acquisition.source_spec import SlimeVrSpec, UdpSpec, parse_source_spec

#: Seconds ``pair listen`` listens by default (a node says hello within a second of being heard).
DEFAULT_LISTEN_S = 5.0


def register(subparsers) -> None:
    parser = subparsers.add_parser("pair", help="pair devices with this installation (network sources)",
                                   description=__doc__.split("\n\n")[0].replace("``", ""))
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    actions.add_parser("list", help="the paired devices").set_defaults(func=run_list)
    listen = actions.add_parser("listen", help="pair every device heard on a network source")
    listen.add_argument("--source", required=True, metavar="SPEC", help="udp:BIND_ADDRESS:PORT or slimevr[:[BIND_ADDRESS:]PORT]")
    listen.add_argument("--duration", type=float, default=DEFAULT_LISTEN_S, metavar="S",
                        help=f"seconds to listen (default {DEFAULT_LISTEN_S:g})")
    listen.add_argument("--sensors", metavar="IDS", help="udp: pair only these wire ids, e.g. 1-10")
    listen.set_defaults(func=run_listen)
    add = actions.add_parser("add", help="pair devices by id")
    add.add_argument("device_ids", nargs="+", metavar="DEVICE_ID")
    add.add_argument("--label", default="", metavar="NAME", help="the sensor id it is known as (for people)")
    add.set_defaults(func=run_add)
    remove = actions.add_parser("remove", help="unpair devices")
    remove.add_argument("device_ids", nargs="+", metavar="DEVICE_ID")
    remove.set_defaults(func=run_remove)


def run_list(args: argparse.Namespace) -> int:
    from mimucap.io.pairing_store import PairingStore

    store = PairingStore()
    devices = store.devices()
    if not devices:
        print(f"no device is paired ({store.path}); pair with: mimucap pair listen --source SPEC")
        return 0
    for device in devices:
        print(f"{device.device_id:<24} {device.describe()}, paired {device.paired_utc or 'at an unknown time'}")
    return 0


def run_add(args: argparse.Namespace) -> int:
    from mimucap.io.pairing_store import PairingStore

    store = PairingStore()
    added = store.pair((device_id, args.label) for device_id in args.device_ids)
    for device_id in args.device_ids:
        print(f"{'paired' if device_id in added else 'already paired'}: {device_id}")
    return 0


def run_remove(args: argparse.Namespace) -> int:
    from mimucap.io.pairing_store import PairingStore

    removed = PairingStore().unpair(args.device_ids)
    missing = [device_id for device_id in args.device_ids if device_id not in removed]
    for device_id in removed:
        print(f"unpaired: {device_id}")
    if missing:
        raise ValueError(f"not paired: {', '.join(missing)} (see mimucap pair list)")
    return 0


def run_listen(args: argparse.Namespace) -> int:
    from mimucap.acquisition.supervisor import Supervisor
    from mimucap.io.pairing_store import PairingStore
    from mimucap.session.sources.source_configs import SourceOptions, parse_sensor_ids, source_configs

    spec = parse_source_spec(args.source)
    if not isinstance(spec, (UdpSpec, SlimeVrSpec)):
        raise ValueError(f"{args.source}: only the network sources (udp:, slimevr:) are paired; "
                         "the simulated suit, a replay and a serial line need no pairing")
    if not (math.isfinite(args.duration) and args.duration > 0):
        raise ValueError(f"--duration must be > 0 s, got {args.duration:g}")
    if args.sensors is not None and not isinstance(spec, UdpSpec):
        raise ValueError("--sensors applies to udp sources only")
    store = PairingStore()
    options = SourceOptions(sensor_ids=parse_sensor_ids(args.sensors), paired_devices=store.device_ids())
    supervisor = Supervisor(source_configs(spec, options))
    print(f"listening on {args.source} for {args.duration:g} s…", file=sys.stderr, flush=True)
    supervisor.start()
    try:
        end = time.monotonic() + args.duration
        while time.monotonic() < end:
            supervisor.poll(min(0.1, max(end - time.monotonic(), 0.0)))
    finally:
        supervisor.stop()
    heard = {}
    for status in supervisor.sources().values():
        if status.state == "failed":
            raise OSError(f"{args.source}: {status.message or status.last_error}")
        heard.update(status.unpaired)
    pairable = [sensor for sensor in heard.values() if sensor.pairable]
    added = store.pair((sensor.device.device_id, sensor.sensor) for sensor in pairable)
    for sensor in pairable:
        print(f"paired: {sensor.device.device_id} ({sensor.describe()})")
    for sensor in heard.values():
        if not sensor.pairable:
            print(f"cannot pair {sensor.describe()}", file=sys.stderr)
    if not added:
        print(f"no new device heard on {args.source} ({len(store.devices())} paired)")
    return 0
