"""A finished study as one file (twin/studies/store.py consolidate_results): verified before
the per-trial files go, older rows (fewer columns) read with nulls, a kill leaves no loss."""
from __future__ import annotations

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from tests.twin.studies.builders import made_row, tiny_results_folder
from rfp_twin.twin.studies import (CONSOLIDATED, SCHEMA, StudyError, consolidate_results,
                                   done_keys, read_results, results_dir, write_row)
from rfp_twin.twin.studies import store


@pytest.fixture()
def parts(tmp_path):
    """The 8 TINY trials as per-trial files; the first written with an older, narrower schema."""
    study, results, trials = tiny_results_folder(tmp_path)
    for t in trials[1:]:
        write_row(results, {**made_row(study, t, kept=0.9), **t.point.ids()})
    old = made_row(study, trials[0])
    old_cols = SCHEMA.names[:SCHEMA.get_field_index("finished_utc") + 1]
    table = pa.Table.from_pylist([{k: old.get(k) for k in old_cols}],
                                 schema=pa.schema([SCHEMA.field(c) for c in old_cols]))
    pq.write_table(table, results / f"part-{trials[0].key}.parquet")
    return tmp_path / "out", trials


def test_consolidation_merges_verifies_and_removes_the_parts(parts):
    out, trials = parts
    results = results_dir(out)
    before = {r["key"]: r for r in read_results(out).to_pylist()}
    assert len(before) == 8 and before[trials[0].key]["kept"] is None   # old row: null
    merged = consolidate_results(out)
    assert merged == results / CONSOLIDATED
    assert [p.name for p in results.iterdir() if p.suffix == ".parquet"] == [CONSOLIDATED]
    meta = pq.ParquetFile(merged)
    assert meta.metadata.num_rows == 8 and meta.schema_arrow.equals(SCHEMA)
    # one call reads the folder (pyarrow, as pandas.read_parquet(folder) does)
    folder = pq.read_table(results)
    assert folder.num_rows == 8 and sorted(folder.column("key").to_pylist()) == sorted(before)
    after = {r["key"]: r for r in read_results(out).to_pylist()}
    assert after == before and done_keys(out) == set(before)
    assert consolidate_results(out) == merged          # already one file: left alone


def test_a_merged_file_that_does_not_read_back_keeps_the_parts(parts, monkeypatch):
    out, _ = parts
    results = results_dir(out)
    names = sorted(p.name for p in results.glob("*.parquet"))

    real = pq.ParquetFile

    class Short:                                       # the file reads back one row short
        def __init__(self, path):
            self.metadata = type("M", (), {"num_rows": real(path).metadata.num_rows - 1})

    monkeypatch.setattr(store.pq, "ParquetFile", Short)
    with pytest.raises(StudyError, match="the per-trial files are kept"):
        consolidate_results(out)
    assert sorted(p.name for p in results.glob("*.parquet")) == names
    assert not list(results.glob(".*.tmp")) and not (results / CONSOLIDATED).exists()


def test_a_kill_between_rename_and_deletes_loses_and_doubles_nothing(parts):
    out, trials = parts
    results = results_dir(out)
    # as if killed right after the rename: the merged file and every part file
    store.write_verified(results / CONSOLIDATED, read_results(out))
    assert len(list(results.glob("*.parquet"))) == 9
    assert read_results(out).num_rows == 8 and len(done_keys(out)) == 8
    consolidate_results(out)
    assert [p.name for p in results.glob("*.parquet")] == [CONSOLIDATED]
    assert pq.read_table(results).num_rows == 8
