"""Run a sweep file on a Dask cluster: the run table split into chunks, each chunk a
`master sweep SPEC --runs A..B` on a worker, the rows gathered into one Parquet file (and CSV).

    python -m suspension_sweep.sweep sweeps/mass_delay.json --local 2 --out results/sweep_dask
    python -m suspension_sweep.sweep sweeps/mass_delay.json --scheduler tcp://HOST:8786 --out DIR

Every run is deterministic and the run table depends on the sweep file alone, so the gathered
table equals `master sweep`'s on one machine row by row (every column but `loop_seconds`).

By default the master binary, the FMUs the sweep needs, the sweep file and its base scenario are
shipped to the workers: packed once into a tar archive, broadcast, and unpacked on each worker
into its temporary directory (keyed by the archive's SHA-256). `--shared` skips that when the
workers see the same paths as this machine (a shared file system).
"""

import argparse
import contextlib
import hashlib
import io
import json
import logging
import os
import pathlib
import re
import subprocess
import sys
import tarfile
import tempfile

import pyarrow as pa
import pyarrow.parquet as pq

ROOT = pathlib.Path(__file__).resolve().parents[2]


def run_count(master, dist, spec):
    """The run table's size, from `master sweep --dry-run`."""
    out = subprocess.run(
        [str(master), "--dist", str(dist), "sweep", str(spec), "--dry-run"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    m = re.search(r": (\d+) runs \(", out)
    if not m:
        raise RuntimeError(f"unexpected --dry-run output: {out!r}")
    return int(m.group(1))


def chunks(total, size):
    return [(a, min(a + size, total)) for a in range(0, total, size)]


def bundle(master, dist, spec):
    """A tar archive (bytes) of `master`, the FMUs the sweep uses, the sweep file (its base
    renamed `base.json`) and the base scenario."""
    spec = pathlib.Path(spec)
    sweep = json.loads(spec.read_text())
    base = spec.parent / sweep["base"]
    sweep["base"] = "base.json"
    fmus = ["road", "plant"] + [c for c in sweep["controllers"] if c != "passive"]
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w") as tar:

        def add_bytes(name, data, mode=0o644):
            info = tarfile.TarInfo(name)
            info.size = len(data)
            info.mode = mode
            tar.addfile(info, io.BytesIO(data))

        add_bytes("master", pathlib.Path(master).read_bytes(), 0o755)
        for f in fmus:
            add_bytes(f"dist/{f}.fmu", (pathlib.Path(dist) / f"{f}.fmu").read_bytes())
        add_bytes("sweep.json", json.dumps(sweep).encode())
        add_bytes("base.json", base.read_bytes())
    return buf.getvalue()


def unpack(archive):
    """Unpack a bundle once per machine; `(master, dist, spec)` paths in it."""
    digest = hashlib.sha256(archive).hexdigest()[:16]
    where = pathlib.Path(tempfile.gettempdir()) / f"suspension-sweep-{digest}"
    if not where.exists():
        staging = pathlib.Path(tempfile.mkdtemp(prefix=f"suspension-sweep-{digest}-"))
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            # Our own archive; the "data" filter where this Python has it (3.11.4+, backports).
            safe = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}
            tar.extractall(staging, **safe)
        (staging / "master").chmod(0o755)
        try:
            os.rename(staging, where)
        except OSError:  # another task on this machine was first
            pass
    return where / "master", where / "dist", where / "sweep.json"


def run_chunk(start, end, archive=None, shared=None):
    """`master sweep --runs start..end` on this worker: `(runs.parquet, runs.csv)` bytes."""
    master, dist, spec = unpack(archive) if archive is not None else shared
    with tempfile.TemporaryDirectory() as out:
        subprocess.run(
            [str(master), "--dist", str(dist), "sweep", str(spec), "--out", out,
             "--runs", f"{start}..{end}"],
            check=True,
            capture_output=True,
        )
        out = pathlib.Path(out)
        return (out / "runs.parquet").read_bytes(), (out / "runs.csv").read_bytes()


def gather(results, out):
    """Write the chunks' rows to `out/runs.parquet` and `out/runs.csv`. The chunks are
    consecutive ranges of the run table given in order, each in run order: concatenated, the
    rows are in run order."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    table = pa.concat_tables([pq.read_table(io.BytesIO(p), use_threads=False) for p, _ in results])
    pq.write_table(table, out / "runs.parquet")
    lines = []
    for k, (_, c) in enumerate(results):
        text = c.decode().splitlines(keepends=True)
        lines.extend(text if k == 0 else text[1:])
    (out / "runs.csv").write_text("".join(lines))
    return table


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m suspension_sweep.sweep", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("spec", help="the sweep file (README 'Robustness sweeps')")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--scheduler", help="address of a running Dask scheduler, tcp://HOST:8786")
    where.add_argument("--local", type=int, metavar="N", help="a LocalCluster of N workers")
    p.add_argument("--out", required=True, help="directory for runs.parquet and runs.csv")
    p.add_argument("--chunk", type=int, default=64, help="runs per task (default 64)")
    p.add_argument("--master", default=ROOT / "target" / "release" / "master")
    p.add_argument("--dist", default=ROOT / "dist", help="directory of the FMUs")
    p.add_argument("--shared", action="store_true",
                   help="the workers see --master, --dist and the sweep file at the same paths: ship nothing")
    a = p.parse_args(argv)
    if a.chunk < 1:
        p.error("--chunk must be >= 1")
    from dask.distributed import Client, LocalCluster

    total = run_count(a.master, a.dist, a.spec)
    parts = chunks(total, a.chunk)
    # The client closes before the cluster, and both before the results are written; the
    # cluster's shutdown warnings (a slow worker being killed) are silenced (see the end of this
    # file).
    with contextlib.ExitStack() as stack:
        if a.local:
            cluster = stack.enter_context(LocalCluster(
                n_workers=a.local, threads_per_worker=1, silence_logs=logging.ERROR))
        client = stack.enter_context(Client(cluster if a.local else a.scheduler))
        if a.shared:
            paths = (pathlib.Path(a.master).resolve(), pathlib.Path(a.dist).resolve(),
                     pathlib.Path(a.spec).resolve())
            futures = [client.submit(run_chunk, s, e, shared=paths, pure=False) for s, e in parts]
        else:
            archive = client.scatter(bundle(a.master, a.dist, a.spec), broadcast=True)
            futures = [client.submit(run_chunk, s, e, archive=archive, pure=False) for s, e in parts]
        results = client.gather(futures)
    table = gather(results, a.out)
    failed = sum(1 for s in table.column("status").to_pylist() if s != "ok")
    print(f"{table.num_rows} runs ({failed} failed) in {len(parts)} chunks; {pathlib.Path(a.out) / 'runs.parquet'}")


if __name__ == "__main__":
    code = main()
    # The work is done and every file closed. End here rather than through interpreter
    # finalisation, where threads of the libraries still alive abort the process after the
    # fact: a Dask daemon thread writing to stderr ("_enter_buffered_busy", dask/distributed#7617)
    # or an Arrow thread pool torn down under a running thread ("terminate called without an
    # active exception", apache/arrow#34314) — each seen once on a loaded machine, exit -6.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code or 0)
