"""--format parquet: trajectory.parquet and results.parquet hold the columns and values of the
CSV files (read with pyarrow, compared column by column)."""

import numpy as np
import pytest

from conftest import EXAMPLE1, GRID

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")
pcsv = pytest.importorskip("pyarrow.csv")


def same_columns(parquet_table, csv_table):
    assert parquet_table.column_names == csv_table.column_names
    assert parquet_table.num_rows == csv_table.num_rows
    for name in parquet_table.column_names:
        a = parquet_table[name]
        b = csv_table[name]
        if pa.types.is_floating(a.type):
            x = a.to_numpy(zero_copy_only=False)
            y = b.cast(pa.float64()).to_numpy(zero_copy_only=False).astype(x.dtype)
            assert np.array_equal(x, y, equal_nan=True), name
        else:
            assert a.to_pylist() == b.to_pylist(), name


@pytest.mark.parametrize("scenario", ["example1.toml", "example2.toml"])
def test_trajectory_parquet_equals_trajectory_csv(host_sim, tmp_path, scenario):
    path = EXAMPLE1.parent / scenario
    host_sim("run", path, "--out", tmp_path / "csv", "--no-plots", "-q", "--set", "simulation.t_end=1")
    host_sim("run", path, "--out", tmp_path / "pq", "--no-plots", "-q", "--set", "simulation.t_end=1", "--format", "parquet")
    assert not (tmp_path / "pq" / "trajectory.csv").exists()
    t = pq.read_table(tmp_path / "pq" / "trajectory.parquet")
    c = pcsv.read_csv(tmp_path / "csv" / "trajectory.csv")
    same_columns(t, c)
    assert t.schema.field("t").type == pa.float64() and t.schema.field("u1_1").type == pa.float32()
    assert (tmp_path / "pq" / "summary.json").read_bytes() == (tmp_path / "csv" / "summary.json").read_bytes()


def test_results_parquet_equals_results_csv(host_sim, tmp_path):
    host_sim("sweep", GRID, "--out", tmp_path, "-q", "--format", "parquet")
    t = pq.read_table(tmp_path / "results.parquet")
    opts = pcsv.ConvertOptions(strings_can_be_null=True)
    c = pcsv.read_csv(tmp_path / "results.csv", convert_options=opts)
    same_columns(t, c)
    assert t["status"].to_pylist().count("invalid") == 2
    assert t["divergence_time"].null_count == c["divergence_time"].null_count


def test_merge_writes_results_parquet_of_the_merged_shards(host_sim, tmp_path):
    for k in (1, 2):
        host_sim("sweep", GRID, "--out", tmp_path / f"s{k}", "--shard", f"{k}/2", "-q")
    host_sim("merge", tmp_path / "s1", tmp_path / "s2", "--out", tmp_path / "m", "--format", "parquet")
    host_sim("sweep", GRID, "--out", tmp_path / "all", "-q", "--format", "parquet")
    assert pq.read_table(tmp_path / "m" / "results.parquet").equals(pq.read_table(tmp_path / "all" / "results.parquet"))
