"""``pacc plot LOG --plotjuggler LAYOUT.xml``: a PlotJuggler layout that opens the recording.

The layout is checked against the recording as PlotJuggler reads it: its curves are
``<topic>/<field>`` of the recording's protobuf channels (read here with the mcap and protobuf
libraries, not pacc's reader), its data file resolves to the recording, and its topics are the
protobuf channels. ``docs/plotjuggler-layout.xml`` is what the command writes for a drive's
``drive.mcap`` beside it. (PlotJuggler itself drew both tabs from a drive's recording; the
screenshot, docs/plotjuggler.png, and how it was taken are in docs/logs.md.)
"""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree as ET

import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from pacc.commands.export import main as export_main
from pacc.commands.plot import main as plot_main
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS

DOC = Path(__file__).resolve().parents[2] / "docs" / "plotjuggler-layout.xml"


def _protobuf_fields(path: Path) -> dict[str, set[str]]:
    """Topic -> field names of the first message of each protobuf channel."""
    fields: dict[str, set[str]] = {}
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None
        protobuf = [c.topic for c in summary.channels.values() if c.message_encoding == "protobuf"]
        for _schema, channel, _msg, proto in reader.iter_decoded_messages(topics=protobuf):
            if channel.topic not in fields:
                fields[channel.topic] = {f.name for f in proto.DESCRIPTOR.fields}
    return fields


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("pj")
    driver = BUILTIN_DRIVERS["d3"]
    cfg = DriveConfig(scenario="B", driver_id="d3", controller="predefined", seed=1, duration_s=5)
    run_drive(cfg, driver, predefined_table(driver), can_log=folder / "drive.mcap")
    return folder / "drive.mcap"


def test_the_layout_names_the_recordings_fields_and_opens_it(
    drive: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layout = tmp_path / "views" / "drive.xml"
    layout.parent.mkdir()
    assert plot_main([str(drive), "--plotjuggler", str(layout)]) == 0
    assert f"plotjuggler -l {layout}" in capsys.readouterr().out
    root = ET.parse(layout).getroot()
    fields = _protobuf_fields(drive)
    curves = [c.get("name", "") for c in root.iter("curve")]
    assert len(curves) == 18  # both tabs, every curve: a drive recording has them all
    for name in curves:
        topic, _, field = name.rpartition("/")
        assert field in fields[topic], name
    [info] = root.iter("fileInfo")
    assert (layout.parent / str(info.get("filename"))).resolve() == drive.resolve()
    [params] = root.iter("parameters")
    assert set(str(params.get("selected_topics")).split(";")) == set(fields)
    assert [t.get("tab_name") for t in root.iter("Tab")] == ["pacc drive", "CAN signals"]


def test_the_shipped_layout_is_the_commands(
    drive: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = drive.parent / "plotjuggler-layout.xml"
    assert plot_main([str(drive), "--plotjuggler", str(out)]) == 0
    assert out.read_text(encoding="utf-8") == DOC.read_text(encoding="utf-8")


def test_a_layout_needs_an_mcap_recording(
    drive: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blf = tmp_path / "drive.blf"
    assert export_main([str(drive), str(blf)]) == 0
    capsys.readouterr()
    assert plot_main([str(blf), "--plotjuggler", str(tmp_path / "x.xml")]) == 2
    err = capsys.readouterr().err
    assert "PlotJuggler opens pacc's .mcap recordings" in err and "pacc export" in err
    assert not (tmp_path / "x.xml").exists()
    with pytest.raises(SystemExit) as stop:
        plot_main([str(drive)])
    assert stop.value.code == 2


def test_no_output_overwrites_the_recording_or_another_output(
    drive: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = drive.read_bytes()
    for argv in (
        [str(drive), "--plotjuggler", str(drive)],
        [str(drive), "-o", str(drive)],
        [str(drive), "--plotjuggler", str(tmp_path / "v.png"), "-o", str(tmp_path / "v")],
    ):
        with pytest.raises(SystemExit) as stop:
            plot_main(argv)
        assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--plotjuggler " + str(drive) + " is LOG itself" in err
    assert "-o " + str(drive) + ": pacc plot writes a PNG" in err
    assert "--out and --plotjuggler name the same file" in err
    assert drive.read_bytes() == before and not list(tmp_path.iterdir())
