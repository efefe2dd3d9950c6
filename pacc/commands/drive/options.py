"""The options of ``pacc drive``: its argument parser, each option validated as it is read."""

from __future__ import annotations

import argparse
from pathlib import Path

from dbc.network import add_network_arguments
from ecu.adaptation import ADAPTATION_MODES
from ecu.buslog.live import add_foxglove_argument
from pacc.commands._args import CommandParser, add_world_arguments, json_parameters, number
from pacc.study.drive import BUSES, CONTROLLERS
from sim_bus.drivers import CONDITION_FACTORS


def parser(description: str = "") -> argparse.ArgumentParser:
    """The parser of ``pacc drive``'s options (``--help`` prints them after
    ``description``)."""
    p = CommandParser(
        prog="pacc drive",
        description=description,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_world_arguments(p)
    p.add_argument("--controller", default="predefined", choices=CONTROLLERS)
    p.add_argument("--profile", type=Path, help="DGPT JSON for the irl controllers")
    p.add_argument(
        "--manual",
        action="store_true",
        help="drive by hand, ACC off (needs --log): a demonstration for pacc cloud learn",
    )
    p.add_argument(
        "--can-log",
        type=Path,
        metavar="FILE",
        help="record the ECU's bus traffic (raw and decoded), its internals and the "
        "simulated world to this MCAP file",
    )
    p.add_argument(
        "--manual-trips",
        type=Path,
        metavar="DIR",
        help="record what the ECU sees of the driver's manual car-following (ACC not "
        "engaged, a lead, inputs good; 10 s or longer: with --brake-mode cancel after a "
        "brake takeover) as trip logs DIR/manual_NNNN.mcap, demonstrations for pacc cloud "
        "learn",
    )
    add_foxglove_argument(p)
    p.add_argument(
        "--pace",
        type=number(0.0, 1e6),
        metavar="X",
        help="run the drive at X times real time (0: as fast as it runs; default 1 with "
        "--foxglove, so the live view shows it as it happens, else 0)",
    )
    p.add_argument(
        "--brake-mode",
        choices=("resume", "cancel"),
        default="resume",
        help="brake press: override and resume (paper) or cancel (production)",
    )
    p.add_argument(
        "--condition",
        choices=sorted(CONDITION_FACTORS),
        default="dry",
        help="driving condition: wet or night lengthen the driver's preference "
        "(docs/drivers.md; multiplies --condition-factor)",
    )
    p.add_argument(
        "--cache", type=Path, help="cache folder of learned IRL tables (default ~/.cache/pacc)"
    )
    p.add_argument(
        "--adaptation-mode",
        choices=ADAPTATION_MODES,
        help="online adaptation of the +oa controllers: the paper's Algorithm 1 "
        "or the time-gap update (default: the ECU's, see docs/ecu.md)",
    )
    p.add_argument(
        "--bus",
        choices=BUSES,
        default=BUSES[0],
        help="the python-can bus between ECU and simulator: the in-process lockstep bus "
        "(default) or python-can's virtual bus (the same frames, slower)",
    )
    p.add_argument(
        "--gap-controller",
        default="",
        metavar="SPEC",
        help="gap controller through the plug-in interface: pid, an installed entry point "
        "of pacc.controllers or module:attribute (default: the built-in PID called directly; "
        "'pacc plugins' lists them)",
    )
    p.add_argument(
        "--adaptation",
        default="",
        metavar="SPEC",
        help="online adaptation of the +oa controllers through the plug-in interface: "
        "timegap, paper, bayes, an entry point of pacc.adaptations or module:attribute",
    )
    p.add_argument(
        "--gap-controller-args",
        type=json_parameters,
        default=(),
        metavar="JSON",
        help="the --gap-controller plug-in's parameters, a JSON object (docs/plugins.md)",
    )
    p.add_argument(
        "--adaptation-args",
        type=json_parameters,
        default=(),
        metavar="JSON",
        help="the --adaptation plug-in's parameters, a JSON object (docs/plugins.md)",
    )
    add_network_arguments(p)
    return p
