"""A recording and docs/foxglove-layout.json as the Foxglove app reads them.

Checked against Foxglove Studio 1.48 (its published web bundle, opened on a recording through
the layout by tools/foxglove_shot.sh, docs/logs.md) and Lichtblick's sources:

- Foxglove's ``parseJsonSchema`` (packages/mcap-support: Studio 1.48's bundle, and Lichtblick's
  source) turns a channel's JSON schema into message definitions and refuses the whole channel
  ("Error in topic ...": nothing read from it) when the schema holds an object without
  ``properties``, a field without a type it knows, or an encoded string other than base64. A
  recording's ``/can/raw`` failed so in the app: its ``dtypes`` object had only
  ``additionalProperties``. :func:`foxglove_fields` is that function's acceptance rules, ported.
- A layout (the format of the app's "Import layout"): ``configById`` (panel id ``Type!name`` ->
  config) and ``layout``, a tree of splits whose leaves are those ids. A panel's title is its
  config's ``foxglovePanelTitle`` (the Plot panel's own ``title`` is deprecated; the State
  Transitions and Log panels have none).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from ecu.buslog.blocks import block_schema
from ecu.buslog.format import LOG_SCHEMA, RAW_COLUMNS, RAW_SCHEMA


class Refused(ValueError):
    """What Foxglove's parseJsonSchema throws on."""


_SCALARS = ("boolean", "number", "integer")


def _nested(sub: dict[str, Any], where: str) -> dict[str, Any] | None:
    """The object schema field ``sub`` nests (itself, or its array's items), None for a
    scalar; Refused where parseJsonSchema throws on the field."""
    kind = sub.get("type")
    if "oneOf" in sub:  # an enumeration: numeric constants only
        if not all(isinstance(alt.get("const"), int | float) for alt in sub["oneOf"]):
            raise Refused(f"{where}: oneOf alternatives must be numbers")
        return None
    if kind == "object":
        return sub
    if kind == "array":
        item: dict[str, Any] = sub.get("items", {})
        if item.get("type") == "object":
            return item
        if item.get("type") not in ("string", *_SCALARS) or "contentEncoding" in item:
            raise Refused(f"{where}: array items {item}")
        return None
    if kind == "string":
        if sub.get("contentEncoding") not in (None, "base64"):
            raise Refused(f"{where}: contentEncoding {sub['contentEncoding']!r}")
        return None
    if kind not in _SCALARS:
        raise Refused(f"{where}: type {kind!r}")
    return None


def foxglove_fields(schema: dict[str, Any], name: str) -> dict[str, list[str]]:
    """Type name -> field names, as Foxglove's parseJsonSchema defines them for ``schema``.

    Raises:
        Refused: where parseJsonSchema throws.
    """
    if schema.get("type") != "object":
        raise Refused(f"{name}: expected type object, got {schema.get('type')!r}")
    props = schema.get("properties")
    if not isinstance(props, dict):  # Object.entries(undefined) throws
        raise Refused(f"{name}: an object without properties")
    out = {name: list(props)}
    for field, sub in props.items():
        nested = _nested(sub, f"{name}.{field}")
        if nested is not None:
            out.update(foxglove_fields(nested, f"{name}.{field}"))
    return out


def test_the_port_refuses_what_foxglove_refuses() -> None:
    dtypes_only = {"type": "object", "additionalProperties": {"type": "string"}}
    with pytest.raises(Refused, match="without properties"):
        foxglove_fields({"type": "object", "properties": {"dtypes": dtypes_only}}, "x")
    with pytest.raises(Refused, match="type None"):
        foxglove_fields({"type": "object", "properties": {"a": {"const": 1}}}, "x")
    with pytest.raises(Refused, match="contentEncoding"):
        s = {"type": "object", "properties": {"a": {"type": "string", "contentEncoding": "hex"}}}
        foxglove_fields(s, "x")
    assert foxglove_fields(LOG_SCHEMA, "foxglove.Log")["foxglove.Log.timestamp"] == ["sec", "nsec"]


def test_block_schemas_name_every_object_property() -> None:
    fields = foxglove_fields(RAW_SCHEMA, "pacc.CanFrames")
    assert fields["pacc.CanFrames.dtypes"] == list(RAW_COLUMNS)
    assert "ragged" in fields["pacc.CanFrames"]
    assert "ragged" not in block_schema("x", "y", {"t_s": ("<f8", "s")})["properties"]


def test_every_json_channel_of_a_recording_opens_in_foxglove(tmp_path: Path) -> None:
    from pacc.study.drive import DriveConfig, predefined_table, run_drive  # noqa: PLC0415
    from sim_bus.drivers import BUILTIN_DRIVERS  # noqa: PLC0415

    driver = BUILTIN_DRIVERS["d2"]
    cfg = DriveConfig(scenario="B", driver_id="d2", controller="predefined", seed=1, duration_s=3)
    run_drive(cfg, driver, predefined_table(driver), can_log=tmp_path / "d.mcap")
    with (tmp_path / "d.mcap").open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    json_schemas = [s for s in summary.schemas.values() if s.encoding == "jsonschema"]
    assert {s.name for s in json_schemas} == {"pacc.CanFrames", "foxglove.Log"}
    for s in json_schemas:
        foxglove_fields(json.loads(s.data), s.name)


LAYOUT = Path(__file__).parents[2] / "docs" / "foxglove-layout.json"
#: the app's panel types the layout uses, and the keys each path of theirs needs
PANEL_PATH_KEYS = {
    "Plot": {"value", "enabled", "timestampMethod"},
    "StateTransitions": {"value", "timestampMethod"},
    "RosOut": set(),
}


def leaves(node: str | dict[str, Any]) -> list[str]:
    """The panel ids of a layout tree, left to right."""
    if isinstance(node, str):
        return [node]
    assert node["direction"] in ("row", "column") and 0 < node["splitPercentage"] < 100
    return leaves(node["first"]) + leaves(node["second"])


def test_the_layout_is_a_tree_of_its_panels() -> None:
    layout = json.loads(LAYOUT.read_text())
    ids = leaves(layout["layout"])
    assert sorted(ids) == sorted(layout["configById"])
    for panel_id, config in layout["configById"].items():
        kind, _, _ = panel_id.partition("!")
        assert kind in PANEL_PATH_KEYS, panel_id
        assert config["foxglovePanelTitle"] and "title" not in config, panel_id
        for path in config.get("paths", []):
            assert PANEL_PATH_KEYS[kind] <= path.keys(), (panel_id, path)
            assert path["timestampMethod"] in ("receiveTime", "headerStamp")
    assert layout["configById"]["RosOut!events"]["topicToRender"] == "/ecu/events"
