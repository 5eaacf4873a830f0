"""The bank, read with pyarrow (src/bank/reader.rs, schema.rs, neighbours.rs).

`CURRENT` or a version directory, `manifest.json`, the shards memory-mapped, the
`wheelflat.bank` JSON of the first shard's footer (sensor axes, flat-free template, calibration
with the identification settings), the parameter columns and the stored neighbour graph
`neighbours.bin`. The peer reads every shard's footer through pyarrow; a `layout.bin` the bank
may carry (src/bank/layout.rs, the Rust reader's way around those footers) is not needed.
"""

import hashlib
import json
import math
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pyarrow.parquet as pq

from .errors import Failure
from .neighbours import NEIGHBOURS, cell_weights, neighbour_graph

PARAMETER_COLUMNS = ["length_mm", "depth_mm", "curvature_mm", "impact_position_m", "l0_mm", "flat_wheel", "peak_contact_kn"]
METADATA_KEY = b"wheelflat.bank"
NEIGHBOURS_MAGIC = b"WFNEIGH2"
EARLIER_NEIGHBOURS_MAGIC = b"WFNEIGH1"
FORMAT_VERSION = 3


def resolve_version(bank_dir):
    """`DIR/CURRENT`'s target, or `DIR` itself when it holds a manifest."""
    current = bank_dir / "CURRENT"
    if current.is_file():
        # The first line names the version; a second states the manifest's SHA-256.
        return bank_dir / current.read_text().split()[0]
    if (bank_dir / "manifest.json").is_file():
        return bank_dir
    raise Failure(f"{bank_dir} is not a wheelflat bank (no CURRENT file and no manifest.json)")


def sample_column(sensor, k, samples):
    """`rps2_t0137`: zero-padded to at least 4 digits (src/bank/schema.rs `sample_column`)."""
    width = max(len(str(max(samples - 1, 0))), 4)
    return f"{sensor}_t{k:0{width}d}"


