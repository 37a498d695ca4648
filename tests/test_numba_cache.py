"""Stale Numba caches are dropped when the sources they inline change (mckibben._numba_cache)."""

from __future__ import annotations

from mckibben._numba_cache import STAMP, drop_stale, fingerprint


def _package(tmp_path):
    pkg = tmp_path / "mckibben"
    for sub in ("plant", "control"):
        (pkg / sub / "__pycache__").mkdir(parents=True)
        (pkg / sub / "a.py").write_text("X = 1\n")
        (pkg / sub / "__pycache__" / "a.f-1.py311.nbi").write_bytes(b"index")
        (pkg / sub / "__pycache__" / "a.f-1.py311.1.nbc").write_bytes(b"code")
    return pkg


def test_caches_survive_while_the_sources_stay_the_same(tmp_path):
    pkg = _package(tmp_path)
    assert drop_stale(pkg)  # no stamp yet: whatever is cached may be stale
    (pkg / "plant" / "__pycache__" / "b.g-2.py311.nbi").write_bytes(b"fresh")
    assert not drop_stale(pkg)
    assert (pkg / "plant" / "__pycache__" / "b.g-2.py311.nbi").exists()
    assert (pkg / "__pycache__" / STAMP).read_text() == fingerprint(pkg)


def test_an_edit_in_another_module_drops_every_cache(tmp_path):
    pkg = _package(tmp_path)
    drop_stale(pkg)
    cached = pkg / "plant" / "__pycache__" / "sim.run-9.py311.1.nbc"
    cached.write_bytes(b"compiled against the old column layout")
    (pkg / "control" / "a.py").write_text("X = 2\n")  # the file the cache inlines, not its own
    assert drop_stale(pkg)
    assert not cached.exists()
    assert not drop_stale(pkg)


def test_a_missing_package_or_a_garbled_stamp_never_raises(tmp_path):
    assert drop_stale(tmp_path / "nowhere") in (True, False)
    pkg = _package(tmp_path)
    drop_stale(pkg)
    (pkg / "__pycache__" / STAMP).write_bytes(b"\xff\xfe not text")
    assert drop_stale(pkg) in (True, False)


def test_a_numba_cache_dir_elsewhere_is_left_alone(tmp_path, monkeypatch):
    pkg = _package(tmp_path)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert not drop_stale(pkg)
    assert not (pkg / "__pycache__" / STAMP).exists()  # no stamp: nothing claimed as checked
