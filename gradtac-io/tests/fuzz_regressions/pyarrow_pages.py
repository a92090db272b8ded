"""Write the reference Parquet files of `parquet_check_passes_pyarrow_files`
(gradtac-io/tests/fuzz_regressions.rs): page headers from another writer (Arrow C++ through
pyarrow; written with pyarrow 26.0.1): data pages v1 and v2, dictionary pages, page CRCs,
page statistics, nulls, a list column, several pages per column chunk.

    python3 pyarrow_pages.py   # in this directory
"""
import pyarrow as pa
import pyarrow.parquet as pq

n = 800
table = pa.table({
    "time_ns": pa.array(range(0, n * 1000, 1000), pa.int64()),
    "value": pa.array([i * 0.5 for i in range(n)], pa.float64()),
    "sensor": pa.array([f"sensor-{i % 5}" for i in range(n)]).dictionary_encode(),
    "note": pa.array([("x" * (i % 40)) if i % 7 else None for i in range(n)]),
    "taxels": pa.array([[float(j) for j in range(i % 4)] for i in range(n)], pa.list_(pa.float32())),
    "flag": pa.array([i % 3 == 0 for i in range(n)]),
})
for version in ["1.0", "2.0"]:
    pq.write_table(
        table,
        f"pyarrow_pages_v{version[0]}.parquet",
        data_page_version=version,
        compression="zstd",
        write_page_checksum=True,
        write_statistics=True,
        data_page_size=256,
        write_batch_size=64,
        row_group_size=400,
    )
