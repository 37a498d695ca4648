"""``mckibben reproduce`` writes a report that says where it came from, with no absolute path."""

from __future__ import annotations

import json
import pathlib
import re

from mckibben.cli import main


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
    for text in (html, json.dumps(summary)):
        assert mckibben.__version__ in text and prov["created_utc"] in text
        assert next(iter(prov["inputs_sha256"].values())) in text
        assert str(tmp_path) not in text and "/tmp/" not in text and "/home/" not in text
        # nor where the package is installed (fitted models cite the files they were fitted to)
        assert str(pathlib.Path(mckibben.__file__).resolve().parent) not in text
