"""Reads a samples.parquet with pyarrow, DuckDB and polars, and checks every
column against the values the run's kernel computed for each sample (given by
the caller, computed without the writer): the column's type in each reader,
and every value exactly; and that the key-value metadata gives every float
column a unit. The orientation quaternion and Bryan angles, which the writer
derives from the rotation matrix, are checked against that matrix. Called by
tests/readers.rs.

usage: check_values.py SAMPLES_PARQUET EXPECTED_JSON
EXPECTED_JSON: {"columns": {name: {"type": "float32" | "float64" | "uint8" |
                                            "uint16" | "uint32" | "uint64" |
                                            "bool",
                                   "values": [...]}},
                "rotation": [[r00, r01, ..., r22], ...]  (row-major, per row;
                             present when the file has the quaternion
                             and the Bryan angles),
                "tolerance": max |R(q) - R| allowed}
"""
import json
import math
import sys

import duckdb
import polars as pl
import pyarrow.parquet as pq

# The type name each reader gives a column of this type.
TYPES = {
    "float32": {"pyarrow": "float", "polars": "Float32", "duckdb": "FLOAT"},
    "float64": {"pyarrow": "double", "polars": "Float64", "duckdb": "DOUBLE"},
    "uint8": {"pyarrow": "uint8", "polars": "UInt8", "duckdb": "UTINYINT"},
    "uint16": {"pyarrow": "uint16", "polars": "UInt16", "duckdb": "USMALLINT"},
    "uint32": {"pyarrow": "uint32", "polars": "UInt32", "duckdb": "UINTEGER"},
    "uint64": {"pyarrow": "uint64", "polars": "UInt64", "duckdb": "UBIGINT"},
    "bool": {"pyarrow": "bool", "polars": "Boolean", "duckdb": "BOOLEAN"},
}
QUATERNION = ["q_w", "q_x", "q_y", "q_z"]
BRYAN = ["psi_deg", "theta_deg", "phi_deg"]


def read_all(path):
    """{reader: ({column: values}, {column: type name})}, rows in sample order."""
    table = pq.read_table(path)
    frame = pl.read_parquet(path)
    con = duckdb.connect()
    types = {r[0]: r[1] for r in con.execute(f"DESCRIBE SELECT * FROM read_parquet('{path}')").fetchall()}
    cursor = con.execute(f"SELECT * FROM read_parquet('{path}') ORDER BY sample")
    names = [d[0] for d in cursor.description]
    rows = cursor.fetchall()
    return {
        "pyarrow": (
            {n: table.column(n).to_pylist() for n in table.column_names},
            {f.name: str(f.type) for f in table.schema},
        ),
        "polars": (
            {n: frame.get_column(n).to_list() for n in frame.columns},
            {n: str(t) for n, t in frame.schema.items()},
        ),
        "duckdb": ({n: [r[i] for r in rows] for i, n in enumerate(names)}, types),
    }


def rotation_of(w, x, y, z):
    return [
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
    ]


def bryan_rotation(psi, theta, phi):
    """Rx(psi) Ry(theta) Rz(phi), angles in degrees, row-major."""
    sx, cx = math.sin(math.radians(psi)), math.cos(math.radians(psi))
    sy, cy = math.sin(math.radians(theta)), math.cos(math.radians(theta))
    sz, cz = math.sin(math.radians(phi)), math.cos(math.radians(phi))
    rx = [[1, 0, 0], [0, cx, -sx], [0, sx, cx]]
    ry = [[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]
    rz = [[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]
    mul = lambda a, b: [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    m = mul(mul(rx, ry), rz)
    return [m[i][j] for i in range(3) for j in range(3)]


def quaternion_rotation(w, x, y, z):
    """The rotation of q_w, q_x, q_y, q_z, or None where q_w < 0."""
    return rotation_of(w, x, y, z) if w >= 0 else None


def bryan_angles_rotation(psi, theta, phi):
    """The rotation of the Bryan angles, or None where one is out of range."""
    if -180 <= psi <= 180 and -90 <= theta <= 90 and -180 <= phi <= 180:
        return bryan_rotation(psi, theta, phi)
    return None


def rotation_problems(reader, cols, expected, names, rotation):
    """The columns `names`, turned into a rotation by `rotation`, against the
    kernel's rotation of each row."""
    if not all(c in cols for c in names):
        return [f"{reader}: no {names} columns"]
    worst = 0.0
    for i, r in enumerate(expected["rotation"]):
        values = [cols[c][i] for c in names]
        m = rotation(*values)
        if m is None:
            return [f"{reader}: {names} = {values} out of range in row {i}"]
        worst = max(worst, max(abs(a - b) for a, b in zip(m, r)))
    if worst > expected["tolerance"]:
        return [f"{reader}: the rotation of {names} differs from the kernel's by {worst}"]
    return []


def main() -> int:
    path, expected_path = sys.argv[1], sys.argv[2]
    expected = json.load(open(expected_path))
    want = expected["columns"]
    quaternion = QUATERNION + BRYAN if "rotation" in expected else []
    problems = []
    for reader, (cols, types) in read_all(path).items():
        extra = sorted(set(cols) - set(want) - set(quaternion))
        missing = sorted(set(want) - set(cols))
        if extra or missing:
            problems.append(f"{reader}: columns not expected {extra}, missing {missing}")
        for name, w in want.items():
            if name not in cols:
                continue
            if types[name] != TYPES[w["type"]][reader]:
                problems.append(f"{reader}: {name} is {types[name]}, expected {w['type']}")
            got = cols[name]
            if got != w["values"]:
                bad = next((i for i, (a, b) in enumerate(zip(got, w["values"])) if a != b), None)
                if bad is None:
                    problems.append(f"{reader}: {name} has {len(got)} rows, expected {len(w['values'])}")
                else:
                    problems.append(f"{reader}: {name}[{bad}] = {got[bad]!r}, the run computed {w['values'][bad]!r}")
        if quaternion:
            problems += rotation_problems(reader, cols, expected, QUATERNION, quaternion_rotation)
            problems += rotation_problems(reader, cols, expected, BRYAN, bryan_angles_rotation)
    meta = pq.read_metadata(path).metadata or {}
    units = json.loads(meta.get(b"impactmc.units", b"{}"))
    floats = [n for n, w in want.items() if w["type"].startswith("float")] + quaternion
    no_unit = [n for n in floats if not units.get(n)]
    if no_unit or sorted(units) != sorted(floats):
        problems.append(f"impactmc.units: no unit for {no_unit}; has {sorted(units)}")
    for p in problems:
        print(p)
    print(f"values: {len(want)} columns x 3 readers checked, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