class Bank:
    """An open bank: manifest, metadata, mapped shard files, parameters, neighbour graph."""

    def __init__(self, bank_dir, threads, watch):
        self.pool = ThreadPoolExecutor(max_workers=threads)
        version = resolve_version(bank_dir)
        self.version = version
        self.manifest = json.loads((version / "manifest.json").read_text())
        files = self.manifest["files"]
        if not files:
            raise Failure(f"{version / 'manifest.json'} lists no shard files")

        def open_file(f):
            path = version / f["name"]
            size = path.stat().st_size
            if size != f["bytes"]:
                raise Failure(f"{path}: {size} bytes, the manifest says {f['bytes']}")
            return pq.ParquetFile(path, memory_map=True)

        self.files = list(self.pool.map(open_file, files))
        self.rows = [f["rows"] for f in files]
        self.n = sum(self.rows)
        kv = self.files[0].metadata.metadata or {}
        if METADATA_KEY not in kv:
            raise Failure(f"{version / files[0]['name']}: no `wheelflat.bank` metadata")
        self.meta = json.loads(kv[METADATA_KEY])
        if self.meta["bank_id"] != self.manifest["bank_id"]:
            raise Failure(f"bank id {self.meta['bank_id']} does not match the manifest's")
        if self.meta["format_version"] != FORMAT_VERSION:
            raise Failure(f"bank format {self.meta['format_version']}; this script reads {FORMAT_VERSION}")
        # The other shards must name the same bank and format: a substring test on their
        # compact (serde_json) metadata instead of parsing 50 kB of JSON per shard.
        identity = (f'"bank_id":"{self.manifest["bank_id"]}"'.encode(), f'"format_version":{FORMAT_VERSION},'.encode())
        for f, pf in zip(files[1:], self.files[1:], strict=True):
            text = (pf.metadata.metadata or {}).get(METADATA_KEY, b"")
            if not all(key in text for key in identity):
                raise Failure(f"{version / f['name']}: belongs to another bank or format")
        self.axes = self.meta["sensors"]
        self.template = [np.asarray(t, dtype=np.float32) for t in self.meta["flat_free_kn"]]
        cal = self.meta["calibration"]
        self.population = cal["population"]
        self._fold_view(cal, version / files[0]["name"])
        watch.lap("open footers")
        self.params = self._read_parameters()
        watch.lap("read parameters")
        self.neighbours = self._read_neighbours()
        watch.lap("neighbour graph")

    def _fold_view(self, cal, path):
        """A folded bank (src/bank/fold.rs): its shards store N instances with X_p over one
        sleeper bay and the windows of the pads up to K sleepers before each sensor; it is read
        as N·(K+1) instances over the calibration's own sensors, instance k·N + i being stored
        instance i shifted by k whole bays."""
        self.n_stored = self.n
        self.fold = None
        self._presented = {}
        if not self.population.get("fold_to_one_bay"):
            return
        spacing = cal["track"]["sleeper_spacing_m"]
        self.revolution_m = 2.0 * math.pi * cal["vehicle"]["wheel_radius_m"]
        self.spacing_m = spacing
        shifts = math.ceil(self.revolution_m / spacing - 1e-9) - 1
        stored = self.axes
        pads = cal["sensors"]["pad"]
        self.fold = []
        for a, pad in enumerate(pads):
            if a >= len(stored) or (stored[a]["name"], stored[a]["sleeper"]) != (pad["name"], pad["sleeper"]):
                raise Failure(f"{path}: folded bank: stored axis {a} is not sensor `{pad['name']}`")
            per = []
            for k in range(shifts + 1):
                at = [i for i, x in enumerate(stored) if x["sleeper"] == pad["sleeper"] - k]
                if pad["sleeper"] < k or not at:
                    raise Failure(f"{path}: folded bank: no stored window {k} sleepers before `{pad['name']}`")
                per.append(at[0])
            self.fold.append(per)
        self.stored_axes = stored
        self.axes = stored[:len(pads)]
        self.template = self.template[:len(pads)]
        self.n = self.n_stored * (shifts + 1)

    def _read(self, columns):
        """`columns` for every instance, shard files in parallel: {name: array in row order}."""
        parts = list(self.pool.map(lambda f: f.read(columns=columns, use_threads=False), self.files))
        for part, rows in zip(parts, self.rows, strict=True):
            if part.num_rows != rows:
                raise Failure(f"a shard holds {part.num_rows} rows, the manifest says {rows}")
        return {c: np.concatenate([p.column(c).to_numpy() for p in parts]) for c in columns}

    def _read_parameters(self):
        p = self._read(["instance"] + PARAMETER_COLUMNS)
        p["flat_wheel"] = p["flat_wheel"].astype(np.uint8)
        if self.fold is not None:
            # Each shift's copy, X_p moved k bays on (back by a revolution past its end).
            factor = len(self.fold[0])
            x0 = self.population["impact_position_m"][0]
            xs = []
            for k in range(factor):
                x = p["impact_position_m"] + k * self.spacing_m
                xs.append(np.where(x >= x0 + self.revolution_m, x - self.revolution_m, x))
            p = {c: np.tile(v, factor) for c, v in p.items()}
            p["instance"] = np.arange(self.n, dtype=np.uint32)
            p["impact_position_m"] = np.concatenate(xs)
        return p

    def read_samples(self, columns):
        """Sample columns (names, of `column_name`) as one float32 matrix, one row per column,
        instance order; a folded bank's column is its stored columns at shifts 0..K in turn."""
        out = np.empty((len(columns), self.n), dtype=np.float32)
        offsets = np.concatenate([[0], np.cumsum(self.rows)])
        if self.fold is None:
            stored = [[c] for c in columns]
        else:
            stored = []
            for c in columns:
                axis, k = self._presented[c]
                stored.append([sample_column(self.stored_axes[s]["name"], k, self.stored_axes[s]["samples"])
                               for s in self.fold[axis]])
        names = sorted({c for per in stored for c in per})
        ns = self.n_stored

        def fill(i):
            table = self.files[i].read(columns=names, use_threads=False)
            if table.num_rows != self.rows[i]:
                raise Failure(f"shard {i} holds {table.num_rows} rows, the manifest says {self.rows[i]}")
            values = {c: table.column(c).to_numpy() for c in names}
            for j, per in enumerate(stored):
                for shift, c in enumerate(per):
                    out[j, shift * ns + offsets[i]:shift * ns + offsets[i + 1]] = values[c]

        list(self.pool.map(fill, range(len(self.files))))
        return out

    def _read_neighbours(self):
        """The stored graph (n × 8 int64), checked like src/bank/neighbours.rs `decode`."""
        aux = self.manifest.get("neighbours")
        if aux is None:
            print("note: the bank stores no neighbour graph; searching it (slow)", file=sys.stderr)
            return neighbour_graph(self.params, self.population)
        path = self.version / aux["name"]
        data = path.read_bytes()
        if len(data) != aux["bytes"] or hashlib.sha256(data).hexdigest() != aux["sha256"]:
            raise Failure(f"{path}: size or SHA-256 differs from the manifest")
        if data[:8] not in (NEIGHBOURS_MAGIC, EARLIER_NEIGHBOURS_MAGIC):
            raise Failure(f"{path}: not a wheelflat neighbour graph (bad magic)")
        n = int.from_bytes(data[8:16], "little")
        k = int.from_bytes(data[16:20], "little")
        id_len = int.from_bytes(data[20:24], "little")
        if data[24:24 + id_len].decode() != self.manifest["bank_id"] or n != self.n or k != NEIGHBOURS:
            raise Failure(f"{path}: belongs to another bank ({n} instances × {k})")
        start = 24 + id_len
        weights = (1.0, 1.0, 1.0, 1.0)
        if data[:8] == NEIGHBOURS_MAGIC:
            weights = tuple(float(w) for w in np.frombuffer(data, dtype="<f8", count=4, offset=start))
            start += 32
        graph = np.frombuffer(data, dtype="<u4", offset=start)
        if graph.size != n * k or (graph >= n).any():
            raise Failure(f"{path}: wrong size or an index outside the bank")
        if weights != cell_weights(self.population):
            # Searched in another metric (an earlier graph): search it as the Rust does at open.
            return neighbour_graph(self.params, self.population)
        return graph.reshape(n, k).astype(np.int64)

    def close(self):
        """Releases the shard files (pyarrow frees 20 wide footers here: tens of ms)."""
        self.pool.shutdown()
        self.files = []

    def column_name(self, axis, k):
        a = self.axes[axis]
        name = sample_column(a["name"], k, a["samples"])
        if self.fold is not None:
            self._presented[name] = (axis, k)
        return name
