"""Outputs that never follow links: the folder lock, the writers, a run's CSV, a fleet's folder."""

from __future__ import annotations

import os

import pytest
from cli_fixtures import run

from motorid.errors import OutputError
from motorid.outputs import LOCK_NAME, FolderLock, create_in_place, write_file


@pytest.fixture
def victim(tmp_path):
    """A file outside the output folder, which a link inside it points at."""
    outside = tmp_path / "outside"
    outside.mkdir()
    path = outside / "victim.txt"
    path.write_text("precious\n")
    return path


@pytest.fixture
def record(tmp_path, capsys):
    path = tmp_path / "rec.csv"
    assert run(capsys, "simulate", "--out", str(path), "--duration", "10")[0] == 0
    return path


def test_a_lock_file_linked_elsewhere_is_refused_and_its_target_kept(tmp_path, victim):
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).symlink_to(victim)
    with pytest.raises(OutputError, match=r"the lock file .*\.motorid\.lock is a symbolic link"):
        FolderLock(out).acquire()
    assert victim.read_text() == "precious\n"


def test_a_dangling_lock_link_creates_nothing(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    target = tmp_path / "created-by-the-lock"
    (out / LOCK_NAME).symlink_to(target)
    with pytest.raises(OutputError, match="is a symbolic link"):
        FolderLock(out).acquire()
    assert not os.path.lexists(target)


def test_a_lock_file_that_is_a_fifo_is_refused_without_hanging(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / LOCK_NAME)
    with pytest.raises(OutputError, match="is not a regular file"):
        FolderLock(out).acquire()


def test_identify_into_a_folder_whose_lock_is_a_link_changes_nothing(tmp_path, victim, record, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).symlink_to(victim)
    code, _, err = run(capsys, "identify", str(record), "--estimator", "arx-rls", "--out", str(out))
    assert code == 2
    assert err.strip().splitlines() == [
        f"motorid identify: error: --out {out}: the lock file {out / LOCK_NAME} is a symbolic link; "
        "it was left as it is; remove it, or choose another folder"
    ]
    assert victim.read_text() == "precious\n"
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]


def test_fleet_into_a_folder_whose_lock_is_a_link_changes_nothing(tmp_path, victim, capsys):
    out = tmp_path / "records"
    out.mkdir()
    (out / LOCK_NAME).symlink_to(victim)
    code, _, err = run(capsys, "fleet", "generate", "--out", str(out), "--drives", "1", "--days", "1")
    assert code == 2
    assert "is a symbolic link" in err
    assert victim.read_text() == "precious\n"
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]


@pytest.mark.parametrize("overwrite", [False, True])
def test_write_file_replaces_or_refuses_a_link_and_never_writes_through_it(tmp_path, victim, overwrite):
    link = tmp_path / "table.csv"
    link.symlink_to(victim)
    if overwrite:
        write_file(link, lambda fh: fh.write("new\n"), overwrite=True)
        assert not link.is_symlink() and link.read_text() == "new\n"
    else:
        with pytest.raises(OutputError, match="the file exists"):
            write_file(link, lambda fh: fh.write("new\n"))
        assert link.is_symlink()
    assert victim.read_text() == "precious\n"


def test_create_in_place_replaces_a_dangling_link_without_creating_its_target(tmp_path):
    link = tmp_path / "run.csv"
    target = tmp_path / "elsewhere.csv"
    link.symlink_to(target)
    with pytest.raises(OutputError, match="the file exists"):
        create_in_place(link)
    fd = create_in_place(link, overwrite=True)
    os.write(fd, b"t\n")
    os.close(fd)
    assert not link.is_symlink() and link.read_text() == "t\n"
    assert not os.path.lexists(target)


def test_run_with_overwrite_replaces_a_link_at_out(tmp_path, victim, capsys):
    out = tmp_path / "run.csv"
    out.symlink_to(victim)
    argv = ("run", "--estimator", "arx-rls", "--duration", "2", "--out", str(out), "--overwrite")
    assert run(capsys, *argv)[0] == 0
    assert victim.read_text() == "precious\n"
    assert not out.is_symlink() and out.read_text().splitlines()[1].startswith(
        "t,seq,u,y"
    )  # after the attributes


def test_control_with_overwrite_replaces_a_link_at_out(tmp_path, victim, capsys):
    from motorid.diagnose import diagnose
    from motorid.drive import paper_rig
    from motorid.signals import two_sine_signal

    rig = paper_rig()
    _, u = two_sine_signal(duration=60.0, dt=rig.dt, seed=0)
    design = tmp_path / "drive.json"
    diagnose(rig.simulate(u, seed=1)).model.save(design)
    out = tmp_path / "loop.csv"
    out.symlink_to(victim)
    argv = ("control", "--design", str(design), "--duration", "2", "--out", str(out), "--overwrite")
    code, _, err = run(capsys, *argv)
    assert code == 0, err
    assert victim.read_text() == "precious\n"
    assert not out.is_symlink() and out.read_text().startswith("# motorid-record ")


# -- tables a spreadsheet opens ------------------------------------------------------------------------
def test_results_csv_escapes_formulas_from_data_and_keeps_negative_numbers(tmp_path):
    import pandas as pd

    from motorid.fleet.results import ResultsStore

    store = ResultsStore(tmp_path)
    store.append([
        {"record": "a.csv", "drive": '=HYPERLINK("http://x","y")', "status": "ok", "params.coulomb": -1.5,
         "note": "-1.25"},
        {"record": "b.csv", "drive": "@SUM(A1:A9)", "status": "failed", "params.coulomb": 2.0,
         "note": "+cmd|' /C calc'!A0", "error": "x" * 20_000_000},
        {"record": "c.csv", "drive": "drive-01", "status": "ok", "params.coulomb": -0.0, "note": "\t=1+1"},
    ])  # fmt: skip
    path = store.write_csv()
    assert path.stat().st_size < 10_000  # the 20 MB error is cut
    table = pd.read_csv(path)
    assert table["drive"].tolist() == ['\'=HYPERLINK("http://x","y")', "'@SUM(A1:A9)", "drive-01"]
    assert table["params.coulomb"].tolist() == [-1.5, 2.0, -0.0]
    assert table["note"].tolist() == ["-1.25", "'+cmd|' /C calc'!A0", "'\t=1+1"]
    assert table["error"][1] == "x" * 80 + "... (20,000,000 characters)"
    assert store.rows()["drive"][0] == '=HYPERLINK("http://x","y")'  # the Parquet parts keep the value


def test_quoted_cuts_a_long_value_and_says_how_long_it_was():
    from motorid.errors import quoted

    assert quoted("abc") == "'abc'"
    assert quoted("y" * 10**8) == repr("y" * 80) + "... (100,000,000 characters)"
    assert quoted(list(range(1000))).endswith("... (4,890 characters)")
