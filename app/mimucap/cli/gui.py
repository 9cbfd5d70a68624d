"""``mimucap gui``: the desktop application (the default when ``mimucap`` has no arguments)."""

from __future__ import annotations

import argparse


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "gui",
        help="start the desktop application (default)",
        description=(
            "Start the MimuCap desktop application. With --screenshot it writes the window to a PNG "
            "after --after seconds and exits (for headless checks: xvfb-run -a mimucap gui --screenshot out.png)."
        ),
    )
    parser.add_argument(
        "--source", default=None,
        help="live source: simulated[:SCENARIO][@ROOM] (default: the last one chosen, first simulated:demo), udp:ADDR:PORT, serial:DEVICE[@BAUD], replay:FILE[@SPEED]",
    )
    parser.add_argument("--screenshot", metavar="PATH", default=None, help="write the window to this PNG and exit")
    parser.add_argument("--after", metavar="SECONDS", type=float, default=3.0,
                        help="seconds of live data before the screenshot (default 3; counted once the filters are prepared)")
    parser.add_argument("--review", metavar="FILE", default=None,
                        help="also open this recorded session (.h5) for review in the Review workspace (with --screenshot: shoot it once shown)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mimucap.gui.app import run_gui

    return run_gui(source=args.source, screenshot=args.screenshot, after_s=args.after, review=args.review)
