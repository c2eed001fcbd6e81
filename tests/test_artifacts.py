"""The artifact contract: round trip, validation failures, atomic writes, up-to-date checks."""

import json
import os

import numpy as np
import pandas as pd
import pytest

from pendtrack.artifacts import (
    SCHEMAS,
    Provenance,
    atomic_write,
    inputs_for,
    is_up_to_date,
    read_artifact,
    read_json_artifact,
    write_artifact,
    write_json_artifact,
)
from pendtrack.errors import ArtifactError


def angle_frame(n=5):
    return pd.DataFrame({"t": np.arange(n) / 120.0, "theta": np.linspace(0, 1, n), "ok": np.ones(n, bool)})


def test_every_schema_has_units_and_unique_columns():
    for schema in SCHEMAS.values():
        names = [c.name for c in schema.columns]
        assert len(names) == len(set(names))
        assert all(c.unit for c in schema.columns)
        assert schema.filename.endswith(".parquet") and schema.version >= 1


def test_round_trip_keeps_data_and_provenance(tmp_path):
    src = tmp_path / "in.bin"
    src.write_bytes(b"abc")
    prov = Provenance(stage="angle", config={"angle": {"rest_seconds": 2.0}}, inputs=inputs_for(src),
                      extra={"axle": [1.5, 2.5]})
    path = write_artifact(angle_frame(), tmp_path / "angle.parquet", "angle", provenance=prov)
    art = read_artifact(path, "angle")
    pd.testing.assert_frame_equal(art.data, angle_frame())
    assert art.provenance.stage == "angle"
    assert art.provenance.inputs == {"in.bin": "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"}
    assert art.provenance.extra == {"axle": [1.5, 2.5]}
    assert art.provenance.config == {"angle": {"rest_seconds": 2.0}}
    # The time is the provenance's own, stamped once: a file written a second later carries the same one as the
    # result returned beside it (a stamp taken at each write differed across a second's edge).
    assert prov.created and art.provenance.created == prov.created == prov.to_dict()["created"]


def test_columns_are_reordered_to_the_schema(tmp_path):
    df = angle_frame()[["ok", "theta", "t"]]
    path = write_artifact(df, tmp_path / "a.parquet", "angle", provenance=Provenance(stage="x"))
    assert list(read_artifact(path, "angle").data.columns) == ["t", "theta", "ok"]


@pytest.mark.parametrize(
    "mutate, fragment",
    [
        (lambda df: df.drop(columns="theta"), "missing column 'theta'"),
        (lambda df: df.assign(ok=df["ok"].astype(float)), "column 'ok' has dtype float64, expected bool"),
        (lambda df: df.assign(theta=df["theta"].astype(str)), "column 'theta'"),
        (lambda df: df.assign(extra=1.0), "column 'extra' is not in the angle schema"),
    ],
)
def test_write_rejects_schema_violations_and_writes_nothing(tmp_path, mutate, fragment):
    path = tmp_path / "angle.parquet"
    with pytest.raises(ArtifactError) as err:
        write_artifact(mutate(angle_frame()), path, "angle", provenance=Provenance(stage="x"))
    assert fragment in str(err.value) and str(path) in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_read_rejects_wrong_columns_naming_file_and_column(tmp_path):
    path = tmp_path / "angle.parquet"
    angle_frame().drop(columns="ok").to_parquet(path)  # written behind the contract's back
    with pytest.raises(ArtifactError, match=r"angle\.parquet: missing column 'ok'"):
        read_artifact(path, "angle")


def test_read_rejects_other_artifact_kind_and_garbage(tmp_path):
    path = write_artifact(angle_frame(), tmp_path / "angle.parquet", "angle", provenance=Provenance(stage="x"))
    with pytest.raises(ArtifactError, match="is a angle artifact, expected kinematics"):
        read_artifact(path, "kinematics")
    junk = tmp_path / "junk.parquet"
    junk.write_bytes(b"not parquet at all")
    with pytest.raises(ArtifactError, match="not a readable Parquet file"):
        read_artifact(junk, "angle")
    with pytest.raises(ArtifactError, match="file not found"):
        read_artifact(tmp_path / "absent.parquet", "angle")


