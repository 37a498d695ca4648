"""``mckibben reproduce`` writes a report that says where it came from, with no absolute path."""

from __future__ import annotations

import json
import pathlib
import re

import pytest

from mckibben.cli import main


@pytest.mark.slow
def test_reproduce_names_version_time_arguments_and_input_hashes(tmp_path, monkeypatch):
    import mckibben

    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "--out", "rep"]) == 0
    summary = json.loads((tmp_path / "rep" / "summary.json").read_text(encoding="utf-8"))
    html = (tmp_path / "rep" / "index.html").read_text(encoding="utf-8")
    prov = summary["provenance"]
    assert prov["mckibben_version"] == mckibben.__version__
    assert re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", prov["created_utc"])
    assert prov["call"] == "mckibben.report.reproduce" and prov["arguments"]["out"] == "rep"
    assert prov["inputs_sha256"] and all(re.fullmatch(r"[0-9a-f]{64}", h) for h in prov["inputs_sha256"].values())
    from PIL import Image

    pngs = sorted((tmp_path / "rep").glob("*.png"))
    assert pngs
    for png in pngs:  # each figure carries the report's provenance, as the HTML and JSON do
        assert json.loads(Image.open(png).text["Description"]) == json.loads(json.dumps(prov, sort_keys=True))
    for text in (html, json.dumps(summary)):
        assert mckibben.__version__ in text and prov["created_utc"] in text
        assert next(iter(prov["inputs_sha256"].values())) in text
        assert str(tmp_path) not in text and "/tmp/" not in text and "/home/" not in text
        # nor where the package is installed (fitted models cite the files they were fitted to)
        assert str(pathlib.Path(mckibben.__file__).resolve().parent) not in text


def _provenance_of(path: pathlib.Path) -> dict:
    """The provenance in a figure's metadata, read back with the format's own reader."""
    if path.suffix == ".png":
        from PIL import Image

        return json.loads(Image.open(path).text["Description"])
    if path.suffix == ".svg":
        import xml.etree.ElementTree as ET

        desc = ET.parse(path).getroot().find(".//{http://purl.org/dc/elements/1.1/}description")
        return json.loads(desc.text)
    raw = path.read_bytes()  # PDF: the document information's Subject, a literal string
    m = re.search(rb"/Subject \((.*?)\) */", raw, re.S) or re.search(rb"/Subject \((.*?)\)\n", raw, re.S)
    return json.loads(re.sub(rb"\\(.)", rb"\1", m.group(1)).decode())


def test_figures_and_csv_tables_say_where_they_came_from(tmp_path, monkeypatch):
    """PNG, PDF and SVG figures hold the call, its arguments, the version, the UTC time and the
    command line in their metadata; a CSV table has them in a sidecar (a comment line would trip
    other CSV readers), Parquet in its schema; an absolute path typed on the line is kept as a bare name."""
    import mckibben
    from mckibben.results import read_provenance

    monkeypatch.chdir(tmp_path)
    for fmt in ("png", "pdf", "svg"):
        assert main(["simulate", "open-loop", "--valve", "117", "--plot", str(tmp_path / f"o.{fmt}")]) == 0
        prov = _provenance_of(tmp_path / f"o.{fmt}")
        assert prov["call"] == "mckibben.experiments.open_loop" and prov["arguments"]["valve_pwm"] == 117
        assert prov["mckibben_version"] == mckibben.__version__
        assert re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", prov["created_utc"])
        assert prov["command"] == f"mckibben simulate open-loop --valve 117 --plot o.{fmt}"
    assert main(["control", "step", "--out", "s.csv"]) == 0
    side = json.loads((tmp_path / "s.csv.provenance.json").read_text(encoding="utf-8"))
    assert side == read_provenance(tmp_path / "s.csv")
    assert side["call"] == "mckibben.experiments.step_response" and side["command"] == "mckibben control step --out s.csv"
    assert (tmp_path / "s.csv").read_text(encoding="utf-8").startswith("time_s,")  # the table itself unchanged
    assert main(["control", "step", "--out", "s.parquet"]) == 0
    assert read_provenance(tmp_path / "s.parquet")["command"] == "mckibben control step --out s.parquet"
    # in a notebook there is no command line: the call and its arguments say it
    mckibben.step_response().to_file(tmp_path / "n.csv")
    assert "command" not in read_provenance(tmp_path / "n.csv")
