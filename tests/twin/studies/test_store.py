"""A study folder on disk (twin/studies/store.py): rows, duplicates, compaction, the lock."""
from __future__ import annotations

import pyarrow.parquet as pq
import pytest

from tests.twin.studies.builders import TINY, made_row, tiny_results_folder
from rfp_twin.twin.studies import (COMPACT_PREFIX, SCHEMA, StudyError, compact_results, done_keys,
                          parse_study, read_results, results_dir, write_row)
from rfp_twin.twin.studies.store import WriterLock, write_study_copy


@pytest.fixture()
def written(tmp_path):
    """A study folder with the 8 TINY trials written as rows."""
    study, results, trials = tiny_results_folder(tmp_path)
    for t in trials:
        write_row(results, made_row(study, t, efficiency=0.5 + 0.01 * t.index))
    return tmp_path / "out", trials


def test_rows_are_one_file_each_and_read_back_with_the_schema(written):
    out, trials = written
    results = results_dir(out)
    assert results_dir(results) == results       # the results folder itself is accepted
    files = sorted(results.glob("part-*.parquet"))
    assert len(files) == 8 and not list(results.glob(".*"))
    assert {f.name for f in files} == {f"part-{t.key}.parquet" for t in trials}
    table = read_results(out)
    assert table.schema.equals(SCHEMA) and table.num_rows == 8
    assert done_keys(out) == {t.key for t in trials}
    assert read_results(out / "missing").num_rows == 0 and done_keys(out / "missing") == set()


def test_duplicates_are_read_once_and_compaction_merges(written):
    out, trials = written
    results = results_dir(out)
    # a compaction killed between its rename and its deletes leaves rows twice: reads dedupe
    first = sorted(results.glob("part-*.parquet"))[0]
    (results / f"{COMPACT_PREFIX}x.parquet").write_bytes(first.read_bytes())
    assert read_results(out).num_rows == 8 and len(done_keys(out)) == 8
    before = {r["key"]: r["efficiency"] for r in read_results(out).to_pylist()}
    merged = compact_results(out)
    assert [p.name for p in results.glob("*.parquet")] == [merged.name]
    assert pq.read_table(merged).num_rows == 8
    assert {r["key"]: r["efficiency"] for r in read_results(out).to_pylist()} == before
    assert compact_results(out) is None                  # one file: nothing to merge


def test_a_damaged_file_is_set_aside(written):
    out, trials = written
    results = results_dir(out)
    bad = results / "part-damaged.parquet"
    bad.write_bytes(b"PAR1 not a parquet file")
    assert read_results(out).num_rows == 8
    assert not bad.exists() and (results / ".damaged-part-damaged.parquet").is_file()


def test_one_writer_per_study_folder(written):
    out, _ = written
    with WriterLock(results_dir(out)):
        with pytest.raises(StudyError, match="another run of this study is writing here"):
            with WriterLock(results_dir(out)):
                pass
    with WriterLock(results_dir(out)):                   # released
        pass


def test_study_copy_is_the_definition(tmp_path):
    study = parse_study(TINY)
    write_study_copy(tmp_path, study)
    assert (tmp_path / "study.toml").read_text() == TINY and not list(tmp_path.glob(".*"))