def test_interrupted_write_leaves_no_file_and_keeps_the_old_one(tmp_path):
    path = tmp_path / "out.txt"
    path.write_text("old")

    def crash(tmp):
        tmp.write_text("half")
        raise KeyboardInterrupt  # a crash or Ctrl-C mid-write

    with pytest.raises(KeyboardInterrupt):
        atomic_write(path, crash)
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]

    fresh = tmp_path / "fresh.parquet"
    with pytest.raises(KeyboardInterrupt):
        atomic_write(fresh, crash)
    assert not fresh.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_killed_writer_leaves_only_a_hidden_tmp_that_is_never_read(tmp_path):
    # A SIGKILL cannot run cleanup: simulate its leftovers and check they are not the artifact.
    leftover = tmp_path / ".angle.parquet.abc.tmp"
    leftover.write_bytes(b"partial")
    assert not is_up_to_date(tmp_path / "angle.parquet", "angle", inputs={}, config={})


def test_up_to_date_follows_inputs_and_config(tmp_path):
    prov = Provenance(stage="angle", config={"a": {"k": 1}}, inputs={"x.parquet": "h1"})
    path = write_artifact(angle_frame(), tmp_path / "angle.parquet", "angle", provenance=prov)
    assert is_up_to_date(path, "angle", inputs={"x.parquet": "h1"}, config={"a": {"k": 1}})
    assert not is_up_to_date(path, "angle", inputs={"x.parquet": "h2"}, config={"a": {"k": 1}})
    assert not is_up_to_date(path, "angle", inputs={"x.parquet": "h1"}, config={"a": {"k": 2}})
    assert not is_up_to_date(tmp_path / "nothing.parquet", "angle", inputs={}, config={})


def test_json_artifact_round_trip_and_required_keys(tmp_path):
    path = tmp_path / "fit.json"
    write_json_artifact({"model": "classic", "n": np.int64(3)}, path, required=("model",),
                        provenance=Provenance(stage="fit", inputs={"k": "h"}))
    data = read_json_artifact(path, required=("model", "n"))
    assert data["n"] == 3 and data["provenance"]["stage"] == "fit"
    assert is_up_to_date(path, "fit", inputs={"k": "h"}, config={})
    with pytest.raises(ArtifactError, match="missing key 'rms'"):
        write_json_artifact({"model": "x"}, tmp_path / "f2.json", required=("model", "rms"),
                            provenance=Provenance(stage="fit"))
    assert not (tmp_path / "f2.json").exists()
    (tmp_path / "bad.json").write_text("{nope")
    with pytest.raises(ArtifactError, match="not valid JSON"):
        read_json_artifact(tmp_path / "bad.json", required=())
    assert json.loads(path.read_text())["model"] == "classic"
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())
    assert os.access(path, os.R_OK)


def test_pattern_columns_are_admitted_and_typed(tmp_path):
    from dataclasses import replace

    from pendtrack.artifacts import ColumnPattern, validate_frame

    schema = replace(SCHEMAS["angle"], patterns=(ColumnPattern(r"p__\w+", "float64", "as named", "param"),))
    df = angle_frame().assign(p__Omega0=1.0)
    assert list(validate_frame(df, schema, "x").columns) == ["t", "theta", "ok", "p__Omega0"]
    with pytest.raises(ArtifactError, match="column 'p__C0' has dtype"):
        validate_frame(df.assign(p__C0="a"), schema, "x")
    with pytest.raises(ArtifactError, match="column 'q' is not in the angle schema"):
        validate_frame(df.assign(q=1.0), schema, "x")
