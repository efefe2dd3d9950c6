"""``pacc plot LOG --plotjuggler OUT.xml``: a PlotJuggler layout that opens a bus recording.

PlotJuggler 3.x names a recording's series ``<topic>/<field>`` (``/ecu/inputs/gap_m``). The
layout has two tabs, the drive (the panels of ``docs/foxglove-layout.json``) and the bus (the
decoded CAN signals), with only the curves the recording has, and names the recording relative
to itself with the MCAP loader's settings, so ``plotjuggler -l OUT.xml`` opens it directly.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET


@dataclass(frozen=True)
class Panel:
    """One plot: a title and its curves as ``(topic, field)``."""

    title: str
    curves: tuple[tuple[str, str], ...]


DRIVE_PANELS = (
    Panel(
        "gap vs desired gap, m",
        (
            ("/ecu/inputs", "gap_m"),
            ("/ecu/outputs", "desired_gap_m"),
            ("/sim/world", "pref_gap_m"),
        ),
    ),
    Panel(
        "speeds, m/s",
        (
            ("/ecu/inputs", "v_mps"),
            ("/sim/world", "v_lead_mps"),
            ("/ecu/outputs", "set_speed_mps"),
        ),
    ),
    Panel("pedals, 0..1", (("/ecu/inputs", "accel_pedal"), ("/ecu/inputs", "brake_pedal"))),
    Panel(
        "ACC request, m/s^2; state (2 ACTIVE, 3 OVERRIDE)",
        (("/ecu/outputs", "accel_request_mps2"), ("/ecu/outputs", "acc_state")),
    ),
)
BUS_PANELS = (
    Panel(
        "ESC_Speed, RADAR_Lead: m/s",
        (("/can/ESC_Speed", "VehicleSpeed"), ("/can/RADAR_Lead", "LeadRelSpeed")),
    ),
    Panel(
        "RADAR_Lead, ACC_Status: m",
        (("/can/RADAR_Lead", "LeadDistance"), ("/can/ACC_Status", "DesiredGap")),
    ),
    Panel(
        "PEDAL_Status: %, bar",
        (("/can/PEDAL_Status", "AccelPedalPos"), ("/can/PEDAL_Status", "BrakePressure")),
    ),
    Panel(
        "ACC_Command: m/s^2, state",
        (("/can/ACC_Command", "AccelRequest"), ("/can/ACC_Command", "AccState")),
    ),
)
_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b")


def recording_series(
    decoded: Mapping[str, Mapping[str, object]], series: Mapping[str, Mapping[str, object]]
) -> dict[str, set[str]]:
    """Topic -> fields of a recording's protobuf channels: ``/can/<message>`` from its decoded
    messages, the internals topics from its series (``t_s``, the reader's own, left out)."""
    out = {f"/can/{name}": set(cols) - {"t_s"} for name, cols in decoded.items()}
    out.update({topic: set(cols) - {"t_s"} for topic, cols in series.items()})
    return out


def _tab(parent: ET.Element, name: str, panels: Sequence[Panel]) -> None:
    tab = ET.SubElement(parent, "Tab", tab_name=name, containers="1")
    split = ET.SubElement(
        ET.SubElement(tab, "Container"),
        "DockSplitter",
        orientation="-",
        count=str(len(panels)),
        sizes=";".join([f"{1 / len(panels):.6f}"] * len(panels)),
    )
    for panel in panels:
        area = ET.SubElement(split, "DockArea", name=panel.title)
        plot = ET.SubElement(
            area, "plot", mode="TimeSeries", flip_x="false", flip_y="false", style="Lines"
        )
        ET.SubElement(plot, "range", bottom="0", top="1", left="0", right="1")
        ET.SubElement(plot, "limitY")
        for (topic, field), colour in zip(panel.curves, _COLOURS, strict=False):
            ET.SubElement(plot, "curve", name=f"{topic}/{field}", color=colour)


def _present(panels: Sequence[Panel], have: Mapping[str, set[str]]) -> list[Panel]:
    """The panels with only the curves the recording has (panels left empty dropped)."""
    kept = []
    for p in panels:
        curves = tuple((t, f) for t, f in p.curves if f in have.get(t, ()))
        if curves:
            kept.append(Panel(p.title, curves))
    return kept


def layout_xml(recording: Path, layout: Path, have: Mapping[str, set[str]]) -> str:
    """The PlotJuggler layout (XML text) for ``recording`` written at ``layout``; ``have``:
    :func:`recording_series` of it. ValueError if it has none of the layout's curves.
    """
    tabs = [
        (name, _present(panels, have))
        for name, panels in (("pacc drive", DRIVE_PANELS), ("CAN signals", BUS_PANELS))
    ]
    tabs = [(name, panels) for name, panels in tabs if panels]
    if not tabs:
        raise ValueError(f"{recording}: none of the layout's signals is in this recording")
    root = ET.Element("root")
    widget = ET.SubElement(root, "tabbed_widget", {"name": "Main Window", "parent": "main_window"})
    for name, panels in tabs:
        _tab(widget, name, panels)
    ET.SubElement(widget, "currentTabIndex", index="0")
    ET.SubElement(root, "use_relative_time_offset", enabled="1")
    files = ET.SubElement(root, "previouslyLoaded_Datafiles")
    rel = os.path.relpath(recording.resolve(), layout.resolve().parent)
    info = ET.SubElement(files, "fileInfo", filename=Path(rel).as_posix(), prefix="")
    ET.SubElement(
        ET.SubElement(info, "plugin", ID="DataLoad MCAP"),
        "parameters",
        use_timestamp="0",
        use_mcap_log_time="1",
        clamp_large_arrays="0",
        max_array_size="500",
        selected_topics=";".join(sorted(have)),
    )
    ET.indent(root, space=" ")
    return "<?xml version='1.0' encoding='UTF-8'?>\n" + ET.tostring(root, encoding="unicode") + "\n"
