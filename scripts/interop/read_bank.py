#!/usr/bin/env python3
"""Opens a wheelflat bank with pyarrow, the way an auditor would, and prints what it finds:
row and column counts, the column names, and the wheelflat metadata (JSON under the
`wheelflat.bank` key). Exits non-zero if anything is inconsistent.

    python3 scripts/interop/read_bank.py BANK_DIR
"""
import hashlib
import json
import pathlib
import sys

import pyarrow.dataset as ds
import pyarrow.parquet as pq


def resolve(bank):
    """CURRENT's version directory and the manifest SHA-256 it states (docs/bank.md)."""
    current = bank / "CURRENT"
    if not current.exists():
        return bank, None
    lines = current.read_text().split()
    digest = lines[2] if len(lines) == 3 and lines[1] == "manifest-sha256" else None
    return bank / lines[0], digest


def main(bank: pathlib.Path) -> int:
    version, digest = resolve(bank)
    raw = (version / "manifest.json").read_bytes()
    if digest is not None and hashlib.sha256(raw).hexdigest() != digest:
        print(f"manifest sha256 differs from CURRENT's {digest}")
        return 1
    manifest = json.loads(raw)
    files = [str(version / f["name"]) for f in manifest["files"]]
    dataset = ds.dataset(files, format="parquet")
    table = dataset.to_table()
    names = table.column_names
    meta = json.loads(pq.ParquetFile(files[0]).metadata.metadata[b"wheelflat.bank"])
    sensors = meta["sensors"]
    expected = ["instance", "length_mm", "depth_mm", "curvature_mm", "impact_position_m", "l0_mm", "flat_wheel", "peak_contact_kn"]
    for s in sensors:
        width = max(4, len(str(s["samples"] - 1)))
        expected += [f"{s['name']}_t{k:0{width}d}" for k in range(s["samples"])]
    problems = []
    if names != expected:
        problems.append("column names differ from the metadata's sensors and samples")
    if table.num_rows != manifest["instances"] or meta["instances"] != manifest["instances"]:
        problems.append("row count differs from the manifest")
    instances = table.column("instance").to_pylist()
    if instances != list(range(table.num_rows)):
        problems.append("instance column is not 0..N-1")
    if set(table.column("flat_wheel").to_pylist()) - {0.0, 1.0}:
        problems.append("flat_wheel holds values other than 0 (leading) and 1 (trailing)")
    peaks = table.column("peak_contact_kn").to_pylist()
    if not all(p is not None and p > 0.0 and p < 1e4 for p in peaks):
        problems.append("peak_contact_kn holds a value that is not a positive force below 10,000 kN")
    if str(table.schema.field(names[8]).type) != "float":
        problems.append("sample columns are not float32")
    print(f"rows {table.num_rows}")
    print(f"columns {len(names)}")
    print(f"first sample column {names[8]}")
    print(f"metadata instances {meta['instances']} format {meta['format_version']} calibration {meta['calibration_sha256'][:12]}")
    print(f"sensors {[s['name'] for s in sensors]}")
    for p in problems:
        print(f"problem: {p}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(pathlib.Path(sys.argv[1])))
