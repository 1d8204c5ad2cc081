"""Reads every Parquet file of an impactmc run folder with pyarrow, DuckDB and
polars, and checks each reader against the run: schema, row counts, and one
value printed by the run. Called by tests/readers.rs.

usage: check_outputs.py RUN_DIR EXPECTED_JSON
EXPECTED_JSON: {"files": {name: {"rows": n or null (readers must agree), "columns": [...]}},
                "value": {"file": ..., "column": ..., "where": {col: val}, "equals": x}}
"""
import json
import sys

import duckdb
import polars as pl
import pyarrow.parquet as pq


def main() -> int:
    run_dir, expected_path = sys.argv[1], sys.argv[2]
    expected = json.load(open(expected_path))
    problems = []
    for name, want in expected["files"].items():
        path = f"{run_dir}/{name}"
        table = pq.read_table(path)
        frame = pl.read_parquet(path)
        con = duckdb.connect()
        rows_duck = con.execute(f"SELECT count(*) FROM read_parquet('{path}')").fetchone()[0]
        cols_duck = [d[0] for d in con.execute(f"SELECT * FROM read_parquet('{path}') LIMIT 0").description]
        counts = {table.num_rows, frame.height, rows_duck}
        if len(counts) != 1 or table.num_rows == 0:
            problems.append(f"{name}: readers disagree or empty: {counts}")
        for reader, rows, cols in [
            ("pyarrow", table.num_rows, table.column_names),
            ("polars", frame.height, frame.columns),
            ("duckdb", rows_duck, cols_duck),
        ]:
            if want["rows"] is not None and rows != want["rows"]:
                problems.append(f"{name} via {reader}: {rows} rows, expected {want['rows']}")
            missing = [c for c in want["columns"] if c not in cols]
            if missing:
                problems.append(f"{name} via {reader}: missing columns {missing}")
    v = expected["value"]
    path = f"{run_dir}/{v['file']}"
    where = " AND ".join(f'"{k}" = \'{val}\'' for k, val in v["where"].items())
    got = {
        "duckdb": duckdb.connect().execute(
            f"SELECT {v['column']} FROM read_parquet('{path}') WHERE {where}"
        ).fetchone()[0],
        "polars": pl.read_parquet(path)
        .filter(pl.all_horizontal([pl.col(k) == val for k, val in v["where"].items()]))
        .get_column(v["column"])
        .item(),
    }
    t = pq.read_table(path).to_pylist()
    match = [r for r in t if all(r[k] == val for k, val in v["where"].items())]
    got["pyarrow"] = match[0][v["column"]] if len(match) == 1 else None
    for reader, x in got.items():
        if x != v["equals"]:
            problems.append(f"{v['file']} {v['column']} via {reader}: {x!r}, the run printed {v['equals']!r}")
    for p in problems:
        print(p)
    print(f"readers: {len(expected['files'])} files x 3 readers checked, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
